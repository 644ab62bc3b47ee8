"""Phong illumination of surface normals and light directions (3DSCA thesis App. B 1.1).

A rendering mechanism, not a phenomenon: it lights any normals with any coefficients (the
layered-materials family combines it with light through its layers, previews light facets).
"""
from __future__ import annotations

import numpy as np

from .errors import InputError

__all__ = ["phong", "light_direction", "heightfield_normals"]


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


def heightfield_normals(height: np.ndarray, spacing: float = 1.0, periodic: bool = False) -> np.ndarray:
    """Unit normals (..., 3) of a height field z(y, x) on a regular grid: central differences,
    one-sided at the edges, or taken across them on a ``periodic`` (tileable) grid, so the
    lighting of a tile matches its neighbour's at the seam."""
    h = np.asarray(height, dtype=float)
    if h.ndim < 2 or h.shape[0] < 2 or h.shape[1] < 2:
        raise InputError(f"heightfield_normals: need a (ny >= 2, nx >= 2) array, got {h.shape}")
    if periodic:
        gx = (np.roll(h, -1, axis=1) - np.roll(h, 1, axis=1)) / (2.0 * spacing)
        gy = (np.roll(h, -1, axis=0) - np.roll(h, 1, axis=0)) / (2.0 * spacing)
    else:
        gy, gx = np.gradient(h, spacing, axis=(0, 1))
    n = np.stack([-gx, -gy, np.ones_like(h)], axis=-1)
    return n / np.linalg.norm(n, axis=-1, keepdims=True)
