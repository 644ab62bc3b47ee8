"""Compiled (numba) snaxel events: finding the arriving snaxel and the common (simple) birth.

Why: a topology event costs a handful of O(N_s) numpy passes (find the edge, mark the
w-snaxels, cut and concatenate the chain) plus ~20 small numpy calls for the children, i.e. tens
of microseconds of interpreter overhead per event for ~2 events per step.  Here ``find`` is one
compiled scan and a simple birth (``Snake._birth_simple``: the w-snaxels are one stretch of the
chain, w's unvisited neighbours one angular run, ~95% of births) is one compiled call that
checks the case, builds the children and writes the new chain.  Every other birth (a
non-connected merge, holes) returns False and runs the numpy path unchanged.  Imported only
through :func:`procgen.accel.kernels` (this module needs numba).

Same results, exactly: the children's geometry uses the numpy path's expressions in the same
order (hypot, clip, divisions), so chains are bit-identical (tests/test_snaxel_events_numba.py
grows whole clouds both ways).  The new chain is allocated per birth like the numpy path's
(its size is the chain's, not the domain's).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .snake import CURVE, DX, DY, ELEN, OX, OY, POS, T, U, UNVISITED, V, VISITED


def find(snake, u: int, v: int) -> int:
    """``Snake.find`` compiled."""
    return int(_find(snake.ints, u, v))


def birth(snake, p: int, carry: float) -> bool:
    """``Snake.birth`` for a simple birth (state, counters and chain updated); False, with
    nothing changed, when the birth is not simple (the caller runs the numpy path)."""
    ints = snake.ints
    w = int(ints[p, V])
    ring = np.asarray(snake.topo.neighbours(w), np.int64)
    res = _simple(ints, snake.flts, p, w, ring, snake.state, snake.topo.points, float(carry),
                  snake.min_offset)
    if res is None:
        return False
    snake.ints, snake.flts, n_w = res
    snake.state[w] = VISITED
    snake.births += 1
    snake.merges += int(n_w) - 1
    return True


@njit(cache=True, nogil=True)
def _find(ints, u, v):
    for i in range(ints.shape[0]):
        if ints[i, V] == v and ints[i, U] == u:
            return i
    return -1


@njit(cache=True, nogil=True)
def _simple(ints, flts, p, w, ring, state, pts, carry, min_offset):
    n = ints.shape[0]
    i = -1
    j = -1
    cnt = 0
    for k in range(n):
        if ints[k, V] == w:
            if i < 0:
                i = k
            j = k
            cnt += 1
    if j - i + 1 != cnt:
        return None
    d = ring.size
    j0 = -1
    for q in range(d):
        if state[ring[q]] != UNVISITED:
            j0 = q
            break
    if j0 < 0:                                  # every neighbour unvisited
        return None
    first = -1
    last = -1
    for q in range(d):
        if state[ring[(j0 + q) % d]] == UNVISITED:
            if first < 0:
                first = q
            last = q
    if first < 0:                               # no unvisited neighbour: the numpy path raises
        return None
    for q in range(first, last + 1):
        if state[ring[(j0 + q) % d]] != UNVISITED:
            return None
    nc = last - first + 1
    m = n - cnt + nc
    oi = np.empty((m, 3), np.int64)
    of = np.empty((m, 7), np.float64)
    at = i                                     # (i == 0: the first child becomes the head)
    for k in range(i):
        oi[k] = ints[k]
        of[k] = flts[k]
    t_parent = flts[p, T]
    curve = ints[p, CURVE]
    wx = pts[w, 0]
    wy = pts[w, 1]
    for q in range(nc):
        vtx = ring[(j0 + first + q) % d]
        dx = pts[vtx, 0] - wx
        dy = pts[vtx, 1] - wy
        elen = math.hypot(dx, dy)
        r = at + q
        oi[r, U] = w
        oi[r, V] = vtx
        oi[r, CURVE] = curve
        of[r, POS] = min(max(carry, min_offset * elen), 0.5 * elen)
        of[r, T] = t_parent
        of[r, ELEN] = elen
        of[r, OX] = wx
        of[r, OY] = wy
        of[r, DX] = dx / elen
        of[r, DY] = dy / elen
    r = at + nc
    for k in range(j + 1, n):
        oi[r] = ints[k]
        of[r] = flts[k]
        r += 1
    return oi, of, cnt
