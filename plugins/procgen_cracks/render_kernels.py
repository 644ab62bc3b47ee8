"""Compiled (numba) scan of the capsule micro-cells: ``render._accumulate`` in one loop.

Why: the numpy path materialises every (piece, micro-cell) pair of the row spans, filters and
gathers them several times and integrates the survivors in batches of (pairs, 8 pieces, 3
Gauss points) temporaries; its cost per covered micro-cell grows with the crack widths (a
wide crack's pieces overlap over many micro-cells).  Here one loop walks the spans, tests each
micro-cell's distance, bounds and integrates it in registers and keeps the maximum, allocating
nothing per pair.  Imported only through :func:`procgen.accel.kernels` (needs numba).

Same bytes: every float expression keeps the numpy path's operations in its order (products
left to right, ``np.linalg.norm`` of a 2-vector as sqrt(x*x + y*y), the 24 Gauss terms of a
micro-cell summed in numpy's pairwise order, procgen.pairwise), and the result is a maximum,
which no visiting order changes: a pair is skipped only when its upper bound is below the
micro-cell's current value, as on the numpy path (tests/test_crack_render_kernels.py compares
the coverage and the exported files).
Serial: the micro-cells of one crack are reached from several pieces, so a parallel loop would
race on the maximum.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from procgen.pairwise import pairwise_sum

# profile codes, in render.PROFILES order
CONSTANT, V_LINEAR, V_PARA_A, V_PARA_B, U_LINEAR, U_PARA_A, U_PARA_B = range(7)

_GL_X = np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
_GL_W = np.array([5.0, 8.0, 5.0]) / 9.0


@njit(cache=True, nogil=True, inline="always")
def _constants(ct, cs, profile, saturation):
    """render.profile_constants for one width: (k, d, constant)."""
    u = profile >= U_LINEAR
    d = 0.5 * ct * saturation if u else 0.0
    usable = (ct * (1.0 - saturation) >= cs) if u else (ct >= cs)
    constant = (not usable) or profile == CONSTANT
    if profile == CONSTANT:
        den = 1.0 * cs
    elif profile == V_LINEAR:
        den = 0.5 * cs * (ct - 0.5 * cs)
    elif profile == V_PARA_A:
        den = 0.25 * cs * (ct * ct - cs ** 2 / 3.0)
    elif profile == V_PARA_B:
        den = 0.25 * cs * (ct * ct - ct * cs + cs ** 2 / 3.0)
    elif profile == U_LINEAR:
        den = cs * (0.5 * ct - 0.25 * cs - d)
    elif profile == U_PARA_A:
        den = cs * (0.25 * (ct * ct) - cs ** 2 / 12.0 - d * (d + 0.5 * cs))
    else:
        den = cs * (0.25 * (cs ** 2 / 3.0 + ct * ct - cs * ct) + d * (d + 0.5 * cs - ct))
    if constant:
        return 1.0 / cs, 0.0, True
    return 1.0 / den, d, False


@njit(cache=True, nogil=True, inline="always")
def _density(x, ct, k, d, constant, cs, profile):
    """render._density for one x >= 0."""
    h = 0.5 * ct
    if profile == CONSTANT:
        shape = 1.0
    elif profile == V_LINEAR or profile == U_LINEAR:
        shape = h - x
    elif profile == V_PARA_A or profile == U_PARA_A:
        shape = h * h - x * x
    else:
        shape = (x - h) * (x - h)
    f = 1.0 / cs if (constant or x <= d) else k * shape
    return f if x <= h else 0.0


@njit(cache=True, nogil=True, inline="always")
def _chord(t, cs, c, s):
    """render._chord for one offset."""
    h = 0.5 * cs * (c + s)
    top = cs / max(c, s)
    ramp = (h - abs(t)) / max(c * s, 1e-12)
    return max(min(top, ramp), 0.0)


@njit(cache=True, nogil=True, inline="always")
def _clip(x, lo, hi):
    return min(max(x, lo), hi)


@njit(cache=True, nogil=True)
def coverage(dist, c, s, ct, cs, profile, saturation, gl_x, gl_w, bp, terms):
    """render.band_coverage for one micro-cell (``bp`` (9,), ``terms`` (24,): scratch)."""
    kk, d, constant = _constants(ct, cs, profile, saturation)
    h = 0.5 * cs * (c + s)
    g = 0.5 * cs * abs(c - s)
    half = 0.5 * ct
    lo, hi = dist - h, dist + h
    bp[0] = dist - h
    bp[1] = dist - g
    bp[2] = dist + g
    bp[3] = dist + h
    bp[4] = -half
    bp[5] = -d
    bp[6] = 0.0
    bp[7] = d
    bp[8] = half
    for i in range(9):                                  # clip, then insertion sort
        v = _clip(bp[i], lo, hi)
        m = i
        while m > 0 and bp[m - 1] > v:
            bp[m] = bp[m - 1]
            m -= 1
        bp[m] = v
    for i in range(8):
        mid = 0.5 * (bp[i] + bp[i + 1])
        rad = 0.5 * (bp[i + 1] - bp[i])
        for j in range(3):
            x = mid + rad * gl_x[j]
            f = _density(abs(x), ct, kk, d, constant, cs, profile)
            terms[3 * i + j] = f * _chord(x - dist, cs, c, s) * gl_w[j] * rad
    return _clip(pairwise_sum(terms, 0, 24) / cs, 0.0, 1.0)


@njit(cache=True, nogil=True, inline="always")
def _bound(dist, c, s, ct, cs, profile, saturation):
    """render.coverage_bound for one micro-cell."""
    kk, d, constant = _constants(ct, cs, profile, saturation)
    h = 0.5 * cs * (c + s)
    half = 0.5 * ct
    x0 = max(dist - h, 0.0)
    xd = max(x0, d)
    second = 0.0 if (constant or xd > half) else _density(xd, ct, kk, -1.0, constant, cs, profile)
    f = max(_density(x0, ct, kk, d, constant, cs, profile), second)
    inside = max(min(dist + h, half) - max(dist - h, -half), 0.0)
    area = min(cs * cs, inside * cs / max(c, s))
    return max(f, 0.0) * area / cs * (1.0 + 1e-6) + 1e-12


@njit(cache=True, nogil=True)
def accumulate(out, face, a, b, wa, wb, piece, my, x0, cols, k, cs, profile, saturation,
               nx, ny, grid_offset, lookup):
    """Raise ``out`` (flat float32 (n_cells * k * k)) to each micro-cell's largest coverage by
    the pieces whose row spans (piece, micro row, first column, columns) cover it."""
    bp = np.empty(9)
    terms = np.empty(24)
    gl_x, gl_w = _GL_X, _GL_W
    reach = cs * np.sqrt(0.5)
    last = max(len(lookup) - 1, 0)
    # as on the numpy path, the pairs beside a piece (projection inside it) first: they raise
    # the values that then prune most pairs off the pieces' ends (their round caps)
    for beside in (True, False):
        for r in range(len(piece)):
            p = piece[r]
            ax, ay, bx, by = a[p, 0], a[p, 1], b[p, 0], b[p, 1]
            abx, aby = bx - ax, by - ay
            ln2 = abx * abx + aby * aby
            ln = math.sqrt(ln2)
            c, s = abs(abx) / ln, abs(aby) / ln
            f = face[p]
            y = (my[r] + 0.5) * cs
            j = my[r] // k
            for mx in range(x0[r], x0[r] + cols[r]):
                x = (mx + 0.5) * cs
                t = _clip(((x - ax) * abx + (y - ay) * aby) / ln2, 0.0, 1.0)
                if (t > 0.0 and t < 1.0) != beside:
                    continue
                dx, dy = x - (ax + t * abx), y - (ay + t * aby)
                dist = math.sqrt(dx * dx + dy * dy)
                width = wa[p] + t * (wb[p] - wa[p])
                if not dist < 0.5 * width + reach:
                    continue
                i = mx // k
                if i < 0 or j < 0 or i >= nx[f] or j >= ny[f]:
                    continue
                cell = lookup[min(grid_offset[f] + i * ny[f] + j, last)]
                if cell < 0:
                    continue
                flat = (cell * k + mx % k) * k + my[r] % k
                if _bound(dist, c, s, width, cs, profile, saturation) < out[flat]:
                    continue
                cov = np.float32(coverage(dist, c, s, width, cs, profile, saturation, gl_x, gl_w,
                                          bp, terms))
                if cov > out[flat]:
                    out[flat] = cov
