"""Maximal Poisson-disk sampling of one small square tile: the lazy tessellation's sampler.

Why not the core ``points.poisson_disk`` here: it is vectorised over a whole domain, and on a
64 x 64 tile (~200 samples) its ~12 rounds of ~30 numpy calls each cost ~15 ms, about 100 us a
sample, three times its per-sample cost on a whole domain; the ~200 tiles of a Chapter 4 cloud
then cost as much as the eager whole-domain tessellation saved (benchmarks/clouds.py). The same
method (Ebeida et al. 2011, "Efficient maximal Poisson-disk sampling", as the core uses it) is
written here for a tile with a fixed layout of random numbers, so that its two forms give the
same samples bit for bit: :func:`sample_rounds` (numpy, whole rounds at once: the reference and
the path without numba) and ``tile_poisson_numba.sample_rounds`` (one sequential loop compiled
by numba, the ``fast`` extra; ~20x faster). A cloud is therefore the same on every install;
``procgen.accel``'s switch (``PROCGEN_ACCELERATE``) picks the path, and run.json says which ran
(``cloud.tile_sampler``); tests/test_snaxel_tile_sampler.py checks both give the same points.

Method: a background grid of cells of side s <= r / sqrt(2) fitted exactly to the tile (a cell
holds at most one sample; points of a cell lie within two cells of every point that can conflict
with or cover it, since r / s < 2 for a tile >= 2 r), holding the ``fixed`` samples of the
neighbouring tiles in a 2-cell rim. Open sub-cells (cell empty, not inside one disk) receive one
dart each per round, thrown one after another in a random order; a dart at least r from every
sample is accepted. When fewer than a tenth of a round's darts are accepted, every open sub-cell
splits into four and those inside one disk close. No open sub-cell left = every point of the tile
is within r of a sample (maximal), down to sub-cells 2**-MAX_LEVEL of a cell wide.

Random numbers come from the tile's own ``numpy`` Generator as a buffer of doubles, used in a
fixed layout (per round: one priority per open sub-cell, then two coordinates per dart in
priority order); the rounds report when the buffer ran out, and the caller reruns them on a
longer prefix of the same stream, so the result depends only on the stream.
"""
from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from procgen.accel import kernels

MAX_LEVEL = 30
"""Deepest sub-cell level (sub-cells 2**-30 of a cell wide; only float-degenerate slivers, e.g.
a point exactly on three circles, can be left open there)."""

SPLIT_BELOW = 0.1
"""Split the open sub-cells when fewer than this fraction of a round's darts are accepted (the
core sampler's rule)."""

KERNELS = "procgen_snaxel.tile_poisson_numba"

_QUAD_I = np.array([0, 1, 0, 1], np.int64)
_QUAD_J = np.array([0, 0, 1, 1], np.int64)


def _near(grid: np.ndarray, cell: np.ndarray, nbr: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(k, 25) sample ids of the 5 x 5 cells around each cell (0 where empty) and where one is."""
    q = grid[cell[:, None] + nbr]
    return np.maximum(q, 0), q >= 0


def _first_come(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    """Darts (of n, in throwing order) that one-at-a-time throwing accepts, given the conflicting
    pairs a < b: Luby rounds (a dart with no live earlier conflict wins, its later conflicts
    die), which reach the sequential result in O(pairs) work."""
    alive = np.ones(n, bool)
    won = np.zeros(n, bool)
    while True:
        blocked = np.zeros(n, bool)
        blocked[b] = True
        win = alive & ~blocked
        won |= win
        alive &= ~win
        alive[b[win[a]]] = False
        if not a.size:
            return won
        keep = alive[a] & alive[b]
        a, b = a[keep], b[keep]


def sample_rounds(u, x0, y0, xmax, ymax, side, n, r, fx, fy):
    """Samples of the tile [x0, x0 + side) x [y0, y0 + side) (xmax, ymax: the largest floats
    inside it) as (k, 2) in acceptance order and the random numbers used, or (0, 2) and -1 when
    the buffer ``u`` ran out. Each round is whole-array numpy; the float expressions are those of
    the compiled loop, in the same order."""
    s = side / n
    r2 = r * r
    pad = n + 4
    nbr = (np.arange(-2, 3)[:, None] * pad + np.arange(-2, 3)).ravel()
    grid = np.full(pad * pad, -1, np.int64)
    px = np.zeros(n * n + fx.shape[0])
    py = np.zeros(n * n + fx.shape[0])
    ci = np.floor((fx - x0) / s).astype(np.int64) + 2
    cj = np.floor((fy - y0) / s).astype(np.int64) + 2
    rim = np.flatnonzero((ci >= 0) & (ci < pad) & (cj >= 0) & (cj < pad))
    npts = rim.size
    grid[cj[rim] * pad + ci[rim]] = np.arange(npts)
    px[:npts], py[:npts] = fx[rim], fy[rim]
    nfixed = npts
    ai = np.tile(np.arange(n, dtype=np.int64), n)          # open sub-cells (level 0: the cells)
    aj = np.repeat(np.arange(n, dtype=np.int64), n)
    level = 0
    pos = 0
    floor_rounds = 0
    while ai.size:
        count = ai.size
        if pos + 3 * count > u.shape[0]:
            return np.empty((0, 2)), -1
        order = np.argsort(u[pos:pos + count], kind="mergesort")
        pos += count
        w = s / (1 << level)
        i, j = ai[order], aj[order]
        cell = ((j >> level) + 2) * pad + (i >> level) + 2
        x = np.minimum(x0 + (i + u[pos:pos + 2 * count:2]) * w, xmax)
        y = np.minimum(y0 + (j + u[pos + 1:pos + 2 * count:2]) * w, ymax)
        pos += 2 * count
        q, has = _near(grid, cell, nbr)
        live = np.flatnonzero(~(has & ((px[q] - x[:, None]) ** 2 + (py[q] - y[:, None]) ** 2 < r2)).any(axis=1))
        xl, yl, cl = x[live], y[live], cell[live]
        pair = cKDTree(np.column_stack([xl, yl])).query_pairs(r * (1.0 + 1e-6), output_type="ndarray")
        a, b = pair.min(axis=1), pair.max(axis=1)              # a thrown before b
        hit = ((xl[a] - xl[b]) ** 2 + (yl[a] - yl[b]) ** 2 < r2) | (cl[a] == cl[b])
        acc = live[_first_come(a[hit], b[hit], live.size)]
        grid[cell[acc]] = npts + np.arange(acc.size)
        px[npts:npts + acc.size], py[npts:npts + acc.size] = x[acc], y[acc]
        npts += acc.size
        split = acc.size < SPLIT_BELOW * count and level < MAX_LEVEL
        if level >= MAX_LEVEL:
            floor_rounds += 1
            if floor_rounds >= 64:
                break
        # keep (or split into four and keep) the sub-cells whose cell is empty and that no
        # single disk contains (farthest corner within r)
        if split:
            level += 1
            ai = (ai[:, None] * 2 + _QUAD_I).ravel()
            aj = (aj[:, None] * 2 + _QUAD_J).ravel()
        nw = s / (1 << level)
        cell = ((aj >> level) + 2) * pad + (ai >> level) + 2
        q, has = _near(grid, cell, nbr)
        xa = (x0 + ai * nw)[:, None]
        ya = (y0 + aj * nw)[:, None]
        dx = np.maximum(np.abs(xa - px[q]), np.abs(xa + nw - px[q]))
        dy = np.maximum(np.abs(ya - py[q]), np.abs(ya + nw - py[q]))
        keep = (grid[cell] < 0) & ~(has & (dx * dx + dy * dy <= r2)).any(axis=1)
        ai, aj = ai[keep], aj[keep]
    return np.column_stack([px[nfixed:npts], py[nfixed:npts]]), pos


def tile_sampler(accelerate: bool | None = None) -> str:
    """Which form of the sampler runs: "numba" or "numpy" (the same samples either way)."""
    return "numpy" if kernels(KERNELS, accelerate) is None else "numba"


def sample_tile(rng: np.random.Generator, origin: tuple[float, float], side: float, radius: float,
                fixed: np.ndarray | None = None, accelerate: bool | None = None) -> np.ndarray:
    """Maximal Poisson-disk sample of the square [origin, origin + side)^2, (k, 2) in acceptance
    order: pairwise >= ``radius`` apart and from ``fixed`` (already placed samples, pairwise
    >= ``radius``), every point of the tile within ``radius`` of a sample or of ``fixed``.
    Depends only on the stream of ``rng``, on every path (``accelerate``: see procgen.accel)."""
    if not side >= 2.0 * radius > 0.0:
        raise ValueError(f"tile side {side:g} must be at least 2 x the Poisson radius {radius:g}")
    kern = kernels(KERNELS, accelerate)
    rounds = sample_rounds if kern is None else kern.sample_rounds
    x0, y0 = float(origin[0]), float(origin[1])
    n = math.ceil(side * math.sqrt(2.0) / radius)
    f = np.zeros((0, 2)) if fixed is None else np.asarray(fixed, np.float64).reshape(-1, 2)
    dx = np.maximum(np.maximum(x0 - f[:, 0], f[:, 0] - (x0 + side)), 0.0)
    dy = np.maximum(np.maximum(y0 - f[:, 1], f[:, 1] - (y0 + side)), 0.0)
    f = f[dx * dx + dy * dy < radius * radius]
    fx, fy = np.ascontiguousarray(f[:, 0]), np.ascontiguousarray(f[:, 1])
    u = rng.random(24 * n * n)
    while True:
        out, used = rounds(u, x0, y0, math.nextafter(x0 + side, -math.inf), math.nextafter(y0 + side, -math.inf),
                           float(side), n, float(radius), fx, fy)
        if used >= 0:
            return out
        u = np.concatenate([u, rng.random(len(u))])
