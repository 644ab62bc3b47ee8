"""Compiled (numba) attack/defence corrosion step: ``corrosion.corrosion_step`` in loops.

Why: the numpy step builds per-entry arrays for the front, sorts them per row (weighted
sampling without replacement), takes a ``np.unique`` of the targets and several full-grid
temporaries per step; compiled loops visit each front entry a few times and write in place.
Imported only through :func:`procgen.accel.kernels` (this module needs numba).

Same results, exactly: the random numbers come from the same Generator calls in the same order
(binomial and ``choice`` for the seeds, one uniform per front entry for the weighted choice of
targets, one per attack for the noise), the Efraimidis-Spirakis keys log(u)/w and their ranking
(largest first, ties in entry order) are the numpy path's, and every float expression keeps its
order (tests/test_corrode_kernels.py compares whole runs).  Buffers live on the graph and are
reused: a step allocates nothing proportional to the domain (``attacks``/``valid_neighbours``
of the state are zeroed in place instead of replaced).  The per-cell passes (open cells,
thinning) run in parallel over numba's threads; each cell writes only its own slots, so the
result does not depend on the thread count.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from procgen.ca.graph import CellGraph

from .corrosion import CORRODED, HOLE, NORMAL, CorrosionState, StepStats

_ATTR = "_corrode_kernel_work"


class Work:
    """Per-graph buffers: cell masks and lists, per-entry random numbers and choices."""

    def __init__(self, graph: CellGraph) -> None:
        n, nnz = graph.n_cells, graph.indices.size
        self.status0 = np.empty(n, np.int8)
        self.open_ = np.empty(n, np.uint8)
        self.newc = np.zeros(n, np.uint8)
        self.front = np.empty(n, np.int64)
        self.helpers = np.empty(n)
        self.u = np.empty(nnz)
        self.noise = np.empty(nnz)
        self.chosen = np.empty(nnz, np.int64)      # chosen entry
        self.chosen_row = np.empty(nnz, np.int64)  # its front row
        self.key = np.empty(nnz)
        self.direction = graph.direction.astype(np.int64)


def corrosion_step(graph: CellGraph, st: CorrosionState, prm, rng: np.random.Generator, *,
                   weights: np.ndarray, edge_logw: np.ndarray | None = None,
                   blocked: np.ndarray | None = None) -> StepStats:
    """``corrosion.corrosion_step`` compiled (same arguments, same result)."""
    work = graph.__dict__.get(_ATTR)
    if work is None:
        work = graph.__dict__[_ATTR] = Work(graph)
    n = graph.n_cells
    out = StepStats()
    if st.attacks is None or st.attacks.shape != (n,) or st.attacks.dtype != np.int64:
        st.attacks = np.zeros(n, np.int64)
        st.valid_neighbours = np.zeros(n, np.int64)
    blk = np.zeros(0, bool) if blocked is None else np.asarray(blocked, bool)
    npool = _open_cells(st.status, st.consumable, st.strong, blk, work.status0, work.open_,
                        st.attacks, st.valid_neighbours)
    nfront, ne = _front(graph.indptr, graph.indices, work.status0, work.open_, work.front)
    seeds = np.zeros(0, np.int64)
    room = prm.max_seeds - st.seeds_used
    if room > 0 and prm.seed_rate > 0:
        want = int(rng.binomial(n, prm.seed_rate)) if prm.seeding == "binomial" else int(np.floor(prm.seed_rate * n))
        k = min(want, room, npool)
        if k > 0:
            idx = rng.choice(npool, k, replace=False)
            seeds = _pool_members(work.open_, st.strong, np.asarray(idx, np.int64))
            out.seed_cells = seeds
            st.seeds_used += k
            out.new_seeds = k
    nch = 0
    if nfront:
        rng.random(out=work.u[:ne])
        logw = np.zeros(0) if edge_logw is None else np.asarray(edge_logw, dtype=float)
        nch, tot, mx, viol = _choose(graph.indptr, graph.indices, work.direction, np.asarray(weights, float),
                                     logw, st.age, int(prm.age_step), int(prm.max_attacks), work.status0,
                                     work.open_, work.front, nfront, work.u, work.key, work.chosen,
                                     work.chosen_row, work.helpers, st.attacks, st.valid_neighbours)
        out.attacks, out.max_attacks_per_cell, out.max_allowed_violation = int(tot), int(mx), int(viol)
        rng.random(out=work.noise[:nch])
    holes, newly = _resolve(graph.indptr, graph.indices, work.status0, work.open_, work.newc, seeds,
                            work.front, work.chosen, work.chosen_row, nch, work.helpers, work.noise,
                            st.status, st.consumable, st.product, st.age, st.strong,
                            float(prm.a0), float(prm.a1), float(prm.a2), float(prm.noise), float(prm.b0),
                            float(prm.b1), float(prm.strong_bonus), float(prm.k1), float(prm.k2),
                            float(prm.k3))
    out.new_holes, out.newly_corroded, out.changed = int(holes), int(newly), int(holes + newly)
    return out


@njit(cache=True, nogil=True, inline="always")
def _has_metal(consumable, c):
    s = 0.0
    for l in range(consumable.shape[1]):
        s += consumable[c, l]
    return s


@njit(cache=True, nogil=True, parallel=True)
def _open_cells(status, consumable, strong, blocked, status0, open_, attacks, valid_nbrs):
    """status0, open_ (normal, metal left, not blocked), attacks = valid_nbrs = 0, in parallel
    over the cells; returns the size of the weak open pool."""
    npool = 0
    for c in prange(status.size):
        s = status[c]
        status0[c] = s
        o = s == NORMAL and _has_metal(consumable, c) > 0
        if blocked.size and blocked[c]:
            o = False
        open_[c] = o
        attacks[c] = 0
        valid_nbrs[c] = 0
        if o and not strong[c]:
            npool += 1
    return npool


@njit(cache=True, nogil=True)
def _front(indptr, indices, status0, open_, front):
    """The front (corroded cells touching an open cell, in cell order) and its entry count."""
    nfront = 0
    ne = 0
    for c in range(status0.size):
        if status0[c] != CORRODED:
            continue
        for j in range(indptr[c], indptr[c + 1]):
            if open_[indices[j]]:
                front[nfront] = c
                nfront += 1
                ne += indptr[c + 1] - indptr[c]
                break
    return nfront, ne


@njit(cache=True, nogil=True)
def _pool_members(open_, strong, idx):
    """The cells at positions idx of the weak open pool (np.nonzero order)."""
    order = np.argsort(idx)
    out = np.empty(idx.size, np.int64)
    k = 0
    seen = 0
    for c in range(open_.size):
        if open_[c] and not strong[c]:
            while k < idx.size and idx[order[k]] == seen:
                out[order[k]] = c
                k += 1
            seen += 1
            if k == idx.size:
                break
    return out


@njit(cache=True, nogil=True)
def _choose(indptr, indices, direction, weights, logw, age, age_step, max_attacks, status0, open_,
            front, nfront, u, key, chosen, chosen_row, helpers, attacks, valid_nbrs):
    """weighted_top_k per front cell: keys log(u)/w, the n_a largest (ties: entry order)."""
    e = 0
    nch = 0
    tot = 0
    mx = 0
    viol = 0
    for r in range(nfront):
        c = front[r]
        j0 = indptr[c]
        j1 = indptr[c + 1]
        n_vc = 0
        hp = 0.0
        for j in range(j0, j1):
            t = indices[j]
            if open_[t]:
                n_vc += 1
                w = weights[direction[j]]
                if logw.size:
                    w = w * math.exp(logw[j])
            else:
                w = 0.0
            key[e + j - j0] = math.log(u[e + j - j0]) / w if w > 0 else -math.inf
            if status0[t] == CORRODED:
                hp += 1.0
        helpers[r] = hp
        f1 = min(max(1 + age[c] // age_step, 1), max_attacks)
        n_a = min(f1, n_vc)
        per = 0
        for j in range(j0, j1):
            kj = key[e + j - j0]
            if not math.isfinite(kj):
                continue
            rank = 0
            for q in range(j0, j1):
                kq = key[e + q - j0]
                if kq > kj or (kq == kj and q < j):
                    rank += 1
            if rank < n_a:
                chosen[nch] = j
                chosen_row[nch] = r
                nch += 1
                per += 1
        attacks[c] = per
        valid_nbrs[c] = n_vc
        tot += per
        mx = max(mx, per)
        if per > min(n_vc, max_attacks):
            viol += 1
        e += j1 - j0
    return nch, tot, mx, viol


@njit(cache=True, nogil=True)
def _resolve(indptr, indices, status0, open_, newc, seeds, front, chosen, chosen_row, nch, helpers,
             noise, status, consumable, product, age, strong, a0, a1, a2, noise_amp, b0, b1,
             strong_bonus, k1, k2, k3):
    """Attacks against defences, then thinning / oxidation / holes, then the new corrosion."""
    for s in seeds:
        newc[s] = 1
    for i in range(nch):
        j = chosen[i]
        r = chosen_row[i]
        t = indices[j]
        attack = a0 + a1 * age[front[r]] + a2 * helpers[r] + noise_amp * noise[i]
        sh = 0.0
        for q in range(indptr[t], indptr[t + 1]):
            x = indices[q]
            if strong[x] and status0[x] == NORMAL:
                sh += 1.0
        defence = b0 + b1 * sh + strong_bonus * (1.0 if strong[t] else 0.0)
        if attack > defence:
            newc[t] = 1
    holes = _thin(status0, status, consumable, product, age, k1, k2, k3)
    newly = 0
    for s in seeds:
        newly += _settle(s, newc, open_, status)
    for i in range(nch):
        newly += _settle(indices[chosen[i]], newc, open_, status)
    return holes, newly


@njit(cache=True, nogil=True, parallel=True)
def _thin(status0, status, consumable, product, age, k1, k2, k3):
    """Cells corroded at the start of the step thin (top layer first), oxidise and age, in
    parallel over the cells (each touches only its own slots); returns the new holes."""
    holes = 0
    L = consumable.shape[1]
    for c in prange(status0.size):
        if status0[c] != CORRODED:
            continue
        remove = k1
        for l in range(L - 1, -1, -1):
            take = min(consumable[c, l], remove)
            consumable[c, l] -= take
            remove -= take
        p = product[c]
        product[c] = min(p + k2, max(p, k3))
        age[c] += 1
        if _has_metal(consumable, c) <= 0:
            for l in range(L):
                consumable[c, l] = 0.0
            status[c] = HOLE
            holes += 1
    return holes


@njit(cache=True, nogil=True, inline="always")
def _settle(c, newc, open_, status):
    """A marked cell corrodes if it was open; the mark is cleared (counted once)."""
    if newc[c]:
        newc[c] = 0
        if open_[c]:
            status[c] = CORRODED
            return 1
    return 0
