"""Per-element Phong shading and light through n semi-transparent layers (3DSCA thesis App. B).

Generic on purpose: everything takes flat arrays of elements (grid cells, mesh faces or
vertices), so the 2.5D water plugin and the 3D surface plugin share one implementation.

Light through layers (digest section 5): with S_j = sum_{i<=j} t_i f(o_i), f(o) = o/(1-o),
layer 1 being the one the light meets first (the top),

    c = sum_j l_j (e^{-S_{j-1}} - e^{-S_j}) / (1 - e^{-S_n})

i.e. each layer's lit colour weighted by the share of light it absorbs.  The weights are
computed with expm1 so thin/transparent stacks stay accurate; when S_n -> 0 they tend to
t_j f(o_j) / S_n.
"""
from __future__ import annotations

import numpy as np

from .errors import InputError

__all__ = ["opacity_factor", "phong", "light_direction", "layer_weights", "through_layers",
           "through_layers_loop", "heightfield_normals"]

MAX_OPACITY = 0.999


def opacity_factor(opacity: np.ndarray | float) -> np.ndarray:
    """f(o) = o / (1 - o): 0 for a transparent layer, -> inf as o -> 1 (o clamped to 0.999)."""
    o = np.asarray(opacity, dtype=float)
    if np.any(~np.isfinite(o)) or np.any(o < 0) or np.any(o >= 1.0 + 1e-12):
        raise InputError("opacity must be in [0, 1)")
    o = np.minimum(o, MAX_OPACITY)
    return o / (1.0 - o)


def light_direction(azimuth_deg: float, elevation_deg: float) -> np.ndarray:
    """Unit vector pointing *towards* the light (azimuth from +x towards +y, elevation from the plane)."""
    az, el = np.radians(azimuth_deg), np.radians(elevation_deg)
    return np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])


def _unit(v: np.ndarray, what: str) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    n = np.linalg.norm(v, axis=-1, keepdims=True)
    if np.any(~np.isfinite(v)) or np.any(n == 0):
        raise InputError(f"{what} must be finite non-zero vectors")
    return v / n


def phong(normals: np.ndarray, color: np.ndarray, *, light: np.ndarray,
          eye: np.ndarray = (0.0, 0.0, 1.0), ambient: np.ndarray | float = 0.25,
          diffuse: np.ndarray | float = 0.7, specular: np.ndarray | float = 0.1,
          exponent: np.ndarray | float = 10.0, specular_color: np.ndarray | None = None,
          light_color: np.ndarray | float = 1.0) -> np.ndarray:
    """Lit colour per element: (ka + kd max(L.N, 0)) C_m + ks max(R.E, 0)^n C_s.

    normals (..., 3); color (3,) or (..., 3); light/eye: unit-able (3,) or (..., 3) vectors
    pointing from the element to the light/eye.  The thesis formula multiplies the specular
    term by the material colour (``specular_color=None``); pass white for plastic highlights.
    Coefficients broadcast against the element shape.  Not clipped: callers combine then clip.
    """
    n = _unit(normals, "normals")
    lv = _unit(np.broadcast_to(np.asarray(light, dtype=float), n.shape), "light direction")
    ev = _unit(np.broadcast_to(np.asarray(eye, dtype=float), n.shape), "eye direction")
    ndl = np.sum(n * lv, axis=-1)
    r = 2.0 * ndl[..., None] * n - lv                      # reflection of L about N
    rde = np.clip(np.sum(r * ev, axis=-1), 0.0, None)
    lit = ndl > 0
    ka, kd, ks, ex = (np.asarray(v, dtype=float) for v in (ambient, diffuse, specular, exponent))
    spec = np.where(lit, ks * rde ** ex, 0.0)
    diff = kd * np.clip(ndl, 0.0, None)
    c = np.asarray(color, dtype=float)
    cs = c if specular_color is None else np.asarray(specular_color, dtype=float)
    out = (ka + diff)[..., None] * c + spec[..., None] * cs
    return out * np.asarray(light_color, dtype=float)


def layer_weights(thickness: np.ndarray, opacity: np.ndarray) -> np.ndarray:
    """Share of the light absorbed by each layer, (..., n) summing to 1 (0 where S_n = 0).

    thickness (..., n) >= 0, top layer first; opacity (n,) or (..., n) in [0, 1).
    """
    t = np.asarray(thickness, dtype=float)
    if np.any(~np.isfinite(t)) or np.any(t < 0):
        raise InputError("layer thickness must be finite and >= 0")
    x = t * opacity_factor(opacity)                       # optical depth of each layer
    s = np.cumsum(x, axis=-1)
    s_prev = s - x
    total = s[..., -1:]
    # e^{-S_{j-1}} - e^{-S_j} = e^{-S_{j-1}} (1 - e^{-x_j}) = -e^{-S_{j-1}} expm1(-x_j)
    num = -np.exp(-s_prev) * np.expm1(-x)
    den = -np.expm1(-total)
    with np.errstate(invalid="ignore", divide="ignore"):
        w = np.where(den > 0, num / np.where(den > 0, den, 1.0), 0.0)
    return w


def through_layers(lit_colors: np.ndarray, thickness: np.ndarray, opacity: np.ndarray,
                   empty: np.ndarray | float = 0.0) -> np.ndarray:
    """Colour seen through n layers: sum_j w_j l_j (digest section 5), top layer first.

    lit_colors (..., n, 3) (each layer already lit, e.g. by :func:`phong`); thickness (..., n);
    opacity (n,) or (..., n).  Elements whose stack has no optical depth at all (every layer
    empty or fully transparent) get ``empty`` (e.g. a background colour for holes).
    """
    lc = np.asarray(lit_colors, dtype=float)
    t = np.asarray(thickness, dtype=float)
    if lc.shape[:-1] != t.shape or lc.shape[-1] != 3:
        raise InputError(f"through_layers: lit colours {lc.shape} must be thickness shape {t.shape} + (3,)")
    w = layer_weights(t, opacity)
    c = np.einsum("...n,...nc->...c", w, lc)
    has = np.sum(w, axis=-1) > 0
    return np.where(has[..., None], c, np.broadcast_to(np.asarray(empty, dtype=float), c.shape))


def through_layers_loop(lit_colors: np.ndarray, thickness: np.ndarray, opacity: np.ndarray) -> np.ndarray:
    """The thesis's single-loop algorithm (App. B 1.3) for one element; a reference for tests.

    lit_colors (n, 3), thickness (n,), opacity (n,); top layer first.
    """
    lc = np.asarray(lit_colors, dtype=float)
    t = np.asarray(thickness, dtype=float)
    f = opacity_factor(opacity)
    n = len(t)
    c = np.zeros(3)
    k = 0.0
    for j in range(n - 1):
        k += t[j] * f[j]
        c += np.exp(-k) * (lc[j + 1] - lc[j])
    big_l = -(k + t[n - 1] * f[n - 1])
    c += lc[0] - lc[n - 1] * np.exp(big_l)
    return c / (1.0 - np.exp(big_l))


def heightfield_normals(height: np.ndarray, spacing: float = 1.0) -> np.ndarray:
    """Unit normals (..., 3) of a height field z(y, x) on a regular grid (central differences)."""
    h = np.asarray(height, dtype=float)
    if h.ndim < 2 or h.shape[0] < 2 or h.shape[1] < 2:
        raise InputError(f"heightfield_normals: need a (ny >= 2, nx >= 2) array, got {h.shape}")
    gy, gx = np.gradient(h, spacing, axis=(0, 1))
    n = np.stack([-gx, -gy, np.ones_like(h)], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)
