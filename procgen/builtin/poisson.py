"""Maximal Poisson-disk sampling of a 2-D rectangle, vectorised with numpy.

Why not ``scipy.stats.qmc.PoissonDisk``: it throws one dart at a time and gives up after a fixed
number of misses, so it is slow and leaves holes (the set is not maximal). Here, following
Ebeida et al. 2011 ("Efficient maximal Poisson-disk sampling"), the domain is cut into a
background grid of square cells of side r/sqrt(2) (so a cell holds at most one sample) and:

1. every still-open cell gets a dart at once; darts that hit an existing disk die, the others are
   settled among themselves by random priority (Luby rounds: a dart wins when no live dart of
   higher priority lies within r of it, which is what sequential throwing in priority order gives);
2. a cell, or a quadtree sub-cell of one, is closed once one disk contains it entirely (test on
   its farthest corner); open cells are split into four sub-cells when darts stop landing, so
   darts keep going only where room is left;
3. the loop ends when no open sub-cell is left: every point of the domain is then within r of a
   sample, i.e. the set is maximal (down to sub-cells of a few ulps, see ``_MAX_LEVEL``).

All per-round work is whole-array numpy on flat, padded grids; there is no per-point Python loop.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from procgen.errors import InputError

__all__ = ["PoissonDiskError", "poisson_disk", "poisson_disk_with_stats", "MAX_GRID_CELLS"]

MAX_GRID_CELLS = 20_000_000
"""Largest background grid accepted (~16 B/cell for the sample grid plus temporaries)."""

_PAD = 2
"""Grid padding in cells: conflicts and coverage only involve the 5x5 block around a cell,
because points three cells apart are at least 2 * r / sqrt(2) > r apart."""

_MAX_LEVEL = 40
"""Deepest quadtree level. Sub-cells are indexed by int64 (cell << level | offset) and their
corners by float64; subdivision also stops once a sub-cell is a few ulps wide."""

_SPLIT_BELOW = 0.25
"""Split all open sub-cells when fewer than this fraction of the round's darts became samples
(measured: a lower value throws many wasted darts, a higher one creates many sub-cells)."""

_TOUCH_SLACK = 1.0 + 1e-9
"""Relative slack on r^2 when deciding which disks may touch a sub-cell (see ``_touches``)."""

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
    side: float
    nx: int
    ny: int
    stride: int = field(init=False)
    px: np.ndarray = field(init=False)
    py: np.ndarray = field(init=False)
    cand_prio: np.ndarray = field(init=False)
    cand_x: np.ndarray = field(init=False)
    cand_y: np.ndarray = field(init=False)
    won: np.ndarray = field(init=False)
    nbr: np.ndarray = field(init=False)

    def __post_init__(self) -> None:
        self.stride = self.nx + 2 * _PAD
        n = (self.ny + 2 * _PAD) * self.stride
        self.px = np.full(n, np.nan)
        self.py = np.full(n, np.nan)
        self.cand_prio = np.full(n, -1, dtype=np.int64)
        self.cand_x = np.full(n, np.nan)
        self.cand_y = np.zeros(n)
        self.won = np.zeros(n, dtype=bool)
        d = np.arange(-_PAD, _PAD + 1)
        di, dj = np.meshgrid(d, d, indexing="ij")
        off = (di * self.stride + dj).ravel()
        self.nbr = off[off != 0]  # 24 neighbours; the own cell is handled separately

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


def _hits_sample(g: _Grid, cell: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """True where (x, y) is closer than r to a sample in the 5x5 block or its cell is taken."""
    nb = cell[:, None] + g.nbr
    dx = g.px[nb] - x[:, None]
    dy = g.py[nb] - y[:, None]
    return ((dx * dx + dy * dy) < g.r2).any(axis=1) | ~np.isnan(g.px[cell])


def _touches(sx, sy, lox, hix, loy, hiy, r2: float) -> np.ndarray:
    """True where the open disk of radius r around (sx, sy) may meet the closed rectangle.

    The slack keeps the test a superset of the exact one under rounding: a disk kept wrongly
    only costs a distance test, one dropped wrongly could let a dart in too close.
    """
    dx = np.maximum(np.maximum(lox - sx, sx - hix), 0.0)
    dy = np.maximum(np.maximum(loy - sy, sy - hiy), 0.0)
    return dx * dx + dy * dy < r2 * _TOUCH_SLACK


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


def _link(g: _Grid, o: _Open, sx: np.ndarray, sy: np.ndarray, scell: np.ndarray):
    """Pairs (sub-cell, new sample) for every open sub-cell in the 5x5 block of each new sample
    whose rectangle the sample's disk touches (sub-cells of a cell are contiguous in ``o``)."""
    first = np.concatenate(([0], np.cumsum(np.bincount(o.cell, minlength=g.px.size))))
    q = (scell[:, None] + g.nbr).ravel()
    lo, cnt = first[q], first[q + 1] - first[q]
    sub = np.repeat(lo - (np.cumsum(cnt) - cnt), cnt) + np.arange(int(cnt.sum()))
    src = np.repeat(np.repeat(np.arange(sx.size), g.nbr.size), cnt)
    px, py = sx[src], sy[src]
    t = _touches(px, py, *(b[sub] for b in o.box), g.r2)
    return sub[t], px[t], py[t]


def _split(g: _Grid, o: _Open) -> _Open:
    """Four children per open sub-cell; each inherits those of the parent's touching disks that
    touch it, and children outside the domain or inside one disk are dropped.

    Children are the parent cut at its midlines, computed with the same formula as
    ``_Grid.bounds``, so the containment test sees exactly the children's corners.
    Quadrant q = 2 * (upper half) + (right half).
    """
    level = o.level + 1
    hc = math.ldexp(g.side, -level)
    mx = g.x0 + (2 * o.j + 1) * hc
    my = g.y0 + (2 * o.i + 1) * hc
    lox, hix, loy, hiy = o.box
    yes = np.ones(mx.size, dtype=bool)
    valid = (np.stack((yes, my < g.y1), axis=1)[:, :, None]
             & np.stack((yes, mx < g.x1), axis=1)[:, None, :]).reshape(-1, 4)
    s = o.pair_sub
    near2, far2 = [], []  # per axis: (low child, high child) squared distances
    for lo, mid, hi, v in ((lox, mx, hix, o.pair_x), (loy, my, hiy, o.pair_y)):
        lo, mid, hi = lo[s], mid[s], hi[s]
        low_hi = np.minimum(mid, hi)  # upper edge of the low child, clipped to the domain
        d = (np.maximum(np.maximum(lo - v, v - low_hi), 0.0), np.maximum(np.maximum(mid - v, v - hi), 0.0))
        f = (np.maximum(v - lo, low_hi - v), np.maximum(v - mid, hi - v))
        near2.append([a * a for a in d])
        far2.append([a * a for a in f])
    covered = np.zeros((mx.size, 4), dtype=bool)
    subs, xs, ys = [], [], []
    for q in range(4):
        qy, qx = q >> 1, q & 1
        t = near2[1][qy] + near2[0][qx] < g.r2 * _TOUCH_SLACK
        t &= valid[s, q]
        covered[s[t & (far2[1][qy] + far2[0][qx] <= g.r2)], q] = True
        subs.append(4 * s[t] + q)
        xs.append(o.pair_x[t])
        ys.append(o.pair_y[t])
    q = np.arange(4)
    child = _Open(level, ((o.i << 1)[:, None] + (q >> 1)).ravel(), ((o.j << 1)[:, None] + (q & 1)).ravel(),
                  np.concatenate(subs), np.concatenate(xs), np.concatenate(ys))
    return child.keep(g, (valid & ~covered).ravel())


def _settle(g: _Grid, o: _Open, x: np.ndarray, y: np.ndarray, prio: np.ndarray) -> np.ndarray:
    """Insert a conflict-free subset of the darts; return the winners in acceptance order.

    A dart stays alive while no sample lies within r and its cell is free; among live darts
    the highest priority of each cell is its representative, and a representative wins when
    no representative of higher priority in the 5x5 block lies within r (Luby rounds). Winners
    are pairwise >= r apart (of two conflicting ones the lower loses) and are inserted at once;
    a losing representative dies when a representative near it won.
    """
    dx = o.pair_x - x[o.pair_sub]
    dy = o.pair_y - y[o.pair_sub]
    dead = np.zeros(x.size, dtype=bool)
    dead[o.pair_sub[dx * dx + dy * dy < g.r2]] = True
    alive = np.flatnonzero(~dead)
    cell = o.cell
    wins: list[np.ndarray] = [np.empty(0, dtype=np.int64)]
    while alive.size:
        c, p = cell[alive], prio[alive]
        np.maximum.at(g.cand_prio, c, p)
        rep = g.cand_prio[c] == p
        a, ca, pa = alive[rep], c[rep], p[rep]
        g.cand_x[ca] = x[a]
        g.cand_y[ca] = y[a]
        nb = ca[:, None] + g.nbr
        nprio = g.cand_prio[nb]
        dx = g.cand_x[nb] - x[a, None]
        dy = g.cand_y[nb] - y[a, None]
        near = (dx * dx + dy * dy) < g.r2  # reset slots hold NaN: never near
        lose = (near & (nprio > pa[:, None])).any(axis=1)
        g.cand_prio[c] = -1
        g.cand_x[c] = np.nan
        win = a[~lose]
        win = win[np.argsort(-prio[win], kind="stable")]
        g.px[cell[win]] = x[win]
        g.py[cell[win]] = y[win]
        wins.append(win)
        g.won[cell[win]] = True
        still = a[lose][~(near[lose] & g.won[nb[lose]]).any(axis=1)]
        g.won[cell[win]] = False
        others = alive[~rep]
        if others.size:
            others = others[~_hits_sample(g, cell[others], x[others], y[others])]
        alive = np.sort(np.concatenate((still, others)))
    return np.concatenate(wins)


def _darts(g: _Grid, o: _Open, rng: np.random.Generator):
    """One uniform dart per open sub-cell (inside the half-open domain), random priorities."""
    lox, hix, loy, hiy = o.box
    u = rng.random((2, o.i.size))
    x = np.minimum(lox + u[0] * (hix - lox), np.nextafter(g.x1, -math.inf))
    y = np.minimum(loy + u[1] * (hiy - loy), np.nextafter(g.y1, -math.inf))
    prio = rng.permutation(o.i.size)
    return x, y, prio


def poisson_disk_with_stats(
    rng: np.random.Generator,
    size: tuple[float, float],
    radius: float,
    *,
    origin: tuple[float, float] = (0.0, 0.0),
    max_points: int | None = None,
) -> tuple[np.ndarray, dict]:
    """Like :func:`poisson_disk`, also returning counters: rounds, darts, deepest level,
    sub-cells left open at the float floor, and a per-round trace (level, darts, accepted)."""
    w, h, ox, oy, r, max_points = _validate(size, radius, origin, max_points)
    side = r / math.sqrt(2.0)
    g = _Grid(x0=ox, y0=oy, x1=ox + w, y1=oy + h, r=r, r2=r * r, side=side,
              nx=max(1, math.ceil(w / side)), ny=max(1, math.ceil(h / side)))
    ii, jj = np.meshgrid(np.arange(g.ny, dtype=np.int64), np.arange(g.nx, dtype=np.int64), indexing="ij")
    o = _Open(0, ii.ravel(), jj.ravel(), np.empty(0, dtype=np.int64), np.empty(0), np.empty(0)).locate(g)
    coord_ulp = math.ulp(max(abs(g.x0), abs(g.x1), abs(g.y0), abs(g.y1), side))
    floor_rounds = 0
    stats: dict = {"rounds": 0, "darts": 0, "level": 0, "leftover_subcells": 0, "trace": []}
    out_x: list[np.ndarray] = []
    out_y: list[np.ndarray] = []
    n_out = 0
    limit = math.inf if max_points is None else max_points
    while o.i.size and n_out < limit:
        x, y, prio = _darts(g, o, rng)
        wins = _settle(g, o, x, y, prio)
        take = wins[: int(min(limit - n_out, wins.size))]
        out_x.append(x[take])
        out_y.append(y[take])
        n_out += take.size
        stats["rounds"] += 1
        stats["darts"] += o.i.size
        stats["trace"].append((o.level, int(o.i.size), int(wins.size)))
        rate = wins.size / o.i.size
        closed = ~np.isnan(g.px[o.cell])  # cell taken
        sub, sx, sy = _link(g, o, x[wins], y[wins], o.cell[wins])
        closed[sub[_contains(sx, sy, *(b[sub] for b in o.box), g.r2)]] = True  # inside a new disk
        o.add_pairs(sub, sx, sy)
        o = o.keep(g, ~closed)
        if not o.i.size:
            break
        if o.level >= _MAX_LEVEL or math.ldexp(side, -o.level) < 64 * coord_ulp:
            floor_rounds += 1
            if floor_rounds >= _ROUNDS_AT_FLOOR:
                stats["leftover_subcells"] = int(o.i.size)
                break
        elif rate < _SPLIT_BELOW:
            o = _split(g, o)
    stats["level"] = o.level
    if not out_x:
        return np.empty((0, 2)), stats
    return np.column_stack([np.concatenate(out_x), np.concatenate(out_y)]), stats


def poisson_disk(
    rng: np.random.Generator,
    size: tuple[float, float],
    radius: float,
    *,
    origin: tuple[float, float] = (0.0, 0.0),
    max_points: int | None = None,
) -> np.ndarray:
    """Maximal Poisson-disk sample of [origin, origin + size): (n, 2) float64 points.

    Every pair is at least ``radius`` apart and every location of the rectangle is within
    ``radius`` of a sample (no further sample fits). Deterministic for a given ``rng`` state.
    Points come in acceptance order; ``max_points`` stops after that many (then the set is
    a valid Poisson-disk set but no longer maximal). Raises PoissonDiskError (an InputError
    and a ValueError) for a non-positive or non-finite radius/size, a bad origin or max_points,
    or a grid larger than MAX_GRID_CELLS.
    """
    return poisson_disk_with_stats(rng, size, radius, origin=origin, max_points=max_points)[0]
