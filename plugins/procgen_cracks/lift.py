"""Drawing the partial-peeling elevation in the crack textures (3DSCA thesis 5.3.3, Figure 5.30).

``cracks.peel`` lifts the unpeeled layer by t = T pc / (1 + pc) (``peel__lift``): the older a
cell's peeling level, i.e. the nearer to a crack, the higher the paint curls up.  The textures are
baked once for every view, so the relief is drawn as shading, not geometry:

* the lifted paint is a height field h = lift over the surface; its normal is n - grad h (the
  gradient taken in the tangent plane, over the links between lifted cells), so a flake's raised
  edge turns lighter on the side facing the light and darker on the other (Lambert's cosine
  change, ``relief`` exaggerates the slope);
* a cell left flat beside a lifted one (the crack it curls away from, or a peeled patch) lies in
  the flake's shadow: a darker rim, by h / (h + cell size) of the highest neighbour.

Lift 0 everywhere (or no ``peel__lift``) leaves every texel exactly as it was.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from procgen import InputError

LIFT = "peel__lift"


def lift_shading(sc: Any, *, light: tuple[float, ...], relief: float, rim: float) -> np.ndarray | None:
    """(n,) brightness factor per cell from ``peel__lift``; None when nothing is lifted."""
    lv = np.asarray(light, float)
    if lv.shape != (3,) or not np.linalg.norm(lv) > 0 or relief < 0 or not 0.0 <= rim <= 1.0:
        raise InputError(f"crack export: need a non-zero 3-vector light (towards the light), "
                         f"lift_relief >= 0 and lift_rim in [0, 1]; got {light}, {relief}, {rim}")
    if LIFT not in sc:
        return None
    lift = np.asarray(sc[LIFT], float)
    if not np.any(lift > 0):
        return None
    lv = lv / np.linalg.norm(lv)
    graph = sc.cell_graph("von_neumann")
    r, c = graph.rows, graph.indices
    pos = np.asarray(sc.center3d, float)
    normal = np.asarray(sc.normal, float)
    n_cells = len(lift)
    # tangent-plane gradient of the height over links between two lifted cells (least squares
    # on an isotropic neighbourhood: 2 sum dh d / sum |d|^2 is the central difference)
    both = (lift[r] > 0) & (lift[c] > 0)
    rr, cc = r[both], c[both]
    d = pos[cc] - pos[rr]
    d -= np.einsum("ij,ij->i", d, normal[rr])[:, None] * normal[rr]
    num = np.zeros((n_cells, 3))
    np.add.at(num, rr, (lift[cc] - lift[rr])[:, None] * d)
    den = np.bincount(rr, np.einsum("ij,ij->i", d, d), minlength=n_cells)
    grad = np.where(den[:, None] > 0, 2.0 * num / np.where(den > 0, den, 1.0)[:, None], 0.0)
    tilted = normal - relief * grad
    tilted /= np.linalg.norm(tilted, axis=1, keepdims=True)
    factor = 1.0 + np.clip(tilted @ lv, 0.0, None) - np.clip(normal @ lv, 0.0, None)
    # the rim: flat cells in the shadow of a lifted neighbour
    over = np.zeros(n_cells)
    np.maximum.at(over, r, lift[c])
    flat = lift <= 0
    factor[flat] *= 1.0 - rim * over[flat] / (over[flat] + float(sc.size))
    return factor
