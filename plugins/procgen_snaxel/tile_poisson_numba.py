"""The tile sampler's dart loop compiled by numba: the lazy tessellation's fast path.

The same method as :func:`procgen_snaxel.tile_poisson.sample_rounds` (one round of darts after
another; see that module), written as one sequential loop over the tile, which numba compiles:
~0.3 ms a 64 x 64 tile against ~5-10 ms for the numpy rounds. The float expressions are the
numpy path's, in the same order, so both give the same samples bit for bit
(tests/test_snaxel_tile_sampler.py). Imported only through :func:`procgen.accel.kernels` (this
module needs numba).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from .tile_poisson import MAX_LEVEL, SPLIT_BELOW


@njit(cache=True, nogil=True)
def sample_rounds(u, x0, y0, xmax, ymax, side, n, r, fx, fy):  # noqa: C901 - one compiled loop
    """``tile_poisson.sample_rounds`` as one loop: darts one after another in the round's order."""
    s = side / n
    r2 = r * r
    pad = n + 4
    grid = np.full(pad * pad, -1, np.int64)
    cap = n * n + fx.shape[0]
    px = np.empty(cap)
    py = np.empty(cap)
    npts = 0
    for k in range(fx.shape[0]):
        ci = int(math.floor((fx[k] - x0) / s)) + 2
        cj = int(math.floor((fy[k] - y0) / s)) + 2
        if 0 <= ci < pad and 0 <= cj < pad:
            grid[cj * pad + ci] = npts
            px[npts] = fx[k]
            py[npts] = fy[k]
            npts += 1
    nfixed = npts
    # open sub-cells (level 0: the cells)
    ai = np.empty(n * n, np.int64)
    aj = np.empty(n * n, np.int64)
    for j in range(n):
        for i in range(n):
            ai[j * n + i] = i
            aj[j * n + i] = j
    count = n * n
    level = 0
    pos = 0
    floor_rounds = 0
    while count > 0:
        if pos + 3 * count > u.shape[0]:
            return np.empty((0, 2)), -1
        order = np.argsort(u[pos:pos + count], kind="mergesort")
        pos += count
        w = s / (1 << level)
        hits = 0
        for k in range(count):
            i = ai[order[k]]
            j = aj[order[k]]
            ci = (i >> level) + 2
            cj = (j >> level) + 2
            x = min(x0 + (i + u[pos]) * w, xmax)
            y = min(y0 + (j + u[pos + 1]) * w, ymax)
            pos += 2
            if grid[cj * pad + ci] >= 0:
                continue
            ok = True
            for dj in range(-2, 3):
                for di in range(-2, 3):
                    q = grid[(cj + dj) * pad + ci + di]
                    if q >= 0 and (px[q] - x) ** 2 + (py[q] - y) ** 2 < r2:
                        ok = False
            if ok:
                grid[cj * pad + ci] = npts
                px[npts] = x
                py[npts] = y
                npts += 1
                hits += 1
        split = hits < SPLIT_BELOW * count and level < MAX_LEVEL
        if level >= MAX_LEVEL:
            floor_rounds += 1
            if floor_rounds >= 64:
                break
        # keep (or split into four and keep) the sub-cells whose cell is empty and that no
        # single disk contains (farthest corner within r)
        kids = 4 if split else 1
        nl = level + 1 if split else level
        nw = s / (1 << nl)
        bi = np.empty(count * kids, np.int64)
        bj = np.empty(count * kids, np.int64)
        m = 0
        for k in range(count):
            for c in range(kids):
                i = ai[k] * 2 + (c & 1) if split else ai[k]
                j = aj[k] * 2 + (c >> 1) if split else aj[k]
                ci = (i >> nl) + 2
                cj = (j >> nl) + 2
                if grid[cj * pad + ci] >= 0:
                    continue
                xa = x0 + i * nw
                xb = xa + nw
                ya = y0 + j * nw
                yb = ya + nw
                covered = False
                for dj in range(-2, 3):
                    for di in range(-2, 3):
                        q = grid[(cj + dj) * pad + ci + di]
                        if q >= 0:
                            dx = max(abs(xa - px[q]), abs(xb - px[q]))
                            dy = max(abs(ya - py[q]), abs(yb - py[q]))
                            if dx * dx + dy * dy <= r2:
                                covered = True
                if not covered:
                    bi[m] = i
                    bj[m] = j
                    m += 1
        ai = bi[:m]
        aj = bj[:m]
        count = m
        level = nl
    out = np.empty((npts - nfixed, 2))
    out[:, 0] = px[nfixed:npts]
    out[:, 1] = py[nfixed:npts]
    return out, pos
