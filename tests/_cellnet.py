"""Shared helper of the cellular-network tests (seed 002)."""
from __future__ import annotations

import numpy as np

from procgen_cellnet.build import PYRAMID
from procgen_cellnet.network import CellNetwork


def permuted(net: CellNetwork, perm: np.ndarray) -> CellNetwork:
    """The same network with cell i of the result = cell perm[i] of ``net`` (fields follow)."""
    inv = np.argsort(perm)
    links = np.sort(inv[net.links], axis=1)
    out = CellNetwork(net.positions[perm], links[np.lexsort(links.T[::-1])], cs=net.cs,
                      grid=net.grid, radius=net.radius)
    for name in net.field_names():
        out.add_field(name, np.asarray(net[name])[perm], at="cell")
    return out


def pyramid_variants():
    """One square pyramid (base 4, apex (2, 2, 2)) as triangles, convex, concave+holed polygons."""
    A, B, C, D, E = [0, 0, 0], [4, 0, 0], [4, 4, 0], [0, 4, 0], [2, 2, 2]
    sides = PYRAMID[:4]
    tris = sides + [[[A, D, C]], [[A, C, B]]]
    convex = PYRAMID
    inner = [3, 0.6, 0.6]                         # a point inside side A-B-E
    concave = [[[A, B, E, inner]], [[A, inner, E]]] + sides[1:] + [
        [[A, D, [2, 4, 0], [2, 2, 0], [4, 2, 0], B]],                      # an L (concave)
        [[[2, 2, 0], [2, 4, 0], C, [4, 2, 0]], [[2.5, 2.5, 0], [3.5, 2.5, 0], [3.5, 3.5, 0], [2.5, 3.5, 0]]],
        [[[2.5, 2.5, 0], [3.5, 2.5, 0], [3.5, 3.5, 0], [2.5, 3.5, 0]]],   # the hole's filling
    ]
    return tris, convex, concave
