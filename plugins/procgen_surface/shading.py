"""Cell colours: Phong per layer, then light through the layers (thesis 3.4, 4.2.3.b, App. B).

The order matters (the thesis stresses it for shiny metal under a thin patina): every layer's
material colour is lit first, then the lit colours are combined with the absorbed-light
weights of :func:`procgen.lighting.through_layers` (shared with the 2.5D plugin).
"""
from __future__ import annotations

import numpy as np

from procgen.errors import InputError
from procgen.lighting import phong, through_layers
from procgen.materials import MaterialTable


def shade_cells(normals: np.ndarray, thickness: np.ndarray, table: MaterialTable, *,
                light: np.ndarray | None = None, eye: np.ndarray | None = None,
                lit: bool = True, empty: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> np.ndarray:
    """(n, 3) colour per cell from its layer stack ``thickness`` (n, L), bottom layer first.

    ``lit=False`` gives the albedo seen through the layers (for texture baking: the viewer
    lights the mesh); ``lit=True`` applies Phong per layer with ``light``/``eye`` directions.
    """
    t = np.asarray(thickness, dtype=float)
    if t.ndim != 2 or t.shape[1] != len(table):
        raise InputError(f"shade: thickness has {t.shape[-1]} layers but the material table has "
                         f"{len(table)}")
    col = table.array("color")                                   # (L, 3) bottom first
    if lit:
        if light is None or eye is None:
            raise InputError("shade: lit shading needs light and eye directions")
        per = [phong(normals, col[l], light=light, eye=eye, ambient=table[l].ambient,
                     diffuse=table[l].diffuse, specular=table[l].specular,
                     exponent=table[l].exponent, specular_color=np.ones(3))
               for l in range(len(table))]                       # one pass per layer
        lc = np.stack(per, axis=1)
    else:
        lc = np.broadcast_to(col, (len(t),) + col.shape)
    top_first = slice(None, None, -1)
    rgb = through_layers(lc[:, top_first], t[:, top_first], table.array("opacity")[top_first],
                         empty=np.asarray(empty, float))
    return np.clip(rgb, 0.0, 1.0)


def label_colors(labels: np.ndarray, seed: int = 0) -> np.ndarray:
    """Distinct pastel colours per integer label (0 = unlabelled -> grey)."""
    rng = np.random.default_rng(seed)
    k = int(labels.max()) + 1 if len(labels) else 1
    hues = (np.arange(k) * 0.618033988749895 + rng.random()) % 1.0
    import colorsys
    pal = np.array([colorsys.hsv_to_rgb(h, 0.55, 0.95) for h in hues])
    pal[0] = (0.6, 0.6, 0.6)
    return pal[np.clip(labels, 0, None)]
