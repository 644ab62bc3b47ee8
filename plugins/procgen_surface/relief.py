"""Relief: a per-cell height over the surface, drawn by the mesh exporters.

Any rule may leave a cell field (units ``length``) saying how far each cell's outer surface
stands off along its normal, on top of the stacked layer thickness: paint curling up before it
peels (3DSCA thesis 5.3.3, Figure 5.30), a blister, an embossing.  The exporters take the field's
name as their ``relief`` option and draw it three ways, so that every output shows the same
object:

* geometry: the exported vertices move along the rounded-facet normal by ``relief_scale`` times
  the field (OBJ/GLB, and the preview's silhouette);
* slope shading (lit previews and baked textures): the field is a height field h over the
  surface; the normal becomes n - grad h (the gradient in the tangent plane, over links between
  raised cells), so a raised edge turns lighter towards the light and darker away from it;
* a rim: a cell left flat beside a raised one lies in its shadow, darker by
  rim * h / (h + cell size) of its highest neighbour (view-independent, baked into textures).

A relief of 0 everywhere changes nothing.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from procgen import InputError


def relief_values(sc: Any, field: str, fmt: str) -> np.ndarray | None:
    """(n,) relief heights from cell field ``field`` ('' = none); one-line errors on bad input."""
    if field == "":
        return None
    if field not in sc:
        raise InputError(f"{fmt}: relief field {field!r} is not a field of the cells")
    h = np.asarray(sc[field], float)
    if h.shape != (sc.n_cells,) or not np.all(np.isfinite(h)):
        raise InputError(f"{fmt}: relief field {field!r} must be one finite number per cell, "
                         f"got shape {h.shape}")
    return h


def check_relief_options(fmt: str, scale: float, rim: float, slope: float = 1.0) -> None:
    if not np.isfinite(scale) or scale < 0 or not 0.0 <= rim <= 1.0 or not slope >= 0:
        raise InputError(f"{fmt}: need relief_scale >= 0, relief_rim in [0, 1] and a slope "
                         f">= 0; got {scale}, {rim}, {slope}")


def rim_factor(sc: Any, h: np.ndarray, rim: float) -> np.ndarray:
    """(n,) darkening of flat cells beside raised ones (1 elsewhere)."""
    graph = sc.cell_graph("von_neumann")
    over = np.zeros(len(h))
    np.maximum.at(over, graph.rows, h[graph.indices])
    flat = h <= 0
    out = np.ones(len(h))
    out[flat] = 1.0 - rim * over[flat] / (over[flat] + float(sc.size))
    return out


def slope_factor(sc: Any, h: np.ndarray, light: np.ndarray, slope: float) -> np.ndarray:
    """(n,) brightness change of the raised cells whose normal tilts by the height's gradient.

    The gradient is a least-squares fit over the links between two raised cells (on an
    isotropic neighbourhood, 2 sum dh d / sum |d|^2 is the central difference); ``slope``
    exaggerates it.  Lambert's cosine change towards ``light`` (unit, towards the light).
    """
    graph = sc.cell_graph("von_neumann")
    r, c = graph.rows, graph.indices
    pos = np.asarray(sc.center3d, float)
    normal = np.asarray(sc.normal, float)
    n_cells = len(h)
    both = (h[r] > 0) & (h[c] > 0)
    rr, cc = r[both], c[both]
    d = pos[cc] - pos[rr]
    d -= np.einsum("ij,ij->i", d, normal[rr])[:, None] * normal[rr]
    num = np.zeros((n_cells, 3))
    np.add.at(num, rr, (h[cc] - h[rr])[:, None] * d)
    den = np.bincount(rr, np.einsum("ij,ij->i", d, d), minlength=n_cells)
    grad = np.where(den[:, None] > 0, 2.0 * num / np.where(den > 0, den, 1.0)[:, None], 0.0)
    tilted = normal - slope * grad
    tilted /= np.linalg.norm(tilted, axis=1, keepdims=True)
    return 1.0 + np.clip(tilted @ light, 0.0, None) - np.clip(normal @ light, 0.0, None)


def relief_shading(sc: Any, h: np.ndarray | None, *, light: Any | None, slope: float,
                   rim: float) -> np.ndarray | None:
    """(n,) brightness factor per cell: slope shading towards ``light`` (None: rim only) times
    the rim; None when nothing is raised."""
    if h is None or not np.any(h > 0):
        return None
    factor = rim_factor(sc, h, rim)
    if light is not None:
        lv = np.asarray(light, float)
        if lv.shape != (3,) or not np.linalg.norm(lv) > 0:
            raise InputError(f"relief: need a non-zero 3-vector light (towards the light), got {light}")
        factor *= slope_factor(sc, h, lv / np.linalg.norm(lv), slope)
    return factor
