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


def random_young_state(net: CellNetwork, seed: int):
    """A State holding ``net`` with random go/receive states and a random half alive, for checking
    ``cellnet.young`` against its equation: returns (state, states, alive)."""
    from procgen import State
    from procgen_cellnet.states import ACTIVE, INFLUENCING, RECEIVING, SLEEPING, put_states

    rng = np.random.default_rng(seed)
    gs = rng.choice([SLEEPING, RECEIVING, INFLUENCING, ACTIVE], net.n_cells, p=[0.1, 0.2, 0.2, 0.5]).astype(np.int8)
    put_states(net, gs)
    alive = rng.random(net.n_cells) < 0.5
    net.add_field("ca__alive", alive, at="cell")
    state = State(seed=1)
    state.add_domain("cells", net)
    return state, gs, alive


def young_field(net: CellNetwork, gs: np.ndarray, alive: np.ndarray, h: float, j1: float, j2: float,
                r1: float, r2: float) -> np.ndarray:
    """h + J1 sum_{r_ij < R1} p_j + J2 sum_{R1 <= r_ij < R2} p_j over sending cells, from all distances."""
    from procgen_cellnet.states import sends

    d = np.linalg.norm(net.positions[:, None] - net.positions[None], axis=2)
    s = (alive & sends(gs)).astype(float)
    return h + j1 * ((d < r1) * s).sum(axis=1) + j2 * (((d >= r1) & (d < r2)) * s).sum(axis=1)
