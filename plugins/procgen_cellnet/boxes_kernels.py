"""Compiled (numba) 27-box link search over the sparse box index (section 4.2-4.3, Figure 3).

Why: the numpy search (:func:`boxes.pairs_within`) tests about three candidates per link,
window by window through fancy indexing, and then sorts the links; a compiled loop walks the
same structure the paper walks (box after box, the 13 forward neighbour boxes of the half
stencil, cell against cell) at several times its speed.
Imported only through :func:`procgen.accel.kernels` (this module needs numba).

Same results, exactly: the neighbour boxes are found in the same packed sorted keys (a merge
instead of a binary search, since the keys plus one offset stay sorted), a pair is a link when
dx^2 + dy^2 + dz^2 (in that order, float64, no fused multiply-add) is below radius^2 - the
expression of ``boxes._within`` - and every pair is met once (same box: only the cells after a
cell; other boxes: the half stencil).  The links are written straight into rows i < j sorted by
(i, j) through a per-cell CSR (count, then fill, then sort each short row), which is
``canonical_links``' order without its global sort (tests/test_cellnet_network.py).
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def _neighbour_box(packed: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """(B, len(offsets)) id of the box at each packed offset of every box, -1 if empty."""
    nb = np.full((len(packed), len(offsets)), -1, np.int64)
    for o in range(len(offsets)):
        off = offsets[o]
        j = 0
        for b in range(len(packed)):          # packed + off is sorted too: one merge pass
            want = packed[b] + off
            while j < len(packed) and packed[j] < want:
                j += 1
            if j < len(packed) and packed[j] == want:
                nb[b, o] = j
    return nb


@njit(cache=True)
def _visit(nb, start, order, x, y, z, r2, count, fill, cursor, partner):
    """Every pair closer than sqrt(r2) once: counts per lower cell id (``fill`` False) or
    writes the higher id into that cell's row (``fill`` True)."""
    for a in range(len(start) - 1):
        for s in range(start[a], start[a + 1]):
            xi, yi, zi = x[s], y[s], z[s]
            ci = order[s]
            for o in range(-1, nb.shape[1]):
                if o < 0:
                    t0, t1 = s + 1, start[a + 1]           # the same box: cells after this one
                else:
                    b = nb[a, o]
                    if b < 0:
                        continue
                    t0, t1 = start[b], start[b + 1]
                for t in range(t0, t1):
                    dx = xi - x[t]
                    dy = yi - y[t]
                    dz = zi - z[t]
                    d2 = dx * dx
                    d2 += dy * dy
                    d2 += dz * dz
                    if d2 < r2:
                        cj = order[t]
                        lo, hi = (ci, cj) if ci < cj else (cj, ci)
                        if fill:
                            partner[cursor[lo]] = hi
                            cursor[lo] += 1
                        else:
                            count[lo] += 1


@njit(cache=True)
def _links(packed, offsets, start, order, x, y, z, r2, n):
    nb = _neighbour_box(packed, offsets)
    count = np.zeros(n, np.int64)
    empty = np.zeros(0, np.int64)
    _visit(nb, start, order, x, y, z, r2, count, False, empty, empty)
    row = np.zeros(n + 1, np.int64)
    for i in range(n):
        row[i + 1] = row[i] + count[i]
    cursor = row[:-1].copy()
    partner = np.empty(row[n], np.int64)
    _visit(nb, start, order, x, y, z, r2, count, True, cursor, partner)
    out = np.empty((row[n], 2), np.int64)
    for i in range(n):
        r0, r1 = row[i], row[i + 1]
        for k in range(r0 + 1, r1):                       # insertion sort of a short row
            v = partner[k]
            m = k - 1
            while m >= r0 and partner[m] > v:
                partner[m + 1] = partner[m]
                m -= 1
            partner[m + 1] = v
        for k in range(r0, r1):
            out[k, 0] = i
            out[k, 1] = partner[k]
    return out


def pairs_within(packed: np.ndarray, offsets: np.ndarray, start: np.ndarray, order: np.ndarray,
                 cols: tuple[np.ndarray, np.ndarray, np.ndarray], radius: float) -> np.ndarray:
    """Links (i < j, sorted) from packed sorted box keys, packed half-stencil offsets, the
    box -> cells CSR and the coordinates in box order."""
    return _links(packed, offsets, start, order, cols[0], cols[1], cols[2], radius * radius,
                  len(order))
