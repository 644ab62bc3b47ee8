"""Compiled rounds of the maximal Poisson-disk sampler (procgen.builtin.poisson), for numba.

Why a second formulation: the numpy path keeps, per open sub-cell, the list of sample disks
touching it (flat pairs) because whole-array code cannot afford to look around each sub-cell;
building, filtering and splitting those pairs cost more than the dart throwing itself. A
compiled loop can simply read the background grid: a sub-cell is closed exactly when its cell
holds a sample or one sample of the 5x5 block around its cell contains it (the single-disk
coverage test of Ebeida et al. 2011), which is the set the pairs describe, so both paths keep
the same open sub-cells in the same order and draw the same random numbers. Every float
expression below is the numpy path's (``_Grid.bounds``, ``_contains``, ``_split_pairs``,
``_darts``), evaluated in the same order, so the samples are bit-identical
(tests/test_poisson.py checks it). Random numbers stay with numpy's Generator (drawn by the
caller into preallocated buffers); these loops only consume them.

Importing this module needs numba (the ``fast`` extra); poisson.py imports it only through
procgen.accel.kernels. Kernels are cached on disk by numba (compiled once per install).
"""
from __future__ import annotations

import numba

from .poisson import _PAD as PAD  # grid padding: the 5x5 block of any cell is inside the grid

jit = numba.njit(cache=True, nogil=True)

RING1 = 8
"""The neighbour offsets come nearest first (``_Grid.near_first``): the first 8 are the cells
touching the own cell. A sample two cells away cannot contain a sub-cell of level 0 or 1 that
the domain does not clip: along that axis its farthest edge is at least 1.5 cell sides away,
and (1.5 side)^2 = 1.125 r^2 > r^2 (12% margin, far above rounding). Clipped sub-cells lie
in the last row or column of cells, so the shortcut is taken only away from those."""


@jit
def _reach(c, margin, level, stride, nx, ny, nbr):
    """How many of the near-first neighbour offsets can hold a disk containing a sub-cell of
    ``level`` in a cell up to ``margin`` cells from cell c (see RING1)."""
    row = c // stride
    if level <= 1 and row + margin < ny - 1 + PAD and c - row * stride + margin < nx - 1 + PAD:
        return RING1
    return nbr.size


@jit
def count_darts(i, j, n, u, cdf, h, x0, y0, x1, y1, lam, full, count, clip, mean):
    """Darts per open sub-cell: inverse-CDF Poisson of ``u`` (numpy's searchsorted, right side);
    for sub-cells clipped by the domain, their index and Poisson mean go to ``clip``/``mean``
    (the caller draws those with ``rng.poisson``). Returns the number of clipped sub-cells."""
    nclip = 0
    for k in range(n):
        c = 0
        while c < cdf.size and cdf[c] <= u[k]:
            c += 1
        count[k] = c
        lox = x0 + j[k] * h
        loy = y0 + i[k] * h
        hix = min(x0 + (j[k] + 1) * h, x1)
        hiy = min(y0 + (i[k] + 1) * h, y1)
        if hix >= x1 or hiy >= y1:
            clip[nclip] = k
            mean[nclip] = lam * ((hix - lox) * (hiy - loy) / full)
            nclip += 1
    return nclip


@jit
def throw(i, j, n, level, count, u, perm, ndart, h, x0, y0, x1, y1, xmax, ymax, stride,
          p, nbr, r2, dart, out, nout, room, wcell):
    """One round of darts: place ``count[k]`` darts uniformly in each open sub-cell k (uniforms
    ``u``: all x first, then all y), throw them one at a time in decreasing priority ``perm``
    against the grid (a dart dies within r of a sample or in a taken cell), write the first
    ``room`` accepted ones to ``out[nout:]`` and the cells of all of them to ``wcell``.
    Returns the number accepted.

    Darts are stored at their rank (highest priority first): scattered writes while placing
    them, then one sequential pass, instead of a random read per dart while throwing."""
    d = 0
    for k in range(n):
        lox = x0 + j[k] * h
        loy = y0 + i[k] * h
        wx = min(x0 + (j[k] + 1) * h, x1) - lox
        wy = min(y0 + (i[k] + 1) * h, y1) - loy
        c = ((i[k] >> level) + PAD) * stride + (j[k] >> level) + PAD
        for _ in range(count[k]):
            t = ndart - 1 - perm[d]
            dart[t, 0] = min(lox + u[d] * wx, xmax)
            dart[t, 1] = min(loy + u[ndart + d] * wy, ymax)
            dart[t, 2] = c
            d += 1
    won = 0
    for t in range(ndart):
        c = int(dart[t, 2])
        if p[c, 0] == p[c, 0]:  # cell already holds a sample
            continue
        x = dart[t, 0]
        y = dart[t, 1]
        ok = True
        for m in range(nbr.size):  # an empty cell holds NaN: never closer than r
            ex = p[c + nbr[m], 0] - x
            ey = p[c + nbr[m], 1] - y
            if ex * ex + ey * ey < r2:
                ok = False
                break
        if ok:
            p[c, 0] = x
            p[c, 1] = y
            if won < room:
                out[nout + won, 0] = x
                out[nout + won, 1] = y
            wcell[won] = c
            won += 1
    return won


@jit
def close(i, j, n, level, h, x0, y0, x1, y1, stride, nx, ny, p, nbr, r2, wcell, nwon, first, shut):
    """Drop, in place and in order, the open sub-cells whose cell a new sample took or which
    one new disk contains (older samples closed theirs already). The numpy path also asks that
    the disk touch the sub-cell; a disk reaching the farthest corner always does (a sub-cell
    is never empty, and ``touch2`` exceeds r^2 by 16 ulps of the coordinates). Sub-cells are sorted by cell:
    ``first`` (grid-sized, all -1 between calls) maps a cell to its first open sub-cell, and
    each new sample visits only the open sub-cells of its 5x5 block. Returns how many stay open."""
    for k in range(n):
        c = ((i[k] >> level) + PAD) * stride + (j[k] >> level) + PAD
        if first[c] < 0:
            first[c] = k
        shut[k] = False
    wcell[:nwon].sort()  # visit the new samples in cell order: neighbouring look-ups stay cached
    for w in range(nwon):
        cw = wcell[w]
        k = first[cw]
        while k >= 0 and k < n and ((i[k] >> level) + PAD) * stride + (j[k] >> level) + PAD == cw:
            shut[k] = True
            k += 1
        sx = p[cw, 0]
        sy = p[cw, 1]
        for m in range(_reach(cw, 2, level, stride, nx, ny, nbr)):
            c = cw + nbr[m]
            k = first[c]
            if k < 0:
                continue
            while k < n and ((i[k] >> level) + PAD) * stride + (j[k] >> level) + PAD == c:
                if not shut[k]:
                    lox = x0 + j[k] * h
                    loy = y0 + i[k] * h
                    hix = min(x0 + (j[k] + 1) * h, x1)
                    hiy = min(y0 + (i[k] + 1) * h, y1)
                    fx = max(sx - lox, hix - sx)  # farthest corner within r (``_contains``)
                    fy = max(sy - loy, hiy - sy)
                    shut[k] = fx * fx + fy * fy <= r2
                k += 1
    m = 0
    for k in range(n):
        first[((i[k] >> level) + PAD) * stride + (j[k] >> level) + PAD] = -1
        if not shut[k]:
            i[m] = i[k]
            j[m] = j[k]
            m += 1
    return m


@jit
def split(i, j, n, level, hc, x0, y0, x1, y1, stride, nx, ny, p, nbr, r2, ci, cj):
    """Children (level + 1, quadrant order 2 * upper + right) of the n open sub-cells that lie in
    the domain and that no disk contains, written in order to ``ci``/``cj`` while they fit.
    Returns how many children there are (more than ``ci.size``: the caller grows the buffers
    and calls again).

    A disk contains a child when its farthest corner is within r: per axis the larger square of
    the distances to the child's two edges (the numpy path's ``_split_pairs``: the larger
    distance, squared, is the same float). The three edges per axis (low, middle clipped to the
    domain, high) are shared by the four children, so each disk of the block costs six squares,
    without branches (an empty cell's NaN fails every test). Containment implies touching for
    these non-empty children, so the touch test of the numpy path changes nothing here."""
    m = 0
    cap = ci.size
    h = 2.0 * hc
    for k in range(n):
        c = ((i[k] >> level) + PAD) * stride + (j[k] >> level) + PAD
        lox = x0 + j[k] * h
        loy = y0 + i[k] * h
        hix = min(x0 + (j[k] + 1) * h, x1)
        hiy = min(y0 + (i[k] + 1) * h, y1)
        mx = x0 + (2 * j[k] + 1) * hc
        my = y0 + (2 * i[k] + 1) * hc
        midx = min(mx, x1)
        midy = min(my, y1)
        in0 = in1 = in2 = in3 = False
        for t in range(_reach(c, 0, level + 1, stride, nx, ny, nbr)):
            sx = p[c + nbr[t], 0]
            sy = p[c + nbr[t], 1]
            a0 = sx - lox
            a1 = sx - midx
            a2 = hix - sx
            b0 = sy - loy
            b1 = sy - midy
            b2 = hiy - sy
            a1 *= a1
            b1 *= b1
            fl = max(a0 * a0, a1)
            fh = max(a1, a2 * a2)
            gl = max(b0 * b0, b1)
            gh = max(b1, b2 * b2)
            in0 |= fl + gl <= r2
            in1 |= fh + gl <= r2
            in2 |= fl + gh <= r2
            in3 |= fh + gh <= r2
        for q in range(4):
            qy = q >> 1
            qx = q & 1
            if (qy and not my < y1) or (qx and not mx < x1):
                continue
            if (in0, in1, in2, in3)[q]:
                continue
            if m < cap:
                ci[m] = 2 * i[k] + qy
                cj[m] = 2 * j[k] + qx
            m += 1
    return m

