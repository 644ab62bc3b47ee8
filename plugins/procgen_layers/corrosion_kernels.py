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
of the state are zeroed in place, at the last front's cells, the only non-zero ones, instead
of replaced).

Parallel and deterministic: every pass runs over numba's threads with each cell, front row or
attack writing only its own slots, and every list keeps the numpy path's order: the front is
listed per chunk of cells into the chunk's own slice and joined in chunk order; the target
choice runs per front row, and the attack list is laid out by a prefix sum of the per-row
counts (front row, then entry order); attacks are judged in parallel (each reads the state at
the start of the step) and marked serially.  So the result does not depend on the thread
count.  Thinning (step 4) runs in the first pass, before the attacks: it touches only cells
corroded at the start, never open ones, and the attacks read a front cell's age as age - 1.
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
        self.eoff = np.empty(n + 1, np.int64)      # first entry of each front row (+ the end)
        self.coff = np.empty(n + 1, np.int64)      # first attack of each front row (+ the end)
        self.helpers = np.empty(n)
        self.u = np.empty(nnz)
        self.noise = np.empty(nnz)
        self.hit = np.empty(nnz, np.uint8)         # attack i succeeded
        self.chosen = np.empty(nnz, np.int64)      # chosen entry
        self.chosen_row = np.empty(nnz, np.int64)  # its front row
        self.key = np.empty(nnz)
        self.pick = np.empty(nnz, np.uint8)        # entry picked as a target
        self.nchunk = max(1, min(256, n // 4096))
        self.chunk_counts = np.empty(max(self.nchunk + 1, 2), np.int64)
        self.direction = graph.direction.astype(np.int64)
        self.cleared = None                         # (attacks, valid_neighbours) zero but the last front


def corrosion_step(graph: CellGraph, st: CorrosionState, prm, rng: np.random.Generator, *,
                   weights: np.ndarray, edge_logw: np.ndarray | None = None,
                   blocked: np.ndarray | None = None) -> StepStats:
    """``corrosion.corrosion_step`` compiled (same arguments, same result)."""
    work = graph.__dict__.get(_ATTR)
    if work is None:
        work = graph.__dict__[_ATTR] = Work(graph)
    n = graph.n_cells
    out = StepStats()
    if (work.cleared is None or work.cleared[0] is not st.attacks or work.cleared[1] is not st.valid_neighbours
            or st.attacks.shape != (n,) or st.attacks.dtype != np.int64):
        st.attacks = np.zeros(n, np.int64)          # new arrays: zero everywhere, no last front
        st.valid_neighbours = np.zeros(n, np.int64)
        work.nfront = 0
    else:                                           # only the last front's cells are non-zero
        _clear(work.front, work.nfront, st.attacks, st.valid_neighbours)
    work.cleared = (st.attacks, st.valid_neighbours)
    blk = np.zeros(0, bool) if blocked is None else np.asarray(blocked, bool)
    _open_cells(st.status, st.consumable, st.product, st.age, st.strong, blk, work.status0, work.open_,
                float(prm.k1), float(prm.k2), float(prm.k3), work.chunk_counts)
    npool, holes = int(work.chunk_counts[0]), int(work.chunk_counts[1])
    nfront, ne = _front(graph.indptr, graph.indices, work.status0, work.open_, work.front, work.eoff,
                        work.chunk_counts)
    work.nfront = nfront
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
        _choose(graph.indptr, graph.indices, work.direction, np.asarray(weights, float), logw, st.age,
                int(prm.age_step), int(prm.max_attacks), work.status0, work.open_, work.front, work.eoff,
                nfront, work.u, work.key, work.pick, work.helpers, st.attacks, st.valid_neighbours)
        nch, mx, viol = _list_attacks(graph.indptr, work.front, work.eoff, work.coff, nfront, work.pick,
                                      st.attacks, st.valid_neighbours, int(prm.max_attacks), work.chosen,
                                      work.chosen_row)
        out.attacks, out.max_attacks_per_cell, out.max_allowed_violation = nch, mx, viol
        rng.random(out=work.noise[:nch])
    _attacks(graph.indptr, graph.indices, work.status0, work.front, work.chosen, work.chosen_row, nch,
             work.helpers, work.noise, st.age, st.strong, work.hit, float(prm.a0), float(prm.a1),
             float(prm.a2), float(prm.noise), float(prm.b0), float(prm.b1), float(prm.strong_bonus))
    newly = _settle_all(graph.indices, seeds, work.chosen, work.hit, nch, work.newc, work.open_, st.status)
    out.new_holes, out.newly_corroded, out.changed = int(holes), int(newly), int(holes + newly)
    return out


@njit(cache=True, nogil=True, inline="always")
def _has_metal(consumable, c):
    s = 0.0
    for l in range(consumable.shape[1]):
        s += consumable[c, l]
    return s


@njit(cache=True, nogil=True)
def _clear(front, nfront, attacks, valid_nbrs):
    """Zero the attack counts of the last front (the only non-zero ones)."""
    for r in range(nfront):
        attacks[front[r]] = 0
        valid_nbrs[front[r]] = 0


@njit(cache=True, nogil=True, parallel=True)
def _open_cells(status, consumable, product, age, strong, blocked, status0, open_, k1, k2, k3, counts):
    """One pass over the cells, in parallel: status0, open_ (normal, metal left, not blocked),
    and step 4 for the cells corroded at the start: they thin (top layer first), oxidise, age
    and may become holes.  Thinning first is exact: it touches only corroded cells, which are
    never open, and a front cell's age is read later as age - 1.  counts[0] = the weak open
    pool, counts[1] = the new holes."""
    npool = 0
    holes = 0
    L = consumable.shape[1]
    for c in prange(status.size):
        s = status[c]
        status0[c] = s
        o = s == NORMAL and _has_metal(consumable, c) > 0
        if blocked.size and blocked[c]:
            o = False
        open_[c] = o
        if o and not strong[c]:
            npool += 1
        if s == CORRODED:
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
    counts[0] = npool
    counts[1] = holes


def _front(indptr, indices, status0, open_, front, eoff, counts):
    """The front (corroded cells touching an open cell, in cell order), its entry offsets
    eoff and entry count: each chunk of cells lists its front cells in its own slice of
    ``front`` (a chunk has no more front cells than cells), in parallel, then the slices are
    moved together in chunk order (the same list as a serial scan)."""
    _front_chunks(indptr, indices, status0, open_, front, counts)
    nfront = _gather_chunks(status0.size, front, counts)
    _entry_offsets(indptr, front, nfront, eoff)
    return nfront, int(eoff[nfront])


@njit(cache=True, nogil=True, parallel=True)
def _front_chunks(indptr, indices, status0, open_, front, counts):
    n = status0.size
    nb = counts.size - 1
    for b in prange(nb):
        r = b * n // nb
        for c in range(b * n // nb, (b + 1) * n // nb):
            if status0[c] == CORRODED:
                for j in range(indptr[c], indptr[c + 1]):
                    if open_[indices[j]]:
                        front[r] = c
                        r += 1
                        break
        counts[b] = r - b * n // nb


@njit(cache=True, nogil=True)
def _gather_chunks(n, front, counts):
    """Move each chunk's list (counts[b] cells from its first cell's slot) to the end of the
    previous ones; returns the front's length."""
    nb = counts.size - 1
    m = 0
    for b in range(nb):
        start = b * n // nb
        for i in range(counts[b]):
            front[m] = front[start + i]
            m += 1
    return m


@njit(cache=True, nogil=True)
def _entry_offsets(indptr, front, nfront, eoff):
    eoff[0] = 0
    for r in range(nfront):
        c = front[r]
        eoff[r + 1] = eoff[r] + indptr[c + 1] - indptr[c]


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


@njit(cache=True, nogil=True, parallel=True)
def _choose(indptr, indices, direction, weights, logw, age, age_step, max_attacks, status0, open_,
            front, eoff, nfront, u, key, pick, helpers, attacks, valid_nbrs):
    """weighted_top_k per front cell: keys log(u)/w, the n_a largest (ties: entry order) are
    picked (pick = 1), in parallel over the front rows (each row writes only its own entries
    and cell); attacks[c] = the row's count, valid_nbrs[c] = its open neighbours.  When n_a
    covers every finite key, all of them are picked without a logarithm: a key is finite iff
    w > 0 and u > 0 (u >= 2**-53 then, |log u| < 37) unless w < 1e-300, where it is computed."""
    for r in prange(nfront):
        c = front[r]
        j0 = indptr[c]
        j1 = indptr[c + 1]
        e = eoff[r] - j0
        n_vc = 0
        n_fin = 0
        hp = 0.0
        for j in range(j0, j1):                 # key[] holds the weight w first
            t = indices[j]
            w = 0.0
            if open_[t]:
                n_vc += 1
                w = weights[direction[j]]
                if logw.size:
                    w = w * math.exp(logw[j])
                if w > 0 and u[e + j] > 0 and (w >= 1e-300 or math.isfinite(math.log(u[e + j]) / w)):
                    n_fin += 1
                else:
                    w = 0.0
            key[e + j] = w
            if status0[t] == CORRODED:
                hp += 1.0
        helpers[r] = hp
        f1 = min(max(1 + (age[c] - 1) // age_step, 1), max_attacks)    # age before this step's +1
        n_a = min(f1, n_vc)
        if n_a >= n_fin:
            for j in range(j0, j1):
                pick[e + j] = key[e + j] > 0
            attacks[c] = n_fin
            valid_nbrs[c] = n_vc
            continue
        for j in range(j0, j1):
            w = key[e + j]
            key[e + j] = math.log(u[e + j]) / w if w > 0 else -math.inf
        per = 0
        for j in range(j0, j1):
            pick[e + j] = 0
            kj = key[e + j]
            if not math.isfinite(kj):
                continue
            rank = 0
            for q in range(j0, j1):
                kq = key[e + q]
                if kq > kj or (kq == kj and q < j):
                    rank += 1
            if rank < n_a:
                per += 1
                pick[e + j] = 1
        attacks[c] = per
        valid_nbrs[c] = n_vc


def _list_attacks(indptr, front, eoff, coff, nfront, pick, attacks, valid_nbrs, max_attacks,
                  chosen, chosen_row):
    """The attack list in front-row then entry order (the numpy path's): row offsets from a
    prefix sum of the per-row counts, then each row fills its slice in parallel.  Returns
    (attacks, the most of one cell, cells above the allowed count)."""
    mx, viol = _attack_offsets(front, nfront, attacks, valid_nbrs, max_attacks, coff)
    _fill_attacks(indptr, front, eoff, coff, nfront, pick, chosen, chosen_row)
    return int(coff[nfront]), int(mx), int(viol)


@njit(cache=True, nogil=True)
def _attack_offsets(front, nfront, attacks, valid_nbrs, max_attacks, coff):
    coff[0] = 0
    mx = 0
    viol = 0
    for r in range(nfront):
        per = attacks[front[r]]
        coff[r + 1] = coff[r] + per
        mx = max(mx, per)
        if per > min(valid_nbrs[front[r]], max_attacks):
            viol += 1
    return mx, viol


@njit(cache=True, nogil=True, parallel=True)
def _fill_attacks(indptr, front, eoff, coff, nfront, pick, chosen, chosen_row):
    for r in prange(nfront):
        c = front[r]
        j0 = indptr[c]
        e = eoff[r] - j0
        i = coff[r]
        for j in range(j0, indptr[c + 1]):
            if pick[e + j]:
                chosen[i] = j
                chosen_row[i] = r
                i += 1


@njit(cache=True, nogil=True, parallel=True)
def _attacks(indptr, indices, status0, front, chosen, chosen_row, nch, helpers, noise, age, strong,
             hit, a0, a1, a2, noise_amp, b0, b1, strong_bonus):
    """hit[i]: attack i beats its target's defence (f2), in parallel over the attacks (each
    reads the state at the start of the step: status0, and the attacker's age before this
    step's thinning added one)."""
    for i in prange(nch):
        r = chosen_row[i]
        t = indices[chosen[i]]
        attack = a0 + a1 * (age[front[r]] - 1) + a2 * helpers[r] + noise_amp * noise[i]
        sh = 0.0
        for q in range(indptr[t], indptr[t + 1]):
            x = indices[q]
            if strong[x] and status0[x] == NORMAL:
                sh += 1.0
        defence = b0 + b1 * sh + strong_bonus * (1.0 if strong[t] else 0.0)
        hit[i] = attack > defence


@njit(cache=True, nogil=True)
def _settle_all(indices, seeds, chosen, hit, nch, newc, open_, status):
    """Seeds and hit targets that were open corrode (each counted once)."""
    for s in seeds:
        newc[s] = 1
    for i in range(nch):
        if hit[i]:
            newc[indices[chosen[i]]] = 1
    newly = 0
    for s in seeds:
        newly += _settle(s, newc, open_, status)
    for i in range(nch):
        if hit[i]:
            newly += _settle(indices[chosen[i]], newc, open_, status)
    return newly


@njit(cache=True, nogil=True, inline="always")
def _settle(c, newc, open_, status):
    """A marked cell corrodes if it was open; the mark is cleared (counted once)."""
    if newc[c]:
        newc[c] = 0
        if open_[c]:
            status[c] = CORRODED
            return 1
    return 0
