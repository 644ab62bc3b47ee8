"""Shared helper of the cellular-network tests (seed 002)."""
from __future__ import annotations

import numpy as np

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
