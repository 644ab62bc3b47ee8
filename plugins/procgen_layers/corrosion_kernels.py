"""Compiled (numba) attack/defence corrosion step: ``corrosion.corrosion_step`` in loops.

Why: the numpy step builds per-entry arrays for the front, sorts them per row (weighted
sampling without replacement), takes a ``np.unique`` of the targets and several full-grid
temporaries per step; compiled loops visit each front entry a few times and write in place.
Imported only through :func:`procgen.accel.kernels` (this module needs numba).

Same results, exactly: the random numbers come from the same Generator calls in the same order
(binomial and ``choice`` for the seeds, one uniform per front entry for the weighted choice of
targets, one per attack for the noise), the Efraimidis-Spirakis keys log(u)/w and their ranking
(largest first, ties in entry order) are the numpy path's, and every float expression keeps its
order (tests/test_corrode_kernels.py compares whole runs).

Where the time goes (``PASS_TIMES``; ``benchmarks/surface.py --paths --only corrode`` prints
it): the front is a few per cent of the cells, so a step is one pass over the cells plus work on
the front.  The one whole-grid pass reads the status (a 64-bit word of 8 cells at a time,
skipping words without a corroded cell) and, for the corroded cells only, whether a neighbour is
open (normal, metal left, not blocked; computed where read, so no open/status copy of the grid
is written); it lists the corroded cells and the front per chunk of cells.  The state stays as
it was at the start of the step until the attacks are judged (thinning, step 4, runs last, over
the listed corroded cells, booking each one's change of solid in the state's ledger if it keeps
one), so the kernels read ``status`` and ``age`` directly.  The settling pass lists the newly
corroded cells as it marks them (``StepStats.newly_cells``).  The weak open
pool is counted (per chunk) only in a step that draws seeds, and a seed is looked for in its
chunk.  Buffers live on the graph: the per-cell ones are made once, the per-entry ones grow with
the largest front seen (a step allocates nothing proportional to the domain;
``attacks``/``valid_neighbours`` of the state are zeroed in place at the last front's cells, the
only non-zero ones).

Parallel and deterministic: every pass runs over numba's threads with each chunk, front row or
attack writing only its own slots, and every list keeps the numpy path's order: the lists are
made per chunk of cells into the chunk's own slice and the front is joined in chunk order; the
target choice runs per front row, and the attack list is laid out by a prefix sum of the
per-row counts (front row, then entry order); attacks are judged in parallel (per front row,
into its slice of the list) and marked serially.  So the result does not depend on the thread count.
"""
from __future__ import annotations

import math
import time

import numpy as np
from numba import njit, prange

from procgen.ca.graph import CellGraph

from .corrosion import CORRODED, HOLE, NORMAL, CorrosionState, StepStats

_ATTR = "_corrode_kernel_work"


class Work:
    """Per-graph buffers: the graph with 32-bit ids, per-chunk cell lists, per-front-entry
    random numbers, keys and choices (grown by :meth:`fit`)."""

    def __init__(self, graph: CellGraph) -> None:
        n, nnz = graph.n_cells, graph.indices.size
        self.indptr = graph.indptr.astype(np.int32 if nnz < 2 ** 31 else np.int64)
        self.indices = graph.indices.astype(np.int32 if n < 2 ** 31 else np.int64)
        self.direction = np.ascontiguousarray(graph.direction)
        self.nchunk = max(1, min(256, n // 4096))
        self.counts = np.zeros((3, self.nchunk), np.int64)   # corroded / front / pool cells per chunk
        self.corr = np.empty(n, self.indices.dtype)          # corroded cells, per chunk slice
        self.front = np.empty(n, self.indices.dtype)         # the front (chunk slices, then joined)
        self.eoff = np.empty(n + 1, np.int64)     # first entry of each front row (+ the end)
        self.coff = np.empty(n + 1, np.int64)     # first attack of each front row (+ the end)
        self.helpers = np.empty(n)
        self.newly = np.empty(n, np.int64)        # the cells corroded in the step, as settled
        self.nfront = 0
        self.cleared = None                       # (attacks, valid_neighbours) zero but the last front
        self.fit(0)

    def fit(self, entries: int) -> None:
        """Room for ``entries`` front entries (and as many attacks)."""
        if getattr(self, "u", np.empty(0)).size >= max(entries, 1):
            return
        m = max(2 * entries, 1024)
        self.u, self.key, self.noise = np.empty(m), np.empty(m), np.empty(m)
        self.pick, self.hit = np.empty(m, np.uint8), np.empty(m, np.uint8)
        self.chosen = np.empty(m, self.indices.dtype)        # chosen entry of each attack


PASS_TIMES: dict[str, float] | None = None
"""Set to a dict to add up each pass's time under its name (seconds by ``PASS_CLOCK``): the
per-pass profile that benchmarks/surface.py prints with ``--paths --only corrode``."""
PASS_CLOCK = time.perf_counter


def _pass(name: str, fn, *args, **kw):
    if PASS_TIMES is None:
        return fn(*args, **kw)
    t0 = PASS_CLOCK()
    got = fn(*args, **kw)
    PASS_TIMES[name] = PASS_TIMES.get(name, 0.0) + PASS_CLOCK() - t0
    return got


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
    else:                                           # only the last front's cells are non-zero
        _pass("clear", _clear, work.front, work.nfront, st.attacks, st.valid_neighbours)
    work.cleared = (st.attacks, st.valid_neighbours)
    blk = np.zeros(0, np.bool_) if blocked is None else np.asarray(blocked, np.bool_)
    nfront = work.nfront = _pass("scan", _scan, work.indptr, work.indices, st.status, st.consumable, blk,
                                 work.corr, work.front, work.counts, work.eoff)
    ne = int(work.eoff[nfront])
    seeds = _pass("seeds", _seeds, work, st, prm, rng, blk, out)
    nch = 0
    if nfront:
        work.fit(ne)
        _pass("draw_u", rng.random, out=work.u[:ne])
        logw = np.zeros(0) if edge_logw is None else np.asarray(edge_logw, dtype=float)
        _pass("choose", _choose, work.indptr, work.indices, work.direction, np.asarray(weights, float), logw,
              st.age, float(prm.age_step), _integral(prm.age_step), int(prm.max_attacks), st.status,
              st.consumable, blk, work.front, work.eoff, nfront, work.u, work.key, work.pick, work.helpers,
              st.attacks, st.valid_neighbours)
        nch, mx, viol = _pass("offsets", _attack_offsets, work.front, nfront, st.attacks,
                              st.valid_neighbours, int(prm.max_attacks), work.coff)
        out.attacks, out.max_attacks_per_cell, out.max_allowed_violation = int(nch), int(mx), int(viol)
        _pass("draw_noise", rng.random, out=work.noise[:nch])
        _pass("judge", _judge, work.indptr, work.indices, st.status, work.front, work.eoff, work.coff, nfront,
              work.pick, work.helpers, work.noise, st.age, st.strong, work.chosen, work.hit, float(prm.a0),
              float(prm.a1), float(prm.a2), float(prm.noise), float(prm.b0), float(prm.b1),
              float(prm.strong_bonus))
    newly = _pass("settle", _settle, work.indices, seeds, work.chosen, work.hit, nch, st.status, work.newly)
    no = np.zeros(0)
    ledger, area = (no, no) if st.ledger is None else (st.ledger, np.asarray(st.area, float))
    holes = _pass("thin", _thin, work.corr, work.counts, n, st.status, st.consumable, st.product, st.age,
                  float(prm.k1), float(prm.k2), float(prm.k3), ledger, area)
    out.new_holes, out.newly_corroded, out.changed = int(holes), int(newly), int(holes + newly)
    out.newly_cells = work.newly[:newly].copy()
    return out


def _seeds(work: Work, st: CorrosionState, prm, rng: np.random.Generator, blk: np.ndarray,
           out: StepStats) -> np.ndarray:
    """Step 1: the new seeds (the numpy path's draws); the weak open pool is counted and
    searched only when the binomial asks for seeds."""
    room = prm.max_seeds - st.seeds_used
    if room <= 0 or prm.seed_rate <= 0:
        return np.zeros(0, np.int64)
    n = st.status.size
    want = int(rng.binomial(n, prm.seed_rate)) if prm.seeding == "binomial" else int(np.floor(prm.seed_rate * n))
    if min(want, room) <= 0:
        return np.zeros(0, np.int64)
    npool = int(_pool_size(st.status, st.consumable, blk, st.strong, work.counts[2]))
    k = min(want, room, npool)
    if k <= 0:
        return np.zeros(0, np.int64)
    idx = rng.choice(npool, k, replace=False)
    out.seed_cells = _pool_members(st.status, st.consumable, blk, st.strong, work.counts[2],
                                   np.asarray(idx, np.int64))
    st.seeds_used += k
    out.new_seeds = k
    return out.seed_cells


@njit(cache=True, nogil=True, inline="always")
def _has_metal(consumable, c):
    s = 0.0
    for l in range(consumable.shape[1]):
        s += consumable[c, l]
    return s


@njit(cache=True, nogil=True, inline="always")
def _is_open(status, consumable, blocked, c):
    """Normal, metal left, not blocked (the numpy path's ``open_``)."""
    return status[c] == NORMAL and _has_metal(consumable, c) > 0 and not (blocked.size and blocked[c])


@njit(cache=True, nogil=True)
def _clear(front, nfront, attacks, valid_nbrs):
    """Zero the attack counts of the last front (the only non-zero ones)."""
    for r in range(nfront):
        attacks[front[r]] = 0
        valid_nbrs[front[r]] = 0


@njit(cache=True, nogil=True, inline="always")
def _chunk(b, n, nb):
    return b * n // nb, (b + 1) * n // nb


_ONES = np.uint64(0x0101010101010101)      # a word of status bytes has a CORRODED (1) byte iff
_HIGHS = np.uint64(0x8080808080808080)     # v = word ^ _ONES has a zero byte: (v - _ONES) & ~v & _HIGHS


@njit(cache=True, nogil=True, parallel=True)
def _scan_chunks(indptr, indices, status, words, consumable, blocked, corr, front, counts):
    n = status.size
    nb = counts.shape[1]
    wend = words.size * 8
    for b in prange(nb):
        c0, c1 = _chunk(b, n, nb)
        k = c0
        r = c0
        c = c0
        while c < c1:
            if (c & 7) == 0 and c + 8 <= c1 and c + 8 <= wend:   # 8 cells at a time: skip the
                v = words[c >> 3] ^ _ONES                       # words without a corroded cell
                if ((v - _ONES) & ~v & _HIGHS) == 0:
                    c += 8
                    continue
            if status[c] == CORRODED:
                corr[k] = c
                k += 1
                for j in range(indptr[c], indptr[c + 1]):
                    if _is_open(status, consumable, blocked, indices[j]):
                        front[r] = c
                        r += 1
                        break
            c += 1
        counts[0, b] = k - c0
        counts[1, b] = r - c0


@njit(cache=True, nogil=True)
def _join_front(indptr, front, counts, eoff):
    """Move each chunk's front slice to the end of the previous ones (the cell-order list a
    serial scan makes) and set the entry offsets; returns the front's length."""
    n = front.size
    nb = counts.shape[1]
    m = 0
    eoff[0] = 0
    for b in range(nb):
        start = b * n // nb
        for i in range(counts[1, b]):
            c = front[start + i]
            front[m] = c
            eoff[m + 1] = eoff[m] + indptr[c + 1] - indptr[c]
            m += 1
    return m


def _scan(indptr, indices, status, consumable, blocked, corr, front, counts, eoff) -> int:
    """The one pass over every cell: the corroded cells (per chunk, for the thinning) and the
    front (corroded cells touching an open cell, joined in cell order) with its entry offsets."""
    one_byte = status.dtype.itemsize == 1 and status.flags.c_contiguous
    words = status[:status.size - status.size % 8].view(np.uint64) if one_byte else np.zeros(0, np.uint64)
    _scan_chunks(indptr, indices, status, words, consumable, blocked, corr, front, counts)
    return int(_join_front(indptr, front, counts, eoff))


@njit(cache=True, nogil=True, parallel=True)
def _pool_size(status, consumable, blocked, strong, per):
    """Cells of the weak open pool (seeding steps only), per chunk of cells into ``per``."""
    n = status.size
    for b in prange(per.size):
        c0, c1 = _chunk(b, n, per.size)
        m = 0                                   # (branch-free: a strong cell is a coin flip)
        if blocked.size:
            for c in range(c0, c1):
                m += (status[c] == NORMAL) & (not strong[c]) & (_has_metal(consumable, c) > 0) & (not blocked[c])
        elif consumable.shape[1] == 1:          # one consumed layer: its thickness is the sum
            for c in range(c0, c1):
                m += (status[c] == NORMAL) & (not strong[c]) & (consumable[c, 0] > 0)
        else:
            for c in range(c0, c1):
                m += (status[c] == NORMAL) & (not strong[c]) & (_has_metal(consumable, c) > 0)
        per[b] = m
    return per.sum()


@njit(cache=True, nogil=True)
def _pool_members(status, consumable, blocked, strong, per, idx):
    """The cells at positions idx of the weak open pool (np.nonzero order): each is looked
    for in its chunk only (``per``: the pool cells of each chunk, from :func:`_pool_size`)."""
    n = status.size
    out = np.empty(idx.size, np.int64)
    for i in range(idx.size):
        b = 0
        seen = 0
        while seen + per[b] <= idx[i]:
            seen += per[b]
            b += 1
        c0, c1 = _chunk(b, n, per.size)
        for c in range(c0, c1):
            if not strong[c] and _is_open(status, consumable, blocked, c):
                if seen == idx[i]:
                    out[i] = c
                    break
                seen += 1
    return out


@njit(cache=True, nogil=True, parallel=True)
def _choose(indptr, indices, direction, weights, logw, age, age_step, istep, max_attacks, status, consumable,
            blocked, front, eoff, nfront, u, key, pick, helpers, attacks, valid_nbrs):
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
            if _is_open(status, consumable, blocked, t):
                n_vc += 1
                w = weights[direction[j]]
                if logw.size:
                    w = w * math.exp(logw[j])
                if w > 0 and u[e + j] > 0 and (w >= 1e-300 or math.isfinite(math.log(u[e + j]) / w)):
                    n_fin += 1
                else:
                    w = 0.0
            elif status[t] == CORRODED:
                hp += 1.0
            key[e + j] = w
            pick[e + j] = w > 0
        helpers[r] = hp
        if istep > 0:                           # an integral age_step: the same quotient
            f1 = min(max(1 + age[c] // istep, 1), max_attacks)
        else:
            f1 = min(max(1 + int(age[c] // age_step), 1), max_attacks)
        n_a = min(f1, n_vc)
        if n_a >= n_fin:                        # every finite key is picked
            attacks[c] = n_fin
            valid_nbrs[c] = n_vc
            continue
        for j in range(j0, j1):
            w = key[e + j]
            key[e + j] = math.log(u[e + j]) / w if w > 0 else -math.inf
            pick[e + j] = 0
        for _ in range(n_a):                    # n_a < n_fin: the n_a largest finite keys, one
            best = -math.inf                    # argmax at a time (strict >: the first of equals)
            bj = j0
            for j in range(j0, j1):
                if key[e + j] > best and not pick[e + j]:
                    best = key[e + j]
                    bj = j
            pick[e + bj] = 1
        attacks[c] = n_a
        valid_nbrs[c] = n_vc


def _integral(x: float) -> int:
    """x as an int when it is a whole number below 2**31, else 0."""
    return int(x) if float(x).is_integer() and 0 < x < 2 ** 31 else 0


@njit(cache=True, nogil=True)
def _attack_offsets(front, nfront, attacks, valid_nbrs, max_attacks, coff):
    """The first attack of each front row (a prefix sum of the per-row counts: the attack list
    in front-row then entry order, the numpy path's); returns (attacks, the most of one cell,
    cells above the allowed count)."""
    coff[0] = 0
    mx = 0
    viol = 0
    for r in range(nfront):
        per = attacks[front[r]]
        coff[r + 1] = coff[r] + per
        mx = max(mx, per)
        if per > min(valid_nbrs[front[r]], max_attacks):
            viol += 1
    return coff[nfront], mx, viol


@njit(cache=True, nogil=True, parallel=True)
def _judge(indptr, indices, status, front, eoff, coff, nfront, pick, helpers, noise, age, strong,
           chosen, hit, a0, a1, a2, noise_amp, b0, b1, strong_bonus):
    """Each front row's attacks (its picked entries, in entry order from coff[r]): chosen[i] =
    the entry, hit[i] = attack i beats its target's defence (f2); in parallel over the rows
    (the state is still the one at the start of the step)."""
    for r in prange(nfront):
        c = front[r]
        j0 = indptr[c]
        e = eoff[r] - j0
        i = coff[r]
        base = a0 + a1 * age[c] + a2 * helpers[r]
        for j in range(j0, indptr[c + 1]):
            if not pick[e + j]:
                continue
            t = indices[j]
            sh = 0                                  # strong normal neighbours (branch-free:
            for q in range(indptr[t], indptr[t + 1]):   # strong cells are a random share)
                x = indices[q]
                sh += strong[x] & (status[x] == NORMAL)
            defence = b0 + b1 * float(sh) + strong_bonus * (1.0 if strong[t] else 0.0)
            chosen[i] = j
            hit[i] = base + noise_amp * noise[i] > defence
            i += 1


@njit(cache=True, nogil=True)
def _settle(indices, seeds, chosen, hit, nch, status, listed):
    """Seeds and hit targets (all open) corrode, each counted once and listed in ``listed``."""
    newly = 0
    for s in seeds:
        if status[s] == NORMAL:
            status[s] = CORRODED
            listed[newly] = s
            newly += 1
    for i in range(nch):
        if hit[i]:
            t = indices[chosen[i]]
            if status[t] == NORMAL:
                status[t] = CORRODED
                listed[newly] = t
                newly += 1
    return newly


@njit(cache=True, nogil=True, parallel=True)
def _thin(corr, counts, n, status, consumable, product, age, k1, k2, k3, ledger, area):
    """Step 4 for the cells corroded at the start (the chunks' lists): they thin (top layer
    first), oxidise, age and may become holes; returns the new holes.  A non-empty ``ledger``
    gets each cell's ((c1 - c0) + p1 - p0) * area, the numpy path's expression in its order
    (layer sums bottom first, as :func:`corrosion.layer_sum`)."""
    nb = counts.shape[1]
    L = consumable.shape[1]
    holes = 0
    for b in prange(nb):
        c0 = b * n // nb
        for i in range(c0, c0 + counts[0, b]):
            c = corr[i]
            before = _has_metal(consumable, c) if ledger.size else 0.0
            remove = k1
            for l in range(L - 1, -1, -1):
                take = min(consumable[c, l], remove)
                consumable[c, l] -= take
                remove -= take
            p = product[c]
            product[c] = min(p + k2, max(p, k3))
            age[c] += 1
            left = _has_metal(consumable, c)
            if left <= 0:
                for l in range(L):
                    consumable[c, l] = 0.0
                left = _has_metal(consumable, c)
                status[c] = HOLE
                holes += 1
            if ledger.size:
                ledger[c] += (left - before + product[c] - p) * area[c]
    return holes
