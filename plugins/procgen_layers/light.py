"""Light through a stack of semi-transparent layers (3DSCA thesis 2.5 and App. B).

Each layer's material colour is lit first (Phong, :func:`procgen.lighting.phong`, with that
layer's own top-surface normal), then the lit colours are combined with the share of light each
layer absorbs.  With S_j = sum_{i<=j} t_i f(o_i), f(o) = o/(1-o), layer 1 being the one the
light meets first (the top), App. B 1.2 gives

    c = sum_j l_j (e^{-S_{j-1}} - e^{-S_j}) / (1 - e^{-S_n})

The weights are computed with expm1 so thin/transparent stacks stay accurate; when S_n -> 0
they tend to t_j f(o_j) / S_n.  Order matters (the thesis stresses it for shiny metal under a
thin patina): light first, combine second.  Every function takes flat arrays of elements (grid
cells, mesh cells), so the 2.5-D and the mesh recipes share this one implementation.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from procgen.errors import InputError
from procgen.lighting import phong

from .materials import Material, MaterialTable

__all__ = ["opacity_factor", "layer_weights", "through_layers", "through_layers_loop", "lit_layers",
           "shade_stack", "scale_opacity", "MAX_OPACITY"]

#: opacity is clamped below this for the f(o) = o/(1-o) law (an opaque layer would be infinite)
MAX_OPACITY = 0.999


def opacity_factor(opacity: np.ndarray | float) -> np.ndarray:
    """f(o) = o / (1 - o): 0 for a transparent layer, -> inf as o -> 1 (o clamped to 0.999)."""
    o = np.asarray(opacity, dtype=float)
    if np.any(~np.isfinite(o)) or np.any(o < 0) or np.any(o >= 1.0 + 1e-12):
        raise InputError("opacity must be in [0, 1)")
    o = np.minimum(o, MAX_OPACITY)
    return o / (1.0 - o)


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
    """Colour seen through n layers: sum_j w_j l_j, top layer first.

    lit_colors (..., n, 3) (each layer already lit); thickness (..., n); opacity (n,) or
    (..., n).  Elements whose stack has no optical depth at all (every layer empty or fully
    transparent) get ``empty`` (e.g. a background colour for holes).
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


def lit_layers(normals: np.ndarray, table: MaterialTable, *, light: np.ndarray,
               eye: np.ndarray = (0.0, 0.0, 1.0), specular_color: np.ndarray | None = None,
               per_layer: bool = False, extra_lights: tuple[tuple[np.ndarray, float], ...] = ()) -> np.ndarray:
    """(..., L, 3) Phong colour of every layer, bottom first.

    normals: (..., 3) shared by every layer, or with ``per_layer`` (..., L, 3): one top-surface
    normal per layer (a 2.5-D stack whose layer tops differ).  ``extra_lights``: (direction,
    intensity) pairs whose diffuse and specular terms add to the main light's (the ambient term
    counts once): the two light sources of plate D-13(a).
    """
    col = table.array("color")
    n = np.asarray(normals, dtype=float)
    out = []
    for li, m in enumerate(table):                     # a handful of layers: one pass each
        nl = n[..., li, :] if per_layer else n
        c = phong(nl, col[li], light=light, eye=eye, ambient=m.ambient, diffuse=m.diffuse,
                  specular=m.specular, exponent=m.exponent, specular_color=specular_color)
        for direction, intensity in extra_lights:      # a few lights: one pass each
            c = c + phong(nl, col[li], light=direction, eye=eye, ambient=0.0, diffuse=m.diffuse,
                          specular=m.specular, exponent=m.exponent, specular_color=specular_color,
                          light_color=intensity)
        out.append(c)
    return np.stack(out, axis=-2)


def shade_stack(normals: np.ndarray, thickness: np.ndarray, table: MaterialTable, *, light: np.ndarray,
                eye: np.ndarray = (0.0, 0.0, 1.0), lit: bool = True, white_highlights: bool = False,
                per_layer: bool = False, held: np.ndarray | None = None, cell_area: float | np.ndarray = 1.0,
                wet_darkening: float = 0.0, film: np.ndarray | None = None,
                film_normals: np.ndarray | None = None, film_material: Material | None = None,
                hole: np.ndarray | None = None,
                background: tuple[float, float, float] = (0.0, 0.0, 0.0),
                extra_lights: tuple[tuple[np.ndarray, float], ...] = (), through: bool = True) -> np.ndarray:
    """RGB in [0, 1] (..., 3) of elements with a bottom-first stack ``thickness`` (..., L).

    Each layer is lit first (Phong, or its bare colour with ``lit=False``: the albedo a viewer
    lights later), then the layers are combined top-down by the share of light each absorbs.
    ``held`` (..., L): liquid held per layer; a layer darkens by ``wet_darkening`` times its
    saturation held / (capacity * thickness * cell_area) (the thesis's wet look, plate 2.4).
    ``film`` (...,): a liquid film of ``film_material`` on top (e.g. standing drops, plate 2.5),
    lit with ``film_normals`` and white highlights.  Elements with no optical depth, and
    ``hole`` ones, show ``background``.  ``through=False`` skips the light-through-layers model:
    each element shows its topmost non-empty layer, as the thesis's plate 2.1 was rendered.
    """
    t = np.asarray(thickness, dtype=float)
    if lit:
        lc = lit_layers(normals, table, light=light, eye=eye, per_layer=per_layer,
                        specular_color=np.ones(3) if white_highlights else None, extra_lights=extra_lights)
    else:
        col = table.array("color")
        lc = np.broadcast_to(col, t.shape + (3,))
    if held is not None and wet_darkening > 0:
        cap = table.array("capacity") * t * np.asarray(cell_area, dtype=float)[..., None]
        with np.errstate(invalid="ignore", divide="ignore"):
            sat = np.where(cap > 0, np.clip(held / np.where(cap > 0, cap, 1.0), 0, 1), 0.0)
        lc = lc * (1.0 - wet_darkening * sat)[..., None]
    opac = table.array("opacity")
    lit_td, t_td, o_td = lc[..., ::-1, :], t[..., ::-1], opac[::-1]        # top layer first
    if film is not None and np.any(film > 0):
        m = film_material
        wl = phong(film_normals, m.color, light=light, eye=eye, ambient=m.ambient, diffuse=m.diffuse,
                   specular=m.specular, exponent=m.exponent, specular_color=(1, 1, 1))
        lit_td = np.concatenate([wl[..., None, :], lit_td], axis=-2)
        t_td = np.concatenate([np.asarray(film, float)[..., None], t_td], axis=-1)
        o_td = np.concatenate([[m.opacity], o_td])
    if through:
        c = through_layers(lit_td, t_td, o_td, empty=np.asarray(background, float))
    else:
        present = t_td > 0
        top = np.argmax(present, axis=-1)[..., None, None]
        c = np.take_along_axis(lit_td, top, axis=-2)[..., 0, :]
        c = np.where(present.any(axis=-1)[..., None], c, np.asarray(background, float))
    if hole is not None:
        c[hole] = background
    return np.clip(c, 0.0, 1.0)


def scale_opacity(table: MaterialTable, factor: float) -> MaterialTable:
    """The table with every layer's f(o) multiplied by ``factor`` (plate 2.3: rising opacity)."""
    mats = []
    for m in table:
        f = opacity_factor(m.opacity) * factor
        mats.append(replace(m, opacity=float(min(f / (1 + f), MAX_OPACITY))))
    return MaterialTable(tuple(mats))
