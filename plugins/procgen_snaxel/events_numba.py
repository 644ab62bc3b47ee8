"""Compiled (numba) snaxel events: all the arrivals of a step in one call, and the per-event pieces.

Why: a topology event costs a handful of O(N_s) numpy passes (find the edge, mark the
w-snaxels, cut and concatenate the chain) plus ~20 small numpy calls for the children, i.e. tens
of microseconds of interpreter overhead per event for ~2 events per step; calling a compiled
kernel per event still paid the Python call, the argument checks and a new chain per birth.
:func:`step_events` takes the step's arrivals in order (the numpy loop of
``CloudGrowth.step``) and handles them in one compiled call: skip a vertex already entered,
find the arriving snaxel, and do a simple birth (``Snake._birth_simple``: the w-snaxels are one
stretch of the chain, w's unvisited neighbours one angular run, ~95% of births) in place in a
chain buffer with room to grow.  At the first birth that is not simple (a non-connected merge,
holes) the kernel stops, ``Snake.birth`` (numpy) handles that event, and the kernel resumes at
the next one.  :func:`find` and :func:`birth` are the per-event forms ``Snake.find`` /
``Snake.birth`` use (thesis-literal head-on merges stay on that path), the same kernel on
one event.  Imported only through
:func:`procgen.accel.kernels` (this module needs numba).

Same results, exactly: the children's geometry uses the numpy path's expressions in the same
order (hypot, clip, divisions), so chains are bit-identical (tests/test_snaxel_events_numba.py
grows whole clouds both ways).  Memory: one chain buffer per step, sized to the chain plus room
for the step's children (never the domain's size).
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
    one = slice(p, p + 1)
    return _handle(snake, snake.ints[one, U], snake.ints[one, V], np.array([carry], np.float64), True) == 1


@njit(cache=True, nogil=True)
def _find(ints, u, v):
    for i in range(ints.shape[0]):
        if ints[i, V] == v and ints[i, U] == u:
            return i
    return -1

ROOM = 8
"""Rows of room per event in the chain buffer (a birth adds at most degree - 2 snaxels; the
kernel asks for a bigger buffer when a step needs more)."""


def step_events(snake, u: np.ndarray, w: np.ndarray, carry: np.ndarray) -> None:
    """The arrivals (u -> w with ``carry`` past w each, in arrival order) of one step, like
    ``CloudGrowth.step``'s loop over ``Snake.find`` / ``Snake.birth``."""
    _handle(snake, np.ascontiguousarray(u, np.int64), np.ascontiguousarray(w, np.int64),
            np.ascontiguousarray(carry, np.float64), False)


def _handle(snake, u: np.ndarray, w: np.ndarray, carry: np.ndarray, stop: bool) -> int:
    """Events in order by the kernel; one that is not simple goes to ``Snake.birth`` (numpy),
    or with ``stop`` ends the call.  Returns the number of events handled."""
    n = len(snake.ints)
    ints, flts = _room(snake.ints, snake.flts, n, n + ROOM * len(w) + 16)
    k = 0
    while k < len(w):
        topo = snake.topo
        k, n, births, merges, p = _events(ints, flts, n, u, w, carry, k, topo.ring, topo.ring_lo,
                                          topo.ring_hi, snake.state, topo.points, snake.min_offset)
        snake.births += births
        snake.merges += merges
        if k == len(w) or stop and p >= 0:
            break
        if p < 0:                              # no room for the children: a bigger buffer
            ints, flts = _room(ints, flts, n, 2 * len(ints))
            continue
        snake.ints, snake.flts = ints[:n], flts[:n]
        snake.birth(p, float(carry[k]))        # not a simple birth: the numpy path
        n = len(snake.ints)
        ints, flts = _room(snake.ints, snake.flts, n, n + ROOM * (len(w) - k) + 16)
        k += 1
    if k:
        snake.ints, snake.flts = ints[:n], flts[:n]
    return k


def _room(ints: np.ndarray, flts: np.ndarray, n: int, cap: int) -> tuple[np.ndarray, np.ndarray]:
    """New chain buffers of ``cap`` rows holding the first n rows of ints/flts."""
    oi, of = np.empty((cap, 3), np.int64), np.empty((cap, 7), np.float64)
    oi[:n], of[:n] = ints[:n], flts[:n]
    return oi, of


@njit(cache=True, nogil=True)
def _events(ints, flts, n, eu, ew, ecarry, k, ring, ring_lo, ring_hi, state, pts, min_offset):
    """Events k.. in order on the chain ints/flts[:n] (in place).  Returns (k, n, births,
    merges, p): k == len(ew) when all are done; else event k is not simple (p = its snaxel)
    or its children do not fit (p = -1)."""
    births = 0
    merges = 0
    cap = ints.shape[0]
    while k < ew.size:
        w = ew[k]
        if state[w] != UNVISITED:              # already entered this step: merged there
            k += 1
            continue
        p = _find(ints[:n], eu[k], w)
        if p < 0:
            k += 1
            continue
        # the w-snaxels: one stretch [i, j] of the chain?
        i = -1
        j = -1
        cnt = 0
        for q in range(n):
            if ints[q, V] == w:
                if i < 0:
                    i = q
                j = q
                cnt += 1
        lo = ring_lo[w]
        d = ring_hi[w] - lo
        j0 = -1                                # a visited neighbour to start the ring at
        for q in range(d):
            if state[ring[lo + q]] != UNVISITED:
                j0 = q
                break
        first = -1
        last = -1
        if j0 >= 0:
            for q in range(d):
                if state[ring[lo + (j0 + q) % d]] == UNVISITED:
                    if first < 0:
                        first = q
                    last = q
        simple = j - i + 1 == cnt and first >= 0
        if simple:
            for q in range(first, last + 1):
                if state[ring[lo + (j0 + q) % d]] != UNVISITED:
                    simple = False
                    break
        if not simple:
            return k, n, births, merges, p
        nc = last - first + 1
        m = n - cnt + nc
        if m > cap:
            return k, n, births, merges, -1
        t_parent = flts[p, T]
        curve = ints[p, CURVE]
        shift = nc - cnt                       # the tail [j + 1, n) moves by this much
        if shift > 0:
            for q in range(n - 1, j, -1):
                _move(ints, flts, q, q + shift)
        elif shift < 0:
            for q in range(j + 1, n):
                _move(ints, flts, q, q + shift)
        wx = pts[w, 0]
        wy = pts[w, 1]
        carry = ecarry[k]
        for q in range(nc):                    # the children replace [i, j] (i == 0: the
            vtx = ring[lo + (j0 + first + q) % d]      # first child becomes the head)
            dx = pts[vtx, 0] - wx
            dy = pts[vtx, 1] - wy
            elen = math.hypot(dx, dy)
            r = i + q
            ints[r, U] = w
            ints[r, V] = vtx
            ints[r, CURVE] = curve
            flts[r, POS] = min(max(carry, min_offset * elen), 0.5 * elen)
            flts[r, T] = t_parent
            flts[r, ELEN] = elen
            flts[r, OX] = wx
            flts[r, OY] = wy
            flts[r, DX] = dx / elen
            flts[r, DY] = dy / elen
        n = m
        state[w] = VISITED
        births += 1
        merges += cnt - 1
        k += 1
    return k, n, births, merges, 0


@njit(cache=True, nogil=True, inline="always")
def _move(ints, flts, src, dst):
    """Chain row src to row dst, element by element (no row views)."""
    for c in range(3):
        ints[dst, c] = ints[src, c]
    for c in range(7):
        flts[dst, c] = flts[src, c]
