"""Corrosion / patina as a strategic attack-defence CA (thesis ch. 2.4 and 4.2, Appendix A).

One kernel on every cell domain (the ``layers.corrode`` rule): a raster's 8-neighbour graph
(2.5-D surfaces, with an optional downhill tilt per neighbour entry) or the cross-edge graph of
a mesh's surface cells; covered layers are blocked.

States: NORMAL (0), CORRODED (1), HOLE (2, the thesis's NO_MORE_CELL).  Per synchronous step:

1. new seeds: Binomial(n, seed_rate) weak normal cells, until ``max_seeds`` in total;
2. every corroded cell attacks n_a = f1(age) = clamp(1 + age // age_step, 1, min(n_VC, 7)) of its
   n_VC valid (normal) neighbours, drawn without replacement with weights from a 3x3 Gaussian
   matrix over the 8 directions;
3. an attack succeeds when  a0 + a1*age + a2*(corroded neighbours of the attacker) + noise*U
   > b0 + b1*(strong neighbours of the defender) + strong_bonus*[defender is strong]   (f2);
4. every cell corroded at the start of the step loses k1 of consumable thickness (top layer
   first), gains k2 of product (oxide) capped at k3, and ages by one; it becomes a HOLE exactly
   when its consumable thickness reaches <= 0.  If the state keeps a ``ledger``, the step adds
   each such cell's change of solid, (consumable + product) * area, to it there: the cells it
   thins are the only ones whose solid changes, so a caller needs no pass of its own for it.

The age function A is the step count since corrosion, i.e. proportional to the oxide thickness
until the k3 cap (thesis: "A proportional to oxide thickness").
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from procgen.accel import MIN_CELLS, kernels
from procgen.ca.graph import MOORE, CellGraph, weighted_top_k

if TYPE_CHECKING:
    from .rules import Corrode

NORMAL, CORRODED, HOLE = 0, 1, 2


def gaussian_matrix(sigma: float) -> np.ndarray:
    """3x3 direction weights exp(-(di^2 + dj^2) / (2 sigma^2)), centre 0."""
    d = np.arange(-1, 2)
    w = np.exp(-(d[None, :] ** 2 + d[:, None] ** 2) / (2.0 * sigma ** 2))
    w[1, 1] = 0.0
    return w


def direction_weights(gaussian: np.ndarray) -> np.ndarray:
    """Weight of each Moore slot (di, dj), read from the 3x3 matrix [dj + 1, di + 1]."""
    g = np.asarray(gaussian, dtype=float)
    return g[MOORE[:, 1] + 1, MOORE[:, 0] + 1]


@dataclass
class CorrosionState:
    """Per-cell arrays of the model (mutated by :func:`corrosion_step`)."""

    status: np.ndarray        # int8 NORMAL / CORRODED / HOLE
    consumable: np.ndarray    # (n, Lc) thickness of the consumed layers, bottom first
    product: np.ndarray       # (n,) oxide / patina / char thickness
    age: np.ndarray           # (n,) int32 steps since corrosion
    strong: np.ndarray        # (n,) bool
    seeds_used: int = 0
    attacks: np.ndarray | None = None   # (n,) attacks made by each cell in the last step
    valid_neighbours: np.ndarray | None = None  # (n,) n_VC of each cell in the last step
    ledger: np.ndarray | None = None    # (n,) float, cumulative solid change per cell (None: not kept)
    area: np.ndarray | None = None      # (n,) cell areas weighting the ledger


@dataclass
class StepStats:
    """What one step did (for ledgers, reports and the tests' invariants)."""

    changed: int = 0
    new_seeds: int = 0
    seed_cells: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    newly_corroded: int = 0
    #: the cells that corroded in this step, each once (numpy: in cell order; compiled: in the
    #: order they are settled, seeds first), so a caller can date them without a pass of its own
    newly_cells: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    new_holes: int = 0
    attacks: int = 0
    max_attacks_per_cell: int = 0
    max_allowed_violation: int = 0   # cells that attacked more than min(n_VC, max_attacks): must be 0


def corrosion_step(graph: CellGraph, st: CorrosionState, prm: "Corrode", rng: np.random.Generator,
                   *, weights: np.ndarray, edge_logw: np.ndarray | None = None,
                   blocked: np.ndarray | None = None, accelerate: bool | None = None) -> StepStats:
    """One synchronous step of every cell; ``st`` is updated in place.

    ``prm`` is the ``layers.corrode`` rule: its parameters are the model's numbers (declared
    once, there).  ``weights``: the Gaussian weight of each Moore slot (:func:`direction_weights`).

    ``edge_logw``: extra log-weight per CSR entry added to the Gaussian direction weight (the
    2.5-D surface tilts attacks downhill). ``blocked``: normal cells that can be neither attacked
    nor seeded (metal under another layer). A normal cell with no consumable left is blocked too.
    ``accelerate``: the numba kernel of procgen_layers.corrosion_kernels (same result), see
    procgen.accel.
    """
    kern = kernels("procgen_layers.corrosion_kernels", accelerate, graph.n_cells, MIN_CELLS)
    if kern is not None:
        return kern.corrosion_step(graph, st, prm, rng, weights=weights, edge_logw=edge_logw, blocked=blocked)
    n = graph.n_cells
    out = StepStats()
    status0 = st.status.copy()
    corroded = status0 == CORRODED
    normal = status0 == NORMAL
    open_ = normal & (st.consumable.sum(axis=1) > 0)
    if blocked is not None:
        open_ &= ~np.asarray(blocked, bool)
    # 1. new seeds on weak open cells
    new_corroded = np.zeros(n, bool)
    room = prm.max_seeds - st.seeds_used
    if room > 0 and prm.seed_rate > 0:
        pool = np.nonzero(open_ & ~st.strong)[0]
        want = int(rng.binomial(n, prm.seed_rate)) if prm.seeding == "binomial" else int(np.floor(prm.seed_rate * n))
        k = min(want, room, len(pool))
        if k > 0:
            out.seed_cells = rng.choice(pool, k, replace=False)
            new_corroded[out.seed_cells] = True
            st.seeds_used += k
            out.new_seeds = k
    # 2-3. attacks from corroded cells that still touch an open cell (the front)
    st.attacks = np.zeros(n, np.int64)
    st.valid_neighbours = np.zeros(n, np.int64)
    front = np.nonzero(corroded & (graph.matrix @ open_.astype(float) > 0))[0]
    if len(front):
        e = graph.entries_of(front)
        tgt = graph.indices[e]
        rows = np.repeat(np.arange(len(front)), graph.degree[front])     # local row ids
        valid = open_[tgt]
        n_vc = np.bincount(rows, weights=valid, minlength=len(front)).astype(np.int64)
        f1 = np.clip(1 + (st.age[front] // prm.age_step).astype(np.int64), 1, prm.max_attacks)
        n_a = np.minimum(f1, n_vc)
        w = weights[graph.direction[e]]
        if edge_logw is not None:
            w = w * np.exp(np.asarray(edge_logw, dtype=float)[e])
        chosen = weighted_top_k(rows, np.where(valid, w, 0.0), n_a, rng)
        per = np.bincount(rows[chosen], minlength=len(front))
        st.attacks[front] = per
        st.valid_neighbours[front] = n_vc
        out.attacks, out.max_attacks_per_cell = int(per.sum()), int(per.max(initial=0))
        out.max_allowed_violation = int(np.sum(per > np.minimum(n_vc, prm.max_attacks)))
        helpers = np.bincount(rows, weights=corroded[tgt], minlength=len(front))
        a_rows, a_tgt = rows[chosen], tgt[chosen]
        targets, t_inv = np.unique(a_tgt, return_inverse=True)
        te = graph.entries_of(targets)
        t_rows = np.repeat(np.arange(len(targets)), graph.degree[targets])
        strong_normal = st.strong & normal
        strong_help = np.bincount(t_rows, weights=strong_normal[graph.indices[te]],
                                  minlength=len(targets))
        attacker = front[a_rows]
        attack = prm.a0 + prm.a1 * st.age[attacker] + prm.a2 * helpers[a_rows] \
            + prm.noise * rng.random(len(a_rows))
        defence = prm.b0 + prm.b1 * strong_help[t_inv] + prm.strong_bonus * st.strong[a_tgt]
        new_corroded[a_tgt[attack > defence]] = True
    # 4. corroded cells thin (top consumed layer first), oxidise (never above k3, never shrinking);
    #    worked on their rows (one gather, one scatter per array)
    thin = np.flatnonzero(corroded)
    if len(thin):
        c = st.consumable[thin]
        p = st.product[thin]
        before = layer_sum(c) if st.ledger is not None else None
        remove = np.full(len(c), prm.k1)
        for layer in range(c.shape[1] - 1, -1, -1):       # top layer first (few layers, not cells)
            take = np.minimum(c[:, layer], remove)
            c[:, layer] -= take
            remove -= take
        gone = c.sum(axis=1) <= 0
        c[gone] = 0.0
        st.consumable[thin] = c
        p1 = np.minimum(p + prm.k2, np.maximum(p, prm.k3))
        st.product[thin] = p1
        st.age[thin] += 1
        st.status[thin[gone]] = HOLE
        out.new_holes = int(np.count_nonzero(gone))
        if before is not None:
            delta = layer_sum(c)                          # (c1 - c0 + p1 - p0) * area, in place
            delta -= before
            delta += p1
            delta -= p
            delta *= st.area[thin]
            st.ledger[thin] += delta
    new_corroded &= open_
    out.newly_cells = np.flatnonzero(new_corroded)
    st.status[out.newly_cells] = CORRODED
    out.newly_corroded = len(out.newly_cells)
    out.changed = int(np.count_nonzero(st.status != status0))
    return out


def layer_sum(c: np.ndarray) -> np.ndarray:
    """(m,) sums of the (m, L) layer thicknesses, added bottom layer first: the compiled
    kernel's order for every L (numpy's own row sum is pairwise from 8 layers on)."""
    s = c[:, 0].copy()
    for layer in range(1, c.shape[1]):                # a few layers, not cells
        s += c[:, layer]
    return s


def strong_mask(n: int, fraction: float, rng: np.random.Generator,
                noise: np.ndarray | None = None) -> np.ndarray:
    """Exactly round(fraction * n) strong cells: at random, or the highest values of ``noise``."""
    k = int(round(fraction * n))
    mask = np.zeros(n, bool)
    if k <= 0:
        return mask
    if noise is None:
        mask[rng.choice(n, k, replace=False)] = True
    else:
        mask[np.argsort(-np.asarray(noise), kind="stable")[:k]] = True
    return mask
