"""Colour map of the multi-layer surface: Phong per layer, then light through the layers.

Order matters (thesis 2.5): each layer's material colour is lit first with that layer's own top
surface normal, then the lit colours are combined top-down by the n-layer formula.  Held water
darkens a layer (wet look, plate 2.4); standing drops can be shown as a water layer on top
(plate 2.5).  Holes (no layer left) show the background colour.
"""
from __future__ import annotations

import numpy as np

from procgen.lighting import heightfield_normals, light_direction, phong
from procgen_layers.light import lit_layers, through_layers
from procgen_layers.materials import PRESETS, Material, MaterialTable


def render_layers(base: np.ndarray, thickness: np.ndarray, table: MaterialTable, *, spacing: float = 1.0,
                  azimuth: float = 135.0, elevation: float = 50.0, held: np.ndarray | None = None,
                  wet_darkening: float = 0.45, water_depth: np.ndarray | None = None,
                  water: Material = PRESETS["water"], hole: np.ndarray | None = None,
                  background: tuple[float, float, float] = (0.05, 0.05, 0.08),
                  z_scale: float = 1.0, base_relief: float = 1.0) -> np.ndarray:
    """RGB in [0, 1], shape (ny, nx, 3).  thickness/held are (ny, nx, L), bottom layer first.

    ``base_relief`` scales the substrate in the shading only (0 shades a tilted plate as if it
    faced the viewer, as the thesis's top views do); ``z_scale`` exaggerates the layer relief.
    """
    t = np.asarray(thickness, dtype=float)
    ny, nx, L = t.shape
    light = light_direction(azimuth, elevation)
    tops = base_relief * base[..., None] + np.cumsum(t, axis=-1)
    normals = np.stack([heightfield_normals(z_scale * tops[..., l], spacing) for l in range(L)], axis=-2)
    lit = lit_layers(normals, table, light=light, per_layer=True)
    if held is not None and wet_darkening > 0:
        cap = table.array("capacity")[None, None, :] * t * spacing * spacing
        with np.errstate(invalid="ignore", divide="ignore"):
            sat = np.where(cap > 0, np.clip(held / np.where(cap > 0, cap, 1.0), 0, 1), 0.0)
        lit *= (1.0 - wet_darkening * sat)[..., None]
    opac = table.array("opacity")
    # top layer first for the light
    lit_td, t_td, o_td = lit[:, :, ::-1], t[:, :, ::-1], opac[::-1]
    if water_depth is not None and np.any(water_depth > 0):
        n = heightfield_normals(z_scale * (tops[..., -1] + water_depth), spacing)
        wl = phong(n, water.color, light=light, ambient=water.ambient, diffuse=water.diffuse,
                   specular=water.specular, exponent=water.exponent, specular_color=(1, 1, 1))
        lit_td = np.concatenate([wl[:, :, None], lit_td], axis=2)
        t_td = np.concatenate([np.asarray(water_depth, float)[..., None], t_td], axis=2)
        o_td = np.concatenate([[water.opacity], o_td])
    c = through_layers(lit_td, t_td, o_td, empty=np.asarray(background, float))
    if hole is not None:
        c[hole] = background
    return np.clip(c, 0.0, 1.0)


def water_depth_map(shape: tuple[int, int], pos: np.ndarray, volume: np.ndarray, spacing: float,
                    gain: float = 1.0) -> np.ndarray:
    """Drop volume splatted per cell as a water depth (volume / cell area * gain)."""
    ny, nx = shape
    if len(volume) == 0:
        return np.zeros(shape)
    ix = np.clip(np.floor(pos[:, 0]).astype(np.int64), 0, nx - 1)
    iy = np.clip(np.floor(pos[:, 1]).astype(np.int64), 0, ny - 1)
    d = np.bincount(iy * nx + ix, weights=volume, minlength=ny * nx) / (spacing * spacing)
    return gain * d.reshape(shape)
