"""Compiled (numba) stepping of the shared cell layer: outer-totalistic rules and propagation.

Why: the numpy steps gather through a sparse product (life) or build entry lists, sorts and
unions per step (Voronoi frontier), i.e. a few temporaries per cell per step; a compiled loop
over the CSR neighbour lists reads each neighbour once and writes in place.  Imported only
through :func:`procgen.accel.kernels` (this module needs numba).

Same results, exactly: the life step is integer counting; the Voronoi step draws the same
random numbers from the same Generator in the same order as ``VoronoiGrowth.step`` (one per
frontier entry, then one per candidate entry, both in frontier order) and applies the same
choice (smallest key per row, first on ties), so labels and frontier are identical
(tests/test_ca_kernels.py).  Buffers are allocated once per graph and reused: no step allocates
anything proportional to the domain (the frontier's sort allocates in proportion to the
frontier).
"""
from __future__ import annotations

import numpy as np
from numba import njit

from .graph import CellGraph

_ATTR = "_ca_kernel_work"
_INDICES = "_ca_indices32"


# --------------------------------------------------------------------------------------------
# outer-totalistic (Life-like) step

def compact_indices(graph: CellGraph) -> np.ndarray:
    """The graph's neighbour ids as int32 (half the bytes streamed per step), made once."""
    idx = graph.__dict__.get(_INDICES)
    if idx is None:                       # a frozen dataclass: cached like its cached_property
        idx = graph.__dict__[_INDICES] = graph.indices.astype(np.int32 if graph.n_cells < 2 ** 31 else np.int64)
    return idx


def life_step(graph: CellGraph, alive: np.ndarray, lut: np.ndarray, out: np.ndarray | None = None
              ) -> np.ndarray:
    """``lifelike.life_step`` compiled; writes into ``out`` (bool, n) when given."""
    if out is None:
        out = np.empty(graph.n_cells, bool)
    a = np.asarray(alive, bool).view(np.uint8)
    _life(graph.indptr, compact_indices(graph), a, np.ascontiguousarray(lut, bool), out.view(np.uint8))
    return out


@njit(cache=True, nogil=True)
def _life(indptr, indices, alive, lut, out):
    top = lut.shape[0] - 1
    for c in range(indptr.size - 1):
        k = 0
        for e in range(indptr[c], indptr[c + 1]):
            k += alive[indices[e]]
        out[c] = lut[min(k, top), alive[c]]


# --------------------------------------------------------------------------------------------
# Voronoi propagation

class VoronoiWork:
    """Per-graph buffers of the compiled Voronoi step (entries, cells) and the transposed graph."""

    def __init__(self, graph: CellGraph) -> None:
        nnz, n = graph.indices.size, graph.n_cells
        self.u = np.empty(nnz)
        self.keys = np.empty(nnz)
        self.ok = np.empty(nnz, bool)
        self.mark = np.zeros(n, bool)
        self.buf = np.empty(n, np.int64)
        back = graph.incoming
        self.indices = compact_indices(graph)
        self.back_indptr, self.back_indices = back.indptr, compact_indices(back)
        self.diag = graph.is_diagonal if graph.direction is not None else np.zeros(0, bool)


def voronoi_step(grow, rng: np.random.Generator) -> int:
    """``VoronoiGrowth.step`` compiled: labels updated in place, frontier replaced."""
    front = grow.frontier
    if len(front) == 0:
        return 0
    g = grow.graph
    work = grow.__dict__.get(_ATTR)
    if work is None:
        work = grow.__dict__[_ATTR] = VoronoiWork(g)
    front = np.ascontiguousarray(front, np.int64)
    ne = _entries(g.indptr, front)
    rng.random(out=work.u[:ne])
    nok = _candidates(g.indptr, work.indices, grow.labels, work.diag, work.diag.size > 0,
                      float(grow.p_diagonal), front, work.u, work.ok)
    if nok == 0:                      # pick_one_per_row draws nothing then
        grow.frontier = front[grow.labels[front] == 0]
        return 0
    rng.random(out=work.keys[:nok])
    nnew, nf = _pick(g.indptr, work.indices, work.back_indptr, work.back_indices, grow.labels, front,
                     work.ok, work.keys, work.mark, work.buf)
    grow.frontier = np.sort(work.buf[:nf])
    return int(nnew)


@njit(cache=True, nogil=True)
def _entries(indptr, front):
    ne = 0
    for c in front:
        ne += indptr[c + 1] - indptr[c]
    return ne


@njit(cache=True, nogil=True)
def _candidates(indptr, indices, labels, diag, has_diag, p_diagonal, front, u, ok):
    """ok per frontier entry: a labelled source, side link or diagonal draw below P."""
    e = 0
    nok = 0
    for c in front:
        for j in range(indptr[c], indptr[c + 1]):
            good = labels[indices[j]] > 0 and (not (has_diag and diag[j]) or u[e] < p_diagonal)
            ok[e] = good
            nok += good
            e += 1
    return nok


@njit(cache=True, nogil=True, inline="always")
def _unlabelled_of(indptr, indices, c, labels, mark, buf, nf):
    """Append c's unmarked, unlabelled neighbours to buf[nf:]; returns the new length."""
    for j in range(indptr[c], indptr[c + 1]):
        t = indices[j]
        if labels[t] == 0 and not mark[t]:
            mark[t] = True
            buf[nf] = t
            nf += 1
    return nf


@njit(cache=True, nogil=True)
def _pick(indptr, indices, bptr, bidx, labels, front, ok, keys, mark, buf):
    """Per frontier cell the candidate of smallest key passes its label (labels in place; a
    candidate's source was labelled before the step, so in-place writes change no choice).
    buf[:nf] = the next frontier, unsorted (mark is left clear)."""
    e = 0
    k = 0
    nnew = 0
    nf = 0
    for c in front:
        best = -1
        bkey = 2.0
        for j in range(indptr[c], indptr[c + 1]):
            if ok[e]:
                if keys[k] < bkey:
                    bkey = keys[k]
                    best = j
                k += 1
            e += 1
        if best >= 0:
            labels[c] = labels[indices[best]]
            nnew += 1
    for c in front:                   # still unlabelled frontier cells, and the unlabelled
        if labels[c] == 0:            # cells next to (either way) a new label
            if not mark[c]:
                mark[c] = True
                buf[nf] = c
                nf += 1
            continue
        nf = _unlabelled_of(indptr, indices, c, labels, mark, buf, nf)
        nf = _unlabelled_of(bptr, bidx, c, labels, mark, buf, nf)
    for i in range(nf):
        mark[buf[i]] = False
    return nnew, nf
