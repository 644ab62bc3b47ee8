"""Maximal Poisson-disk sampling of a 2-D rectangle, vectorised with numpy.

Why not ``scipy.stats.qmc.PoissonDisk``: it throws one dart at a time and gives up after a fixed
number of misses, so it is slow and leaves holes (the set is not maximal). Here, following
Ebeida et al. 2011 ("Efficient maximal Poisson-disk sampling"), the domain is cut into a
background grid of square cells of side r/sqrt(2) (a cell holds at most one sample), and
rounds of darts run until nothing is left open:

1. darts: a Poisson number per open sub-cell (mean proportional to its area), uniform inside it
   and in random priority order, i.e. i.i.d. uniform darts over the open region;
2. settling: darts closer than r to a sample die; among the rest, the conflict graph (same cell
   or closer than r) is resolved by Luby rounds in priority order, which accepts exactly what
   one-at-a-time throwing in that order would. Rounds 1-2 together are therefore sequential
   random dart throwing (RSA), and a maximal set has the RSA jamming density (~0.547);
3. bookkeeping: each open sub-cell keeps the samples whose disks touch it (flat pairs). A
   sub-cell closes when its cell gets a sample or one disk contains it (farthest corner test);
   when darts stop landing, open sub-cells split into four (quadtree) and inherit the pairs;
4. the loop ends when no open sub-cell is left: every point of the rectangle is then within r
   of a sample, i.e. the set is maximal (down to sub-cells a few ulps wide, see ``_MAX_LEVEL``).

Every per-round step is whole-array numpy on flat arrays (no per-point Python loop): the
reference path. With numba (the ``fast`` extra) the rounds run as compiled loops over the
background grid instead (procgen.builtin.poisson_kernels), drawing the same random numbers and
giving bit-identical samples, ~3.5x faster (benchmarks/poisson.py).
"""
from __future__ import annotations

import functools
import math
from dataclasses import dataclass, field

import numpy as np

from procgen.accel import kernels
from procgen.errors import InputError

__all__ = ["PoissonDiskError", "poisson_disk", "poisson_disk_with_stats", "MAX_GRID_CELLS"]

MAX_GRID_CELLS = 5_000_000
"""Largest background grid accepted: peak memory is ~550 B per cell (~1.6 KB per sample),
so this caps a call near 2.7 GB and ~1.7 million samples."""

_PAD = 2
"""Grid padding in cells: conflicts and coverage only involve the 5x5 block around a cell,
because points three cells apart are at least 2 * r / sqrt(2) > r apart."""

_MAX_LEVEL = 40
"""Deepest quadtree level. Sub-cells are indexed by int64 (cell << level | offset) and their
corners by float64; subdivision also stops once a sub-cell is a few ulps wide."""

_SPLIT_BELOW = 0.1
"""Split all open sub-cells when fewer than this fraction of the round's darts became samples.
Measured at r = 0.004: 0.1 is ~5% faster than 0.5, so at level 0 a second round is thrown."""

_DARTS_PER_SUBCELL = 1.0
"""Mean darts per open sub-cell in later rounds (0.7 and 1.5 measured slower). Any mean keeps
the result distributed as sequential dart throwing; it only changes how work is batched."""

_FIRST_DARTS_PER_CELL = 0.5
"""Mean darts per cell in the very first round: the conflict graph grows with its square and
the first round is the largest (measured at r = 0.004: 0.5 is ~15% faster overall than 1.0)."""

_NUMBA_MIN_CELLS = 400_000
"""Grid size from which ``accelerate=None`` takes the compiled rounds (procgen.accel). Importing
numba and loading the cached kernels costs ~0.5-1 s per process; the compiled rounds save
~2.6 us per cell (measured at r = 0.004, 125k cells: numpy 3.7 us, compiled 1.0 us per cell),
so they pay for themselves from ~400k cells (~140k samples)."""

KERNELS = "procgen.builtin.poisson_kernels"

_ROUNDS_AT_FLOOR = 64
"""Dart rounds allowed once sub-cells cannot be split further (only float-degenerate slivers,
e.g. a point exactly on three circles, can be left there)."""


class PoissonDiskError(InputError, ValueError):
    """Bad arguments to the sampler: an InputError for procgen, a ValueError for plain callers."""


@dataclass
class _Grid:
    """Background grid: geometry, padded flat sample arrays and neighbour offsets."""

    x0: float
    y0: float
    x1: float
    y1: float
    r: float
    r2: float
    touch2: float
    side: float
    nx: int
    ny: int
    stride: int = field(init=False)
    px: np.ndarray = field(init=False)
    py: np.ndarray = field(init=False)
    nbr: np.ndarray = field(init=False)
    near_first: np.ndarray = field(init=False)
    half: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.stride = self.nx + 2 * _PAD
        n = (self.ny + 2 * _PAD) * self.stride
        self.px = np.full(n, np.nan)
        self.py = np.full(n, np.nan)
        d = np.arange(-_PAD, _PAD + 1)
        di, dj = np.meshgrid(d, d, indexing="ij")
        off = (di * self.stride + dj).ravel()
        self.nbr = off[off != 0]  # 24 neighbours; the own cell is handled separately
        gap = (np.maximum(np.abs(di) - 1, 0) ** 2 + np.maximum(np.abs(dj) - 1, 0) ** 2).ravel()[off != 0]
        self.near_first = self.nbr[np.argsort(gap, kind="stable")]  # likeliest conflicts first
        self.half = off[off >= 0]  # own cell and the 12 "later" neighbours: each cell pair once

    def cell_of(self, i: np.ndarray, j: np.ndarray, level: int) -> np.ndarray:
        """Flat padded index of the level-0 cell holding sub-cell (i, j) of ``level``."""
        return ((i >> level) + _PAD) * self.stride + ((j >> level) + _PAD)

    def bounds(self, i: np.ndarray, j: np.ndarray, level: int):
        """Sub-cell rectangles clipped to the domain (exact: level scaling is a power of two)."""
        h = math.ldexp(self.side, -level)
        lox = self.x0 + j * h
        loy = self.y0 + i * h
        hix = np.minimum(self.x0 + (j + 1) * h, self.x1)
        hiy = np.minimum(self.y0 + (i + 1) * h, self.y1)
        return lox, hix, loy, hiy


def _validate(size, radius, origin, max_points) -> tuple[float, float, float, float, float, int | None]:
    """Check the arguments and return them as plain floats (one-line error on failure)."""
    try:
        w, h = (float(v) for v in size)
        ox, oy = (float(v) for v in origin)
        r = float(radius)
    except (TypeError, ValueError) as exc:
        raise PoissonDiskError(f"poisson_disk: size/origin must be 2 numbers and radius a number ({exc})") from None
    if not (math.isfinite(r) and r > 0.0):
        raise PoissonDiskError(f"poisson_disk: radius must be a finite number > 0, got {radius!r}")
    if not all(math.isfinite(v) and v > 0.0 for v in (w, h)):
        raise PoissonDiskError(f"poisson_disk: size must be two finite numbers > 0, got {tuple(size)!r}")
    if not all(math.isfinite(v) for v in (ox, oy)):
        raise PoissonDiskError(f"poisson_disk: origin must be two finite numbers, got {tuple(origin)!r}")
    if max_points is not None:
        if isinstance(max_points, bool) or not isinstance(max_points, (int, np.integer)) or max_points < 0:
            raise PoissonDiskError(f"poisson_disk: max_points must be None or an int >= 0, got {max_points!r}")
        max_points = int(max_points)
    side = r / math.sqrt(2.0)
    cells = math.ceil(w / side) * math.ceil(h / side)
    if cells > MAX_GRID_CELLS:
        raise PoissonDiskError(
            f"poisson_disk: radius {r:g} is too small for size ({w:g}, {h:g}): "
            f"{cells} grid cells > {MAX_GRID_CELLS}"
        )
    scale = max(abs(ox), abs(oy), abs(ox + w), abs(oy + h))
    if side < 1e6 * math.ulp(scale):
        raise PoissonDiskError(
            f"poisson_disk: radius {r:g} is below float64 resolution at coordinates ~{scale:g}"
        )
    return w, h, ox, oy, r, max_points


def _touches(sx, sy, lox, hix, loy, hiy, touch2: float) -> np.ndarray:
    """True where the open disk of radius r around (sx, sy) may meet the closed rectangle.

    ``touch2`` is r^2 padded by a few ulps of the coordinates (see ``_Grid``): a disk kept
    wrongly only costs a distance test, one dropped wrongly could let a dart in too close
    (a dart may sit an ulp outside its sub-cell after rounding).
    """
    dx = np.maximum(np.maximum(lox - sx, sx - hix), 0.0)
    dy = np.maximum(np.maximum(loy - sy, sy - hiy), 0.0)
    return dx * dx + dy * dy < touch2


def _contains(sx, sy, lox, hix, loy, hiy, r2: float) -> np.ndarray:
    """True where the closed disk around (sx, sy) contains the rectangle (its farthest corner)."""
    fx = np.maximum(sx - lox, hix - sx)
    fy = np.maximum(sy - loy, hiy - sy)
    return fx * fx + fy * fy <= r2


@dataclass
class _Open:
    """Open sub-cells of one quadtree level plus, as flat pairs, the samples whose disks touch
    each of them. Sub-cells stay sorted by level-0 cell, so a cell's sub-cells are contiguous."""

    level: int
    i: np.ndarray
    j: np.ndarray
    pair_sub: np.ndarray
    pair_x: np.ndarray
    pair_y: np.ndarray
    cell: np.ndarray = field(init=False)
    box: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] = field(init=False)

    def locate(self, g: _Grid) -> "_Open":
        self.cell = g.cell_of(self.i, self.j, self.level)
        self.box = g.bounds(self.i, self.j, self.level)
        return self

    def add_pairs(self, sub: np.ndarray, sx: np.ndarray, sy: np.ndarray) -> None:
        self.pair_sub = np.concatenate((self.pair_sub, sub))
        self.pair_x = np.concatenate((self.pair_x, sx))
        self.pair_y = np.concatenate((self.pair_y, sy))

    def keep(self, g: _Grid, mask: np.ndarray) -> "_Open":
        """Sub-cells where ``mask`` holds, with their pairs renumbered."""
        new_index = np.cumsum(mask) - 1
        pm = mask[self.pair_sub]
        return _Open(self.level, self.i[mask], self.j[mask], new_index[self.pair_sub[pm]],
                     self.pair_x[pm], self.pair_y[pm]).locate(g)


_CHUNK = 1 << 13
"""Centres (or pairs) per vectorised batch: bounds the temporaries of block expansions
(~25 pairs per centre, ~15 arrays each) and of ``_split_pairs`` to a few tens of MB."""


class _CellIndex:
    """Contiguous ranges of a non-decreasing array of cell indices, for block look-ups."""

    def __init__(self, g: _Grid, sorted_cells: np.ndarray, queries: int):
        self.cells = sorted_cells
        self.first = None
        if queries * 8 >= g.px.size:  # many queries: one histogram beats binary searches
            self.first = np.concatenate(([0], np.cumsum(np.bincount(sorted_cells, minlength=g.px.size))))

    def members(self, centres: np.ndarray, offsets: np.ndarray):
        """All (k, m) with ``cells[m]`` in a cell ``centres[k] + offsets``, as two index arrays."""
        q = (centres[:, None] + offsets).ravel()
        if self.first is None:
            lo = np.searchsorted(self.cells, q, "left")
            cnt = np.searchsorted(self.cells, q, "right") - lo
        else:
            lo = self.first[q]
            cnt = self.first[q + 1] - lo
        member = np.repeat(lo - (np.cumsum(cnt) - cnt), cnt) + np.arange(int(cnt.sum()))
        owner = np.repeat(np.arange(centres.size), cnt.reshape(-1, offsets.size).sum(axis=1))
        return owner, member


def _chunks(n: int, scale: int = 1):
    step = _CHUNK * scale
    return (slice(k, min(k + step, n)) for k in range(0, n, step))


def _link(g: _Grid, o: _Open, sx: np.ndarray, sy: np.ndarray, scell: np.ndarray):
    """Pairs (sub-cell, new sample) for every open sub-cell in the 5x5 block of each new sample
    whose rectangle the sample's disk touches, and which sub-cells a new disk contains."""
    index = _CellIndex(g, o.cell, scell.size * g.nbr.size)
    out: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = [(np.empty(0, dtype=np.int64), np.empty(0), np.empty(0))]
    covered = np.zeros(o.i.size, dtype=bool)
    for part in _chunks(scell.size):
        src, sub = index.members(scell[part], g.nbr)
        px, py = sx[part][src], sy[part][src]
        box = [b[sub] for b in o.box]
        t = _touches(px, py, *box, g.touch2)
        out.append((sub[t], px[t], py[t]))
        covered[sub[t & _contains(px, py, *box, g.r2)]] = True
    return (*(np.concatenate(z) for z in zip(*out)), covered)


def _split_pairs(o: _Open, part: slice, mx, my, touch2: float, r2: float):
    """numpy path of ``_split`` for the pairs in ``part``: (child, x, y) for each pair whose
    disk touches a child (children are 4 * parent + quadrant), and the children it contains."""
    s = o.pair_sub[part]
    vx, vy = o.pair_x[part], o.pair_y[part]
    lox, hix, loy, hiy = o.box
    near2, far2 = [], []  # per axis: (low child, high child) squared distances
    for lo, mid, hi, v in ((lox, mx, hix, vx), (loy, my, hiy, vy)):
        lo, mid, hi = lo[s], mid[s], hi[s]
        low_hi = np.minimum(mid, hi)  # upper edge of the low child, clipped to the domain
        d = (np.maximum(np.maximum(lo - v, v - low_hi), 0.0), np.maximum(np.maximum(mid - v, v - hi), 0.0))
        f = (np.maximum(v - lo, low_hi - v), np.maximum(v - mid, hi - v))
        near2.append([a * a for a in d])
        far2.append([a * a for a in f])
    touch = np.empty((4, s.size), dtype=bool)
    inside = np.empty((4, s.size), dtype=bool)
    for q in range(4):
        qy, qx = q >> 1, q & 1
        np.less(near2[0][qx] + near2[1][qy], touch2, out=touch[q])
        np.less_equal(far2[0][qx] + far2[1][qy], r2, out=inside[q])

    def child_of(k):  # flat index into (4, P) -> child, pair; no integer division
        q = (k >= s.size).astype(np.int64) + (k >= 2 * s.size) + (k >= 3 * s.size)
        pr = k - q * s.size
        return 4 * s[pr] + q, pr

    pr = child_of(np.flatnonzero(touch))
    return pr[0], vx[pr[1]], vy[pr[1]], child_of(np.flatnonzero(inside & touch))[0]


def _split(g: _Grid, o: _Open) -> _Open:
    """Four children per open sub-cell; each inherits those of the parent's touching disks that
    touch it, and children outside the domain or inside one disk are dropped.

    Children are the parent cut at its midlines, computed with the same formula as
    ``_Grid.bounds``, so the containment test sees exactly the children's corners.
    Quadrant q = 2 * (upper half) + (right half); children are numbered 4 * parent + q.
    """
    level = o.level + 1
    hc = math.ldexp(g.side, -level)
    mx = g.x0 + (2 * o.j + 1) * hc
    my = g.y0 + (2 * o.i + 1) * hc
    lox, hix, loy, hiy = o.box
    yes = np.ones(mx.size, dtype=bool)
    valid = (np.stack((yes, my < g.y1), axis=1)[:, :, None]
             & np.stack((yes, mx < g.x1), axis=1)[:, None, :]).reshape(-1, 4)
    parts = [_split_pairs(o, part, mx, my, g.touch2, g.r2) for part in _chunks(o.pair_sub.size, 8)]
    csub, cx, cy, inside = (np.concatenate([p[k] for p in parts]) if parts else np.empty(0, dtype=t)
                            for k, t in enumerate((np.int64, float, float, np.int64)))
    del parts  # free the pieces before the children are filtered
    covered = np.zeros((mx.size, 4), dtype=bool)
    covered.ravel()[inside] = True
    keep = (valid & ~covered).ravel()
    kid = np.flatnonzero(keep)  # surviving children, 4 * parent + quadrant
    new_index = np.cumsum(keep) - 1
    pm = keep[csub]
    return _Open(level, (o.i[kid >> 2] << 1) + ((kid & 3) >> 1), (o.j[kid >> 2] << 1) + (kid & 1),
                 new_index[csub[pm]], cx[pm], cy[pm]).locate(g)


@functools.cache
def _poisson_cdf(lam: float) -> np.ndarray:
    """P(N <= k), k = 0..39, for N ~ Poisson(lam): a uniform u maps to #{k: cdf[k] <= u}."""
    return np.cumsum([math.exp(-lam) * lam**k / math.factorial(k) for k in range(40)])


def _darts(g: _Grid, o: _Open, rng: np.random.Generator, lam: float):
    """A Poisson number of uniform darts per open sub-cell (mean ``lam`` times the fraction of
    its area inside the domain) in random order: i.i.d. uniform darts over the open region, which is
    what makes the accepted sequence distributed exactly like sequential dart throwing.

    Returns dart sub-cell (non-decreasing), x, y and priority (a permutation).
    """
    lox, hix, loy, hiy = o.box
    full = math.ldexp(g.side, -o.level) ** 2
    # whole sub-cells: inverse-CDF Poisson draws (one uniform each, much cheaper than
    # rng.poisson with an array of means); sub-cells clipped by the domain: rng.poisson
    count = np.searchsorted(_poisson_cdf(lam), rng.random(o.i.size), side="right")
    clipped = np.flatnonzero((hix >= g.x1) | (hiy >= g.y1))
    count[clipped] = rng.poisson(lam * ((hix - lox) * (hiy - loy) / full)[clipped])
    sub = np.repeat(np.arange(o.i.size), count)
    u = rng.random((2, sub.size))
    lox, hix, loy, hiy = (b[sub] for b in o.box)
    x = np.minimum(lox + u[0] * (hix - lox), np.nextafter(g.x1, -math.inf))
    y = np.minimum(loy + u[1] * (hiy - loy), np.nextafter(g.y1, -math.inf))
    return sub, x, y, rng.permutation(sub.size)


def _settle(g: _Grid, o: _Open, sub: np.ndarray, x: np.ndarray, y: np.ndarray, prio: np.ndarray) -> np.ndarray:
    """Accept exactly the darts that sequential throwing in decreasing priority would accept;
    return them in decreasing priority (the compiled path does just that, one dart after another).

    Darts within r of a sample (found through the sub-cell's touching disks) die. The live
    ones form a conflict graph (same cell, or closer than r; edges built per 13-cell half
    block, oriented from higher to lower priority). Luby rounds on the edge list: a live dart
    with no live higher neighbour wins, the lower neighbours of winners die. This yields the
    greedy independent set in priority order, i.e. the sequential result, in O(edges) steps.
    """
    cell = o.cell[sub]
    count = np.bincount(sub, minlength=o.i.size)
    start = np.cumsum(count) - count
    k = count[o.pair_sub]  # each touching disk against every dart of its sub-cell
    dart = np.repeat(start[o.pair_sub] - (np.cumsum(k) - k), k) + np.arange(int(k.sum()))
    pair = np.repeat(np.arange(o.pair_sub.size), k)
    dx = o.pair_x[pair] - x[dart]
    dy = o.pair_y[pair] - y[dart]
    dead = np.zeros(sub.size, dtype=bool)
    dead[dart[dx * dx + dy * dy < g.r2]] = True
    live = np.flatnonzero(~dead)  # stays sorted by cell
    # conflict graph among live darts: same cell, or closer than r; each edge once, hi -> lo
    c = cell[live]
    index = _CellIndex(g, c, c.size * g.half.size)
    edges: list[tuple[np.ndarray, np.ndarray]] = [(np.empty(0, dtype=np.int64),) * 2]
    for part in _chunks(c.size):
        a, b = index.members(c[part], g.half)
        a += part.start
        keep = c[a] != c[b]
        keep |= b > a  # same cell: each unordered pair once
        a, b = live[a[keep]], live[b[keep]]
        dx = x[b] - x[a]
        dy = y[b] - y[a]
        edge = (dx * dx + dy * dy < g.r2) | (cell[a] == cell[b])
        a, b = a[edge], b[edge]
        up = prio[a] > prio[b]
        edges.append((np.where(up, a, b), np.where(up, b, a)))
    hi, lo = (np.concatenate(z) for z in zip(*edges))
    alive = ~dead
    wins: list[np.ndarray] = []
    while True:  # Luby rounds on the edge list
        blocked = np.zeros(sub.size, dtype=bool)
        blocked[lo] = True  # every remaining edge has both ends alive
        win = alive & ~blocked
        wins.append(np.flatnonzero(win))
        alive &= ~win
        alive[lo[win[hi]]] = False
        if not lo.size:
            break
        e = alive[hi] & alive[lo]
        hi, lo = hi[e], lo[e]
    win = np.concatenate(wins)
    g.px[cell[win]] = x[win]
    g.py[cell[win]] = y[win]
    return win[np.argsort(prio[win])[::-1]]


def _place_fixed(g: _Grid, o: _Open, fixed: np.ndarray) -> _Open:
    """Put already-placed samples (pairwise >= r apart, e.g. a neighbouring tile's) into the
    grid and the level-0 sub-cells' disk pairs, so that darts keep r from them and the cells
    they cover start closed. Only samples within r of the rectangle matter; they lie in the
    grid or its padding (r < _PAD cell sides)."""
    f = np.asarray(fixed, dtype=np.float64).reshape(-1, 2)
    dx = np.maximum(np.maximum(g.x0 - f[:, 0], f[:, 0] - g.x1), 0.0)
    dy = np.maximum(np.maximum(g.y0 - f[:, 1], f[:, 1] - g.y1), 0.0)
    f = f[dx * dx + dy * dy < g.touch2]
    ci = np.floor((f[:, 1] - g.y0) / g.side).astype(np.int64)
    cj = np.floor((f[:, 0] - g.x0) / g.side).astype(np.int64)
    g.px[(ci + _PAD) * g.stride + cj + _PAD] = f[:, 0]
    g.py[(ci + _PAD) * g.stride + cj + _PAD] = f[:, 1]
    d = np.arange(-_PAD, _PAD + 1)
    bi = (ci[:, None, None] + d[None, :, None]).repeat(d.size, axis=2).reshape(len(f), -1)
    bj = (cj[:, None, None] + d[None, None, :]).repeat(d.size, axis=1).reshape(len(f), -1)
    inside = (bi >= 0) & (bi < g.ny) & (bj >= 0) & (bj < g.nx)
    owner = np.nonzero(inside)[0]
    sub = (bi * g.nx + bj)[inside]      # level-0 sub-cells are the cells in row-major order
    sx, sy = f[owner, 0], f[owner, 1]
    box = [b[sub] for b in o.box]
    t = _touches(sx, sy, *box, g.touch2)
    o.add_pairs(sub[t], sx[t], sy[t])
    covered = np.zeros(o.i.size, dtype=bool)
    covered[sub[t & _contains(sx, sy, *box, g.r2)]] = True
    return o.keep(g, ~(covered | ~np.isnan(g.px[o.cell])))


def poisson_disk_with_stats(
    rng: np.random.Generator,
    size: tuple[float, float],
    radius: float,
    *,
    origin: tuple[float, float] = (0.0, 0.0),
    max_points: int | None = None,
    accelerate: bool | None = None,
    fixed: np.ndarray | None = None,
) -> tuple[np.ndarray, dict]:
    """Like :func:`poisson_disk`, also returning counters: rounds, darts, deepest level,
    sub-cells left open at the float floor, a per-round trace (level, open sub-cells, darts,
    accepted) and whether numba ran. ``accelerate`` (see procgen.accel): None = compiled when numba
    is installed and the grid has at least _NUMBA_MIN_CELLS cells, False = pure numpy, True =
    compiled or PoissonDiskError.
    Both paths return identical arrays."""
    w, h, ox, oy, r, max_points = _validate(size, radius, origin, max_points)
    side = r / math.sqrt(2.0)
    cells = math.ceil(w / side) * math.ceil(h / side)
    try:
        kern = kernels(KERNELS, accelerate, work=cells, min_work=_NUMBA_MIN_CELLS)
    except InputError as exc:
        raise PoissonDiskError(f"poisson_disk: {exc}") from None
    coord_ulp = math.ulp(max(abs(ox), abs(oy), abs(ox + w), abs(oy + h), side))
    g = _Grid(x0=ox, y0=oy, x1=ox + w, y1=oy + h, r=r, r2=r * r, touch2=(r + 16 * coord_ulp) ** 2 * (1 + 1e-12),
              side=side, nx=max(1, math.ceil(w / side)), ny=max(1, math.ceil(h / side)))
    limit = math.inf if max_points is None else max_points
    stats: dict = {"rounds": 0, "darts": 0, "level": 0, "leftover_subcells": 0, "trace": [],
                   "numba": kern is not None}
    o = None
    if fixed is not None or kern is None:
        ii, jj = np.meshgrid(np.arange(g.ny, dtype=np.int64), np.arange(g.nx, dtype=np.int64), indexing="ij")
        o = _Open(0, ii.ravel(), jj.ravel(), np.empty(0, dtype=np.int64), np.empty(0), np.empty(0)).locate(g)
        if fixed is not None:
            o = _place_fixed(g, o, fixed)
    if kern is not None:
        return _rounds_compiled(g, o, rng, kern, limit, stats, coord_ulp), stats
    return _rounds_numpy(g, o, rng, limit, stats, coord_ulp), stats


def _at_floor(g: _Grid, level: int, coord_ulp: float) -> bool:
    """Sub-cells of ``level`` cannot be split further (see ``_MAX_LEVEL``)."""
    return level >= _MAX_LEVEL or math.ldexp(g.side, -level) < 64 * coord_ulp


def _rounds_numpy(g: _Grid, o: _Open, rng: np.random.Generator, limit: float, stats: dict,
                  coord_ulp: float) -> np.ndarray:
    """The dart rounds on whole arrays (the reference path); returns the samples."""
    floor_rounds = 0
    out_x: list[np.ndarray] = []
    out_y: list[np.ndarray] = []
    n_out = 0
    while o.i.size and n_out < limit:
        lam = _FIRST_DARTS_PER_CELL if stats["rounds"] == 0 else _DARTS_PER_SUBCELL
        sub, x, y, prio = _darts(g, o, rng, lam)
        wins = _settle(g, o, sub, x, y, prio)
        take = wins[: int(min(limit - n_out, wins.size))]
        out_x.append(x[take])
        out_y.append(y[take])
        n_out += take.size
        stats["rounds"] += 1
        stats["darts"] += sub.size
        stats["trace"].append((o.level, int(o.i.size), int(sub.size), int(wins.size)))
        rate = wins.size / max(sub.size, 1)
        closed = ~np.isnan(g.px[o.cell])  # cell taken
        near = np.sort(wins)  # darts are sorted by cell: link in cell order for locality
        sub, sx, sy, covered = _link(g, o, x[near], y[near], o.cell[sub[near]])
        o.add_pairs(sub, sx, sy)
        o = o.keep(g, ~(closed | covered))
        if not o.i.size:
            break
        if _at_floor(g, o.level, coord_ulp):
            floor_rounds += 1
            if floor_rounds >= _ROUNDS_AT_FLOOR:
                stats["leftover_subcells"] = int(o.i.size)
                break
        elif rate < _SPLIT_BELOW:
            o = _split(g, o)
    stats["level"] = o.level
    if not out_x:
        return np.empty((0, 2))
    return np.column_stack([np.concatenate(out_x), np.concatenate(out_y)])


class _Scratch:
    """Buffers of the compiled rounds, allocated once per call and grown (rarely, by doubling):
    the grid as (x, y) rows, a grid-sized cell -> first open sub-cell index, per open sub-cell
    (i, j, children, dart counts, uniforms, clipped ones, closed flags) and per dart (uniforms,
    priorities, x/y/cell by rank, cells of the accepted ones): ~200 B per grid cell."""

    def __init__(self, g: _Grid, subcells: int, darts: int):
        self.grid = np.column_stack((g.px, g.py))  # one cache line holds a sample's x and y
        self.first = np.full(g.px.size, -1, dtype=np.int64)  # cell -> first open sub-cell, see close
        self.sub_cap = self.dart_cap = 0
        self.grow_subcells(subcells)
        self.grow_darts(darts)

    def grow_subcells(self, n: int, keep: int = 0) -> None:
        if n <= self.sub_cap:
            return
        cap = max(n, 2 * self.sub_cap)
        old = (self.i[:keep], self.j[:keep]) if keep else None
        self.i, self.j, self.ci, self.cj, self.count, self.clip = (np.empty(cap, np.int64) for _ in range(6))
        self.u, self.mean = np.empty(cap), np.empty(cap)
        self.shut = np.empty(cap, dtype=bool)
        if old:
            self.i[:keep], self.j[:keep] = old
        self.sub_cap = cap

    def grow_darts(self, n: int) -> None:
        if n <= self.dart_cap:
            return
        cap = max(n, 2 * self.dart_cap)
        self.ud, self.dart = np.empty(2 * cap), np.empty((cap, 3))  # dart: x, y, cell
        self.iota = np.arange(cap)
        self.perm, self.wcell = np.empty(cap, np.int64), np.empty(cap, np.int64)
        self.dart_cap = cap


def _rounds_compiled(g: _Grid, o: _Open | None, rng: np.random.Generator, kern, limit: float,
                     stats: dict, coord_ulp: float) -> np.ndarray:
    """The dart rounds of ``_rounds_numpy`` as compiled loops over the grid (see
    procgen.builtin.poisson_kernels): same random draws, same open sub-cells, same samples.
    Python only draws the random numbers (into preallocated buffers) and sequences the rounds."""
    cells = g.nx * g.ny
    b = _Scratch(g, cells, int(cells * _DARTS_PER_SUBCELL * 1.25) + 64)  # ~ the largest round
    if o is None:
        n = cells
        b.i[:n], b.j[:n] = np.divmod(np.arange(n, dtype=np.int64), g.nx)
    else:
        n = o.i.size
        b.i[:n], b.j[:n] = o.i, o.j
    out = np.empty((cells, 2))  # at most one sample per cell
    n_out = level = floor_rounds = 0
    xmax, ymax = np.nextafter(g.x1, -math.inf), np.nextafter(g.y1, -math.inf)
    geom = (g.x0, g.y0, g.x1, g.y1)
    while n and n_out < limit:
        lam = _FIRST_DARTS_PER_CELL if stats["rounds"] == 0 else _DARTS_PER_SUBCELL
        h = math.ldexp(g.side, -level)
        u = rng.random(out=b.u[:n])
        nclip = kern.count_darts(b.i, b.j, n, u, _poisson_cdf(lam), h, *geom, lam, h ** 2, b.count, b.clip, b.mean)
        b.count[b.clip[:nclip]] = rng.poisson(b.mean[:nclip])
        darts = int(b.count[:n].sum())
        b.grow_darts(darts)
        rng.random(out=b.ud[:2 * darts])
        perm = b.perm[:darts]
        perm[:] = b.iota[:darts]
        rng.shuffle(perm)  # rng.permutation(darts), in place
        room = int(min(limit - n_out, cells - n_out))
        won = kern.throw(b.i, b.j, n, level, b.count, b.ud, b.perm, darts, h, *geom, xmax, ymax, g.stride,
                         b.grid, g.near_first, g.r2, b.dart, out, n_out, room, b.wcell)
        n_out += min(won, room)
        stats["rounds"] += 1
        stats["darts"] += darts
        stats["trace"].append((level, n, darts, won))
        n = kern.close(b.i, b.j, n, level, h, *geom, g.stride, g.nx, g.ny, b.grid, g.near_first, g.r2,
                       b.wcell, won, b.first, b.shut)
        if not n:
            break
        if _at_floor(g, level, coord_ulp):
            floor_rounds += 1
            if floor_rounds >= _ROUNDS_AT_FLOOR:
                stats["leftover_subcells"] = n
                break
        elif won / max(darts, 1) < _SPLIT_BELOW:
            args = (n, level, math.ldexp(g.side, -level - 1), *geom, g.stride, g.nx, g.ny, b.grid, g.near_first, g.r2)
            m = kern.split(b.i, b.j, *args, b.ci, b.cj)
            if m > b.sub_cap:
                b.grow_subcells(m, keep=n)
                m = kern.split(b.i, b.j, *args, b.ci, b.cj)
            b.i, b.ci, b.j, b.cj = b.ci, b.i, b.cj, b.j
            n, level = m, level + 1
    stats["level"] = level
    return out[:n_out].copy()


def poisson_disk(
    rng: np.random.Generator,
    size: tuple[float, float],
    radius: float,
    *,
    origin: tuple[float, float] = (0.0, 0.0),
    max_points: int | None = None,
    fixed: np.ndarray | None = None,
) -> np.ndarray:
    """Maximal Poisson-disk sample of [origin, origin + size): (n, 2) float64 points.

    Every pair is at least ``radius`` apart and every location of the rectangle is within
    ``radius`` of a sample (no further sample fits). Deterministic for a given ``rng`` state.
    Points come in acceptance order; ``max_points`` stops after that many (then the set is
    a valid Poisson-disk set but no longer maximal). ``fixed``: samples already placed (pairwise
    >= ``radius``, e.g. a neighbouring tile's): the new ones keep ``radius`` from them, the
    rectangle is maximal with them counted, and they are not returned. Raises PoissonDiskError (an InputError
    and a ValueError) for a non-positive or non-finite radius/size, a bad origin or max_points,
    or a grid larger than MAX_GRID_CELLS.
    """
    return poisson_disk_with_stats(rng, size, radius, origin=origin, max_points=max_points, fixed=fixed)[0]
