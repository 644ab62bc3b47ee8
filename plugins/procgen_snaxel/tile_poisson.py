"""Maximal Poisson-disk sampling of one small square tile, compiled: the lazy tessellation's sampler.

Why not the core ``points.poisson_disk`` here: it is vectorised over a whole domain, and on a
64 x 64 tile (~200 samples) its ~12 rounds of ~30 numpy calls each cost ~15 ms, about 100 us a
sample, three times its per-sample cost on a whole domain; the ~200 tiles of a Chapter 4 cloud
then cost as much as the eager whole-domain tessellation saved (benchmarks/clouds.py). The same
method (Ebeida et al. 2011, "Efficient maximal Poisson-disk sampling", as the core uses it) is
written here as one sequential loop over the tile, compiled by numba when it is installed (the
``fast`` extra): ~0.3 ms a tile.

Method: a background grid of cells of side s <= r / sqrt(2) fitted exactly to the tile (a cell
holds at most one sample; points of a cell lie within two cells of every point that can conflict
with or cover it, since r / s < 2 for a tile >= 2 r), holding the ``fixed`` samples of the
neighbouring tiles in a 2-cell rim. Open sub-cells (cell empty, not inside one disk) receive one
dart each per round in a random order; a dart at least r from every sample is accepted. When
fewer than a tenth of a round's darts are accepted, every open sub-cell splits into four and
those inside one disk close. No open sub-cell left = every point of the tile is within r of a
sample (maximal), down to sub-cells 2**-MAX_LEVEL of a cell wide.

Random numbers come from the tile's own ``numpy`` Generator as a buffer of doubles; the loop
reports when it ran out, and the caller reruns it on a longer prefix of the same stream, so the
result depends only on the stream. Without numba (plain Python would take ~0.7 s a tile) the
tiles come from the core vectorised sampler: the same properties, other samples, so a cloud is
reproducible per install kind; run.json says which sampler ran (``cloud.tile_sampler``).
"""
from __future__ import annotations

import functools
import math

import numpy as np

from procgen.builtin.poisson import poisson_disk

MAX_LEVEL = 30
"""Deepest sub-cell level (sub-cells 2**-30 of a cell wide; only float-degenerate slivers, e.g.
a point exactly on three circles, can be left open there)."""

SPLIT_BELOW = 0.1
"""Split the open sub-cells when fewer than this fraction of a round's darts are accepted (the
core sampler's rule)."""


def _sample_loop(u, x0, y0, xmax, ymax, side, n, r, fx, fy):  # noqa: C901 - one compiled loop
    """Samples of the tile [x0, x0 + side) x [y0, y0 + side) (xmax, ymax: the largest floats
    inside it) as (k, 2) and the random numbers used, or (0, 2) and -1 when the buffer ``u`` ran
    out. Plain Python so numba can compile it."""
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


@functools.cache
def kernel():
    """The loop compiled by numba (cached on disk), or None when numba is not installed."""
    try:
        import numba
    except ImportError:
        return None
    return numba.njit(cache=True, nogil=True)(_sample_loop)


def sample_tile(rng: np.random.Generator, origin: tuple[float, float], side: float, radius: float,
                fixed: np.ndarray | None = None) -> np.ndarray:
    """Maximal Poisson-disk sample of the square [origin, origin + side)^2, (k, 2) in acceptance
    order: pairwise >= ``radius`` apart and from ``fixed`` (already placed samples, pairwise
    >= ``radius``), every point of the tile within ``radius`` of a sample or of ``fixed``.
    Depends only on the stream of ``rng``. Without numba: the core vectorised sampler (same
    properties, other samples; ``kernel()`` tells which one runs)."""
    if not side >= 2.0 * radius > 0.0:
        raise ValueError(f"tile side {side:g} must be at least 2 x the Poisson radius {radius:g}")
    x0, y0 = float(origin[0]), float(origin[1])
    kern = kernel()
    if kern is None:
        return poisson_disk(rng, (side, side), radius, origin=(x0, y0), fixed=fixed)
    n = math.ceil(side * math.sqrt(2.0) / radius)
    f = np.zeros((0, 2)) if fixed is None else np.asarray(fixed, np.float64).reshape(-1, 2)
    dx = np.maximum(np.maximum(x0 - f[:, 0], f[:, 0] - (x0 + side)), 0.0)
    dy = np.maximum(np.maximum(y0 - f[:, 1], f[:, 1] - (y0 + side)), 0.0)
    f = f[dx * dx + dy * dy < radius * radius]
    fx, fy = np.ascontiguousarray(f[:, 0]), np.ascontiguousarray(f[:, 1])
    u = rng.random(24 * n * n)
    while True:
        out, used = kern(u, x0, y0, math.nextafter(x0 + side, -math.inf), math.nextafter(y0 + side, -math.inf),
                         float(side), n, float(radius), fx, fy)
        if used >= 0:
            return out
        u = np.concatenate([u, rng.random(len(u))])
