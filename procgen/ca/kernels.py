"""Compiled (numba) stepping of the shared cell layer: outer-totalistic rules and propagation.

Why: the numpy steps gather through a sparse product (life) or build entry lists, sorts and
unions per step (Voronoi frontier), i.e. a few temporaries per cell per step; a compiled loop
reads each neighbour once, through int32 ids, and writes in place.  The life step gathers
through fixed-length rows of int16 id deltas where the degrees allow (:class:`Neighbours`: half
the neighbour bytes, with exact int32 escape rows for far neighbours) and the ``ca.life`` rule
runs one fused kernel per step (:class:`LifeRun`), in parallel over numba's threads, or, once
few cells change, an activity-tracking step that evaluates only the cells that can change;
the Voronoi step is one kernel per step over per-graph links (the diagonal flag in the id's sign
bit, the backward direction only through one-way links), drawing from the rule's Generator inside
numba and marking the next frontier in a bitmap read in order (no sort).  Imported only through
:func:`procgen.accel.kernels` (this module needs numba).

Same results, exactly: the life step is integer counting, each cell from the previous state
only (so any thread count gives the same cells; the tracking step skips only cells whose
outcome is provably their state); the Voronoi step draws the same random numbers
from the same Generator in the same order as ``VoronoiGrowth.step`` (one per frontier entry,
then one per candidate entry, both in frontier order) and applies the same choice (smallest key
per row, first on ties), so labels and frontier are identical (tests/test_ca_kernels.py,
tests/test_life_kernels.py, tests/test_voronoi_kernels.py).  Buffers are allocated once per graph
(or per rule, in setup) and reused: no step allocates anything proportional to the domain (the
Voronoi step allocates its new frontier array, and its candidate buffers grow with the largest
frontier seen).
"""
from __future__ import annotations

import numpy as np
from numba import njit, prange

from ..errors import InputError
from .graph import CellGraph

_ATTR = "_ca_kernel_work"
_INDICES = "_ca_indices32"
_NEIGHBOURS = "_ca_neighbours"


# --------------------------------------------------------------------------------------------
# outer-totalistic (Life-like) step

def compact_indices(graph: CellGraph) -> np.ndarray:
    """The graph's neighbour ids as int32 (half the bytes streamed per step), made once."""
    idx = graph.__dict__.get(_INDICES)
    if idx is None:                       # a frozen dataclass: cached like its cached_property
        idx = graph.__dict__[_INDICES] = graph.indices.astype(np.int32 if graph.n_cells < 2 ** 31 else np.int64)
    return idx


AGE_MODES = {"cumulative": (0,), "consecutive": (0, 0), "since_first": (0, 0, 0)}
"""The ``lifelike.next_age`` readings as tuples of lengths 1, 2, 3: numba compiles one kernel
per argument type, and a tuple's length is part of its type, so the kernels test the mode at
compile time (no mode test nor generic expression per cell; half again as fast)."""


class Neighbours:
    """The gather layout of one graph, made once per graph.

    When the degrees are about equal (lattices, surface cells) every row is a fixed-length loop
    the compiler unrolls (about twice as fast as the CSR loop with its row bounds), stored
    compactly: ``delta`` (n, K) int16 = neighbour id - cell id, 16 bytes per cell for K = 8
    instead of the int32 ids' 32 (cells are numbered along rows of a lattice or of a
    triangle's grid, so nearly every neighbour lies within +-32767; 0.4 % of the rows of the
    250k-cell cylinder do not).  A row that does not fit - a far neighbour, or fewer than K
    neighbours - is an *escape* row: its delta row is unused and its int32 ids (a short row
    padded with the id n of an always-0 sentinel slot of the state buffers) are a row of
    ``esc_table``; ``esc_rows`` lists the escape rows in order and ``esc_ptr`` where each
    block of ``BLOCK`` cells starts in it, so the cell loop (parallel over the blocks) walks
    the plain rows between two escape rows with no test per cell.  Uneven degrees: CSR."""

    BLOCK = 4096

    def __init__(self, graph: CellGraph) -> None:
        n, nnz = graph.n_cells, graph.indices.size
        deg = graph.degree
        k = int(deg.max(initial=0))
        self.indptr, self.indices = graph.indptr, compact_indices(graph)
        self.delta = np.zeros((0, 0), np.int16)
        if n and k <= 255 and n * k <= 1.25 * nnz + n:         # at most ~25 % padding
            table = np.full((n, k), n, np.int64)
            table[graph.rows, np.arange(nnz) - graph.indptr[graph.rows]] = graph.indices
            delta = table - np.arange(n)[:, None]
            esc = (deg < k) | np.any(np.abs(delta) > np.iinfo(np.int16).max, axis=1)
            delta[esc] = 0
            self.delta = delta.astype(np.int16)
            self.esc_rows = np.flatnonzero(esc)
            self.esc_table = table[esc].astype(self.indices.dtype)
            starts = np.minimum(np.arange(-(-n // self.BLOCK) + 1) * self.BLOCK, n)
            self.esc_ptr = np.searchsorted(self.esc_rows, starts)
        self.scratch = np.zeros(n + 1, np.uint8)                # life_step's state + sentinel

    @property
    def nbytes(self) -> int:
        """Bytes of the gather layout (the neighbour bytes a dense step streams)."""
        if self.delta.shape[1]:
            return sum(x.nbytes for x in (self.delta, self.esc_rows, self.esc_table, self.esc_ptr))
        return self.indptr.nbytes + self.indices.nbytes

    @property
    def layout(self) -> tuple:
        """The compact layout's arrays, as the kernels take them."""
        return (0,) * self.delta.shape[1], self.delta, self.esc_rows, self.esc_table, self.esc_ptr, self.BLOCK

    def step(self, a: np.ndarray, rule: tuple[int, int], out: np.ndarray, present=None, u=None,
             p=None, ever=None, age=None, mode: tuple = AGE_MODES["cumulative"]) -> int:
        """One fused step (:func:`_step_cell`) from ``a`` (n + 1 uint8, a[n] = 0) into ``out``
        with the rule ``(code, cap)`` of :func:`table_code`; returns the number of cells whose
        state changed."""
        args = (a, *rule, present, u, p, out, ever, age, mode)
        if self.delta.shape[1]:
            return _rule_compact(*self.layout, *args)
        return _rule_csr(self.indptr, self.indices, *args)

    def count(self, a: np.ndarray, rule: tuple[int, int], present, count: np.ndarray,
              flag: np.ndarray) -> None:
        """Live-neighbour counts of the state ``a`` into ``count``, and per cell whether the
        rule (before any birth draw) would change it into ``flag`` (:class:`LifeRun`)."""
        if self.delta.shape[1]:
            _count_compact(*self.layout, a, *rule, present, count, flag)
        else:
            _count_csr(self.indptr, self.indices, a, *rule, present, count, flag)


def neighbours(graph: CellGraph) -> Neighbours:
    """The graph's :class:`Neighbours`, made once per graph."""
    nb = graph.__dict__.get(_NEIGHBOURS)
    if nb is None:
        nb = graph.__dict__[_NEIGHBOURS] = Neighbours(graph)
    return nb


def table_code(lut: np.ndarray) -> tuple[int, int]:
    """A (N + 1, 2) bool table T[count, state] as (code, cap): the bits T[min(k, cap), s] at
    2 * min(k, cap) + s of one integer, where rows cap.. are all equal (the numpy path caps the
    count at N, so every count from the first row of the table's constant tail reads the same
    row).  A shift replaces the table load in the cell loop; up to 31 distinct rows."""
    t = np.ascontiguousarray(lut, bool)
    cap = len(t) - 1
    while cap > 0 and np.array_equal(t[cap - 1], t[cap]):
        cap -= 1
    if cap > 30:
        raise InputError(f"a compiled life table has at most 31 distinct count rows, got {cap + 1}")
    bits = t[: cap + 1].reshape(-1)
    return int(np.sum(bits.astype(np.int64) << np.arange(bits.size, dtype=np.int64))), cap


def life_step(graph: CellGraph, alive: np.ndarray, lut: np.ndarray, out: np.ndarray | None = None
              ) -> np.ndarray:
    """``lifelike.life_step`` compiled; writes into ``out`` (bool, n) when given."""
    if out is None:
        out = np.empty(graph.n_cells, bool)
    nb = neighbours(graph)
    nb.scratch[:-1] = np.asarray(alive, bool).view(np.uint8)
    nb.step(nb.scratch, table_code(lut), out.view(np.uint8))
    return out


class LifeRun:
    """The ``ca.life`` rule's state on the compiled path: buffers made once in setup, and per
    step either the dense fused kernel (count, rule table, presence, optional birth draw,
    ever-alive and age, in parallel over the cells: each cell's update reads only the previous
    buffers, so the result does not depend on the thread count) or, once few cells change, the
    activity-tracking step (:func:`_active_step`).  ``alive`` and ``age`` are the current
    arrays (``alive`` is a view of the current state buffer; ``age`` is updated in place);
    ``ever`` is updated in place where the age mode needs it, else derived when read.

    Activity tracking, the classic Life optimisation, kept exact for every mode: a cell can
    change at the next step only if its table outcome T(count, state) & present differs from
    its state (an *unstable* cell; a birth draw can only hold such a cell back, never make a
    stable one change).  The active step keeps the live-neighbour counts and the unstable
    list, evaluates only the unstable cells, flips those that change, updates the counts of
    the cells listing them (the transposed graph) and re-tests the touched cells; ever/age
    remain one dense (cheap, streaming) pass.  It starts after a dense step that changed at most
    ``ACTIVE_SHARE`` of the cells and runs while the unstable share stays below twice that;
    above it the dense kernel runs: a flip touches every cell listing it, serially and at
    random places, so tracking pays only while a few percent of the cells change (25/357 at
    7.6 % unstable cells per step: the tracking step costs more than the dense one)."""

    ACTIVE_SHARE = 0.02

    def __init__(self, graph: CellGraph, present: np.ndarray, lut: np.ndarray, age_mode: str,
                 alive: np.ndarray, ever: np.ndarray, age: np.ndarray) -> None:
        n = graph.n_cells
        self.nb = neighbours(graph)
        self.rule = table_code(lut)
        present = np.ascontiguousarray(present, bool)
        self.present = None if present.all() else present.view(np.uint8)
        self.mode = AGE_MODES[age_mode]
        self.buf, self.spare = np.zeros(n + 1, np.uint8), np.zeros(n + 1, np.uint8)   # [n]: sentinel 0
        self.buf[:n] = np.asarray(alive, bool)
        self.ever0 = np.array(ever, bool)
        # ever-alive is kept per step only where the age does not tell it: a cumulative age
        # grows exactly on the steps alive, so ever = ever0 | age > 0 (no byte read and written)
        self.ever_buf = None if age_mode == "cumulative" else self.ever0.view(np.uint8)
        self.age = np.array(age, np.int32)          # updated in place (a cell reads its own age only)
        self.u = np.empty(0)
        self.active = False                         # on the activity-tracking step
        self.wait, self.backoff = 0, 1              # dense steps before the next tracking attempt
        self.share = 1.0                            # cells evaluated by the last step / n
        self.inc = graph.incoming                   # the cells listing each cell
        self.inc_indices = compact_indices(self.inc)
        self.count = np.zeros(n, np.uint16)         # (tracking) live neighbours per cell
        self.flag = np.zeros(n, np.uint8)
        self.unstable = np.empty(n, np.int64)       # (tracking) the unstable cells, then the touched
        self.nunstable = 0
        self.flipped = np.empty(n, np.int64)
        self.mark = np.zeros(n, np.uint8)

    @property
    def alive(self) -> np.ndarray:
        return self.buf[:-1].view(bool)

    @property
    def ever(self) -> np.ndarray:
        """The cells ever alive (a new array when derived from the age)."""
        return self.ever0 if self.ever_buf is not None else self.ever0 | (self.age > 0)

    def draws(self) -> np.ndarray:
        """The buffer the birth draws go to (one uniform per cell)."""
        if self.u.size != self.age.size:
            self.u = np.empty(self.age.size)
        return self.u

    def step(self, birth_p: np.ndarray | None = None) -> bool:
        """One generation; ``birth_p``: per-cell birth probability with the draws in
        :meth:`draws` (the numpy path's ``new &= alive | (u < p)``).  True if a cell changed."""
        u = None if birth_p is None else self.u
        n = self.age.size
        if self.active:
            self.share = self.nunstable / max(n, 1)
            changed, self.nunstable = _active_step(
                self.inc.indptr, self.inc_indices, self.buf, self.count, *self.rule, self.present, u,
                birth_p, self.unstable, self.nunstable, self.flipped, self.mark)
            _age_pass(self.buf, self.ever_buf, self.age, self.mode)
            if self.nunstable > 2 * self.ACTIVE_SHARE * n:     # (hysteresis: no switching to and fro)
                self.active = False
            return changed > 0
        self.share = 1.0
        changed = self.nb.step(self.buf, self.rule, self.spare, self.present, u, birth_p,
                               self.ever_buf, self.age, self.mode)
        self.buf, self.spare = self.spare, self.buf
        if changed <= self.ACTIVE_SHARE * n:
            if self.wait:
                self.wait -= 1
            else:
                self._start_tracking()
        return changed > 0

    def _start_tracking(self) -> None:
        """Counts and the unstable list from the current state (one dense gather)."""
        n = self.age.size
        self.nb.count(self.buf, self.rule, self.present, self.count, self.flag)
        self.nunstable = _compact(self.flag, self.unstable)
        self.active = self.nunstable <= self.ACTIVE_SHARE * n
        # a failed attempt cost a dense pass: where few cells change per step but more are
        # unstable (birth draws holding cells back, or a churning rule), wait 1, 2, 4 .. 64
        # dense steps before the next one instead of paying it every step
        self.wait = 0 if self.active else self.backoff
        self.backoff = 1 if self.active else min(2 * self.backoff, 64)


# Two cell loops (the compact fixed rows, or CSR) around one inlined cell update: each cell
# writes only its own slots and reads only the previous state, so the parallel loops give the
# serial result.  The optional parts (presence, birth draws, ever, age) are None when off:
# numba compiles one version per combination with the part removed, so no cell pays a test or
# a read for it.

@njit(cache=True, nogil=True, inline="always")
def _step_cell(c, k, a, code, cap, present, u, p, out, ever, age, mode):
    """Cell c's next state from its live-neighbour count k: table bit 2k + state of ``code``,
    presence, birth draw (a birth happens only where u < p), ever-alive and age; a part given
    as None is compiled out.  Returns 1 when the state changed."""
    c = np.uint64(c)                       # (unsigned indices: numba adds no negative wraparound)
    ac = np.int64(a[c])
    v = (code >> (2 * min(k, cap) + ac)) & 1
    if present is not None:
        v &= np.int64(present[c])
    if u is not None:
        v &= ac | np.int64(u[c] < p[c])
    _age(c, v, ever, age, mode)
    out[c] = v
    return v ^ ac


@njit(cache=True, nogil=True, inline="always")
def _age(c, v, ever, age, mode):
    """ever |= v and the age step of the mode (:data:`AGE_MODES`) at cell c; None: not kept."""
    ev = np.int64(0)
    if ever is not None:
        ev = np.int64(ever[c]) | v
        ever[c] = ev
    if age is not None:
        if len(mode) == 1:                 # cumulative: +1 per step alive
            age[c] += np.int32(v)
        elif len(mode) == 2:               # consecutive: +1 per step alive, 0 on death
            age[c] = (age[c] + np.int32(1)) * np.int32(v)
        else:                              # since_first: +1 per step once ever alive
            age[c] += np.int32(ev)


@njit(cache=True, nogil=True, inline="always")
def _gather(ks, delta, a, c):
    """Live neighbours of a plain row of the compact layout.  Unsigned indices: numba adds a
    test for negative (from-the-end) indices per signed read (about half the time); the row
    length is ``len(ks)`` (a tuple: a compile-time constant, so the loop is unrolled)."""
    k = 0
    for s in range(len(ks)):
        k += a[np.uint64(c + delta[c, s])]
    return k


@njit(cache=True, nogil=True, inline="always")
def _gather_ids(ks, table, a, j):
    """Live neighbours of row j of an int32 id table (an escape row)."""
    k = 0
    for s in range(len(ks)):
        k += a[np.uint64(table[j, s])]
    return k


@njit(cache=True, nogil=True, parallel=True)
def _rule_compact(ks, delta, esc_rows, esc_table, esc_ptr, block, a, code, cap, present, u, p, out,
                  ever, age, mode):
    """The fused step over the compact layout (:class:`Neighbours`), in parallel over blocks."""
    n = delta.shape[0]
    changed = 0
    for b in prange(esc_ptr.size - 1):
        lo = b * block
        hi = min(lo + block, n)
        ch = 0
        for j in range(esc_ptr[b], esc_ptr[b + 1] + 1):
            stop = esc_rows[j] if j < esc_ptr[b + 1] else hi
            for c in range(lo, stop):
                ch += _step_cell(c, _gather(ks, delta, a, c), a, code, cap, present, u, p, out, ever,
                                 age, mode)
            if stop < hi:
                ch += _step_cell(stop, _gather_ids(ks, esc_table, a, j), a, code, cap, present, u, p,
                                 out, ever, age, mode)
            lo = stop + 1
        changed += ch
    return changed


@njit(cache=True, nogil=True, parallel=True)
def _rule_csr(indptr, indices, a, code, cap, present, u, p, out, ever, age, mode):
    changed = 0
    for c in prange(indptr.size - 1):
        k = 0
        for e in range(indptr[c], indptr[c + 1]):
            k += a[indices[e]]
        changed += _step_cell(c, k, a, code, cap, present, u, p, out, ever, age, mode)
    return changed

# --------------------------------------------------------------------------------------------
# Voronoi propagation
#
# One compiled call per step (:func:`_voronoi_kernel`) draws from the rule's Generator itself
# (numba runs the same bit generator: the same numbers in the same order as the numpy path's
# ``rng.random`` arrays) in two passes over the frontier: the candidates (one draw per entry),
# then the pick (one key per candidate) with the next frontier marked in a bitmap whose set bits,
# read in word order, are that frontier sorted (no sort, no union).  ``st`` is one byte per
# cell for the neighbour tests, a quarter of the int32 labels' bytes in the cache.

_LINKS = "_ca_voronoi_links"
_LABELLED, _HOLE, _QUEUED, _LISTED = 1, 2, 4, 8     # st bits (_LISTED: has one-way listing cells)


class VoronoiLinks:
    """The graph as the compiled Voronoi step reads it, made once per graph (:func:`voronoi_links`).

    ``links``: the neighbour ids (int32 below 2**31 cells) with the sign bit set on diagonal
    entries, so a link's one load gives both (``link & id_mask`` is the id, ``link < 0`` the
    diagonal flag).  ``xptr, xidx``: CSR of the cells listing a cell that the cell does not
    list itself, the transposed graph minus the graph (empty on a symmetric lattice; the
    one-way cross-edge links of a surface): a new label reaches its neighbours both ways
    (``VoronoiGrowth._frontier_of``) through ``links`` and this remainder only; the st bit
    _LISTED marks the cells that have one."""

    def __init__(self, graph: CellGraph) -> None:
        dtype = np.int32 if graph.n_cells < 2 ** 31 else np.int64
        self.links = graph.indices.astype(dtype)
        if graph.direction is not None:
            self.links[graph.is_diagonal] |= np.iinfo(dtype).min
        self.id_mask = dtype(np.iinfo(dtype).max)
        back = graph.incoming
        ptr = np.int32 if graph.indices.size < 2 ** 31 else np.int64
        self.xptr, self.xidx = _one_way(graph.indptr, graph.indices, back.indptr, back.indices,
                                        np.empty(0, ptr), np.empty(0, dtype))
        self.max_degree = int(graph.degree.max(initial=0))


def voronoi_links(graph: CellGraph) -> VoronoiLinks:
    got = graph.__dict__.get(_LINKS)
    if got is None:
        got = graph.__dict__[_LINKS] = VoronoiLinks(graph)
    return got


@njit(cache=True, nogil=True)
def _one_way(indptr, indices, bptr, bidx, like_ptr, like_id):
    """CSR (indptr, ids) of the back entries absent from the cell's own row, in the dtypes of
    ``like_ptr`` and ``like_id``."""
    xptr = np.zeros(indptr.size, like_ptr.dtype)
    for rep in range(2):                   # count, then fill
        xidx = np.empty(xptr[-1], like_id.dtype)
        m = 0
        for c in range(indptr.size - 1):
            for e in range(bptr[c], bptr[c + 1]):
                t = bidx[e]
                found = False
                for j in range(indptr[c], indptr[c + 1]):
                    found |= indices[j] == t
                if not found:
                    if rep:
                        xidx[m] = t
                    m += 1
            xptr[c + 1] = m
    return xptr, xidx


class VoronoiWork:
    """Buffers of the compiled Voronoi step, made once per growth: ``st`` (one byte per cell,
    the bits above, following ``labels``, which the step updates in place; a new labels array,
    e.g. set from outside, is read again), the candidate sources and counts of one step, and
    the frontier bitmap (one bit per cell, all clear between steps); the candidate sources and
    counts of one step grow with the largest frontier seen (:meth:`fit`), not with the domain."""

    def __init__(self, graph: CellGraph) -> None:
        self.g = voronoi_links(graph)
        n = graph.n_cells
        self.st = np.zeros(n, np.uint8)
        self.words = np.zeros(n // 64 + 1, np.uint64)
        self.cand = np.empty(0, self.g.links.dtype)
        self.ncand = np.empty(0, np.int32)
        self.labels = None

    def follow(self, labels: np.ndarray) -> None:
        if self.labels is not labels:
            st = np.where(labels > 0, _LABELLED, np.where(labels < 0, _HOLE, 0))
            self.st[:] = st | np.where(np.diff(self.g.xptr) > 0, _LISTED, 0)
            self.labels = labels

    def fit(self, n_front: int) -> None:
        """Room for the candidates of ``n_front`` frontier cells (+1: the branch-free append)."""
        if self.ncand.size < n_front:
            self.ncand = np.empty(2 * n_front, np.int32)
            self.cand = np.empty(2 * n_front * self.g.max_degree + 1, self.g.links.dtype)


def voronoi_step(grow, rng: np.random.Generator) -> int:
    """``VoronoiGrowth.step`` compiled: labels updated in place, frontier replaced."""
    front = grow.frontier
    if len(front) == 0:
        return 0
    work = grow.__dict__.get(_ATTR)
    if work is None:
        work = grow.__dict__[_ATTR] = VoronoiWork(grow.graph)
    work.follow(grow.labels)
    work.fit(len(front))
    g = work.g
    nnew, grow.frontier = _voronoi_kernel(
        grow.graph.indptr, g.links, g.id_mask, g.xptr, g.xidx,
        float(grow.p_diagonal), np.ascontiguousarray(front, np.int64), rng, grow.labels, work.st,
        work.cand, work.ncand, work.words)
    return int(nnew)


def _de_bruijn_table() -> np.ndarray:
    table = np.zeros(64, np.int64)
    for i in range(64):
        table[((1 << i) * _DE_BRUIJN % 2 ** 64) >> 58] = i
    return table


_DE_BRUIJN = 0x03F79D71B4CB0A89
_LOWEST_BIT = _de_bruijn_table()
"""Index of a uint64's lowest set bit b: _LOWEST_BIT[(b * _DE_BRUIJN) >> 58] (every 6-bit
window of the de Bruijn sequence is distinct)."""


@njit(cache=True, nogil=True, inline="always")
def _mark(t, st, words, nq, lo, hi):
    """Queue cell t for the next frontier (its st bit and bitmap bit); the count and the range
    of bitmap words touched."""
    st[t] |= _QUEUED
    w = t >> 6
    words[w] |= np.uint64(1) << np.uint64(t & 63)
    return nq + 1, min(lo, w), max(hi, w)


@njit(cache=True, nogil=True, inline="always")
def _queue_row(indptr, indices, id_mask, c, st, words, nq, lo, hi):
    """Queue c's unlabelled, unqueued neighbours (holes have st bit 2)."""
    for j in range(indptr[c], indptr[c + 1]):
        t = indices[j] & id_mask
        if st[t] & 7 == 0:
            nq, lo, hi = _mark(t, st, words, nq, lo, hi)
    return nq, lo, hi


@njit(cache=True, nogil=True)
def _voronoi_kernel(indptr, links, id_mask, xptr, xidx, p_diagonal, front, rng, labels, st,
                    cand, ncand, words):
    """One step: (cells labelled, next frontier sorted).

    Pass 1, per frontier entry in order: a draw u, and the entry is a candidate when its source
    is labelled and it is a side link or u < P (the numpy ``ok``); the sources are appended to
    ``cand``.  Pass 2, per frontier cell in order: one key per candidate, the smallest wins
    (first on ties: ``pick_one_per_row``'s lexsort), its label is copied (in place: a candidate's
    source was labelled before the step, so no choice changes), and the cell's unlabelled
    neighbours both ways are queued; a cell left unlabelled stays queued.  A queued cell
    labelled later in the pass is not emitted."""
    nc = 0
    for i in range(front.size):
        c = front[i]
        k0 = nc
        for j in range(indptr[c], indptr[c + 1]):
            v = links[j]
            t = v & id_mask
            u = rng.random()
            good = (st[t] & 3 == _LABELLED) & ((v >= 0) | (u < p_diagonal))
            cand[nc] = t
            nc += good
        ncand[i] = nc - k0
    nnew = 0
    nq = 0
    k = 0
    lo, hi = words.size, 0
    for i in range(front.size):
        c = front[i]
        m = ncand[i]
        if m == 0:
            if st[c] & 7 == 0:
                nq, lo, hi = _mark(c, st, words, nq, lo, hi)
        else:
            src = cand[k]
            bkey = rng.random()
            for q in range(k + 1, k + m):
                key = rng.random()
                better = key < bkey
                bkey = key if better else bkey
                src = cand[q] if better else src
            k += m
            labels[c] = labels[src]
            if st[c] & _QUEUED:                # queued by an earlier cell of this pass
                nq -= 1
            st[c] = (st[c] & _LISTED) | _LABELLED
            nnew += 1
            nq, lo, hi = _queue_row(indptr, links, id_mask, c, st, words, nq, lo, hi)
            if st[c] & _LISTED:
                nq, lo, hi = _queue_row(xptr, xidx, id_mask, c, st, words, nq, lo, hi)
    out = np.empty(nq, np.int64)
    m = 0
    for w in range(lo, hi + 1):
        bits = words[w]
        words[w] = 0
        while bits:
            low = bits & (~bits + np.uint64(1))
            t = (w << 6) + _LOWEST_BIT[(low * np.uint64(_DE_BRUIJN)) >> np.uint64(58)]
            bits ^= low
            if st[t] & 7 == _QUEUED:
                st[t] &= _LISTED
                out[m] = t
                m += 1
    return nnew, out


# --------------------------------------------------------------------------------------------
# activity tracking (LifeRun)

@njit(cache=True, nogil=True, inline="always")
def _outcome(c, k, ac, code, cap, present):
    """T(count, state) & present of cell c (before any birth draw)."""
    v = (code >> (2 * min(k, cap) + ac)) & 1
    if present is not None:
        v &= np.int64(present[c])
    return v


@njit(cache=True, nogil=True, parallel=True)
def _count_compact(ks, delta, esc_rows, esc_table, esc_ptr, block, a, code, cap, present, count, flag):
    n = delta.shape[0]
    for b in prange(esc_ptr.size - 1):
        lo = b * block
        hi = min(lo + block, n)
        for j in range(esc_ptr[b], esc_ptr[b + 1] + 1):
            stop = esc_rows[j] if j < esc_ptr[b + 1] else hi
            for c in range(lo, stop):
                k = _gather(ks, delta, a, c)
                count[c] = k
                flag[c] = _outcome(c, k, np.int64(a[c]), code, cap, present) != a[c]
            if stop < hi:
                k = _gather_ids(ks, esc_table, a, j)
                count[stop] = k
                flag[stop] = _outcome(stop, k, np.int64(a[stop]), code, cap, present) != a[stop]
            lo = stop + 1


@njit(cache=True, nogil=True, parallel=True)
def _count_csr(indptr, indices, a, code, cap, present, count, flag):
    for c in prange(indptr.size - 1):
        k = 0
        for e in range(indptr[c], indptr[c + 1]):
            k += a[indices[e]]
        count[c] = k
        flag[c] = _outcome(c, k, np.int64(a[c]), code, cap, present) != a[c]


@njit(cache=True, nogil=True)
def _compact(flag, out):
    m = 0
    for c in range(flag.size):
        if flag[c]:
            out[m] = c
            m += 1
    return m


@njit(cache=True, nogil=True)
def _active_step(inc_ptr, inc_idx, a, count, code, cap, present, u, p, unstable, nu, flipped, mark):
    """One synchronous step over the unstable cells only (see :class:`LifeRun`): every new
    state from the old states and counts, then the flips, the count updates of the cells
    listing a flipped cell, and the new unstable list (the old one and the touched cells,
    re-tested).  Returns (cells changed, unstable cells)."""
    nf = 0
    for i in range(nu):
        c = unstable[i]
        ac = np.int64(a[c])
        v = _outcome(c, np.int64(count[c]), ac, code, cap, present)
        if u is not None:
            v &= ac | np.int64(u[c] < p[c])
        if v != ac:
            flipped[nf] = c
            nf += 1
    for i in range(nu):                      # the re-test list: old unstable cells ...
        mark[unstable[i]] = 1
    m = nu
    for i in range(nf):
        c = flipped[i]
        a[c] ^= 1
        d = 1 if a[c] else -1
        for e in range(inc_ptr[c], inc_ptr[c + 1]):
            t = inc_idx[e]
            count[t] += d
            if not mark[t]:                   # ... and the cells whose count changed
                mark[t] = 1
                unstable[m] = t
                m += 1
    nu2 = 0
    for i in range(m):
        c = unstable[i]
        mark[c] = 0
        if _outcome(c, np.int64(count[c]), np.int64(a[c]), code, cap, present) != a[c]:
            unstable[nu2] = c
            nu2 += 1
    return nf, nu2


@njit(cache=True, nogil=True, parallel=True)
def _age_pass(a, ever, age, mode):
    """ever |= state and the age update of :func:`_step_cell`, over every cell (``ever`` None:
    not kept)."""
    for c in prange(age.size):
        _age(np.uint64(c), np.int64(a[c]), ever, age, mode)
