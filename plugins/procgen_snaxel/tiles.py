"""An unbounded Poisson-disk Delaunay tessellation made tile by tile, only where the cloud grows.

The thesis samples the whole screen (section 3.1), yet a cloud covers a few percent of it, so
cost followed the domain. Here the plane is cut into square tiles of side ``tile`` (>= 2 r)
anchored at the origin, and each piece is a pure function of (seed, tile index), so the
tessellation does not depend on the order in which growth asks for tiles:

* **Points.** Tiles are coloured in four phases by index parity (phase = i mod 2 + 2 (j mod 2));
  a tile is sampled (maximal; :mod:`.tile_poisson`, the same samples with or without numba) with the already-final samples of its
  lower-phase neighbours as fixed points, and a random stream spawned from (seed, i, j).
  Same-phase tiles never touch, so every pair of samples is >= r apart and every location is
  within r of a sample across borders (the parallel phase-group scheme of Wei 2008).
* **Triangles.** A Delaunay triangle of a maximal r-sample has an empty circumcircle, hence a
  circumradius <= r. A tile owns the triangles whose circumcentre lies in it; they are taken from
  the Delaunay triangulation of its 3 x 3 block of tiles, which holds every sample within r of
  the tile, so they are exactly the global Delaunay triangles (empty-circle test) and every
  triangle is owned by one tile.
* **Rings.** A vertex's triangles have circumcentres within r of it, so once the tiles within r
  of it own their triangles, its ring is final and the vertex is *ready*.

``ensure`` is called with the snaxels' destination vertices every step; it does nothing until a
destination is not ready, then, in one batch, owns the tiles within r of those vertices (sampling
the blocks they need) and finishes the ring of every vertex whose tiles are now all owned.
"""
from __future__ import annotations

import numpy as np

from .tile_poisson import sample_tile
from .topology import Topology, angular_rings

Tile = tuple[int, int]


def _zigzag(k: int) -> int:
    """Tile index -> non-negative int for a SeedSequence spawn key (0, -1, 1, -2, ... -> 0, 1, 2, 3, ...)."""
    return 2 * k if k >= 0 else -2 * k - 1


def _key(i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Tile index pair -> one int64 (|i|, |j| < 2**31)."""
    return (np.asarray(i, np.int64) << 32) + (np.asarray(j, np.int64) + (1 << 31))


def _unkey(k: int) -> Tile:
    k = int(k)
    j = (k & 0xFFFFFFFF) - (1 << 31)
    return ((k - (j + (1 << 31))) >> 32, j)


def _extend(buf: np.ndarray, used: int, new: np.ndarray) -> np.ndarray:
    """``buf`` holding ``new`` after its first ``used`` rows, reallocated (doubled) when full: the
    tessellation grows by appending, and copying it whole per tile cost O(N) each time."""
    if used + len(new) > len(buf):
        bigger = np.empty((max(2 * len(buf), used + len(new), 1024),) + buf.shape[1:], buf.dtype)
        bigger[:used] = buf[:used]
        buf = bigger
    buf[used:used + len(new)] = new
    return buf


def _phase(t: Tile) -> int:
    return (t[0] & 1) + 2 * (t[1] & 1)


def _block(t: Tile, k: int = 1) -> list[Tile]:
    return [(t[0] + di, t[1] + dj) for dj in range(-k, k + 1) for di in range(-k, k + 1)]


def circumcentres(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Circumcentres (m, 2); each triangle's corners are taken in x order first, so the float
    result does not depend on how a triangulation listed them."""
    order = np.argsort(p[tri, 0], axis=1, kind="stable")
    a, b, c = (p[np.take_along_axis(tri, order[:, k:k + 1], axis=1)[:, 0]] for k in range(3))
    b = b - a
    c = c - a
    d = 2.0 * (b[:, 0] * c[:, 1] - b[:, 1] * c[:, 0])
    b2, c2 = (b * b).sum(1), (c * c).sum(1)
    return a + np.column_stack([(c[:, 1] * b2 - b[:, 1] * c2) / d, (b[:, 0] * c2 - c[:, 0] * b2) / d])


class TiledTopology(Topology):
    """A :class:`Topology` whose vertices, triangles and rings are made tile by tile on demand."""

    unbounded = True

    def __init__(self, radius: float, tile: float, seed: np.random.SeedSequence) -> None:
        if not tile >= 2.0 * radius:
            raise ValueError(f"tile = {tile:g} must be at least 2 x the Poisson radius {radius:g}")
        super().__init__(np.zeros((0, 2)), np.zeros((0, 3), np.int64), np.zeros(0, np.int64),
                         np.zeros(0, np.int64), np.zeros(0, np.int64), np.zeros(0, bool), 0.0, float(radius))
        self.radius = float(radius)
        self.tile = float(tile)
        self.seed = seed
        self.vtile = np.zeros((0, 2), np.int64)   # tile index of every vertex
        self._bufs = {"points": np.zeros((0, 2)), "vtile": self.vtile, "ring": self.ring,   # points etc. are views
                      "faces": self.faces}
        self._points: dict[Tile, np.ndarray] = {}  # tile -> vertex ids (sampling order)
        self._owned: dict[Tile, np.ndarray] = {}   # tile -> triangles it owns
        self._owned_keys = np.zeros(0, np.int64)
        self.batches = 0
        self.accelerate: bool | None = None   # the tile sampler's path (procgen.accel; same samples)

    # -- points ------------------------------------------------------------------------------
    def tile_points(self, t: Tile) -> np.ndarray:
        """Vertex ids of tile t's samples, sampling it (and its lower-phase neighbours) if needed."""
        ids = self._points.get(t)
        if ids is not None:
            return ids
        deps = [n for n in _block(t) if n != t and _phase(n) < _phase(t)]
        fixed = None
        if deps:
            dep_ids = np.concatenate([self.tile_points(n) for n in deps])   # may add points: index after
            fixed = self.points[dep_ids]
        rng = np.random.default_rng(np.random.SeedSequence(self.seed.entropy,
                                                           spawn_key=(*self.seed.spawn_key, _zigzag(t[0]), _zigzag(t[1]))))
        new = sample_tile(rng, (t[0] * self.tile, t[1] * self.tile), self.tile, self.radius, fixed,
                          self.accelerate)
        ids = np.arange(len(self.points), len(self.points) + len(new))
        self._append("points", new)
        self._append("vtile", np.tile(np.array(t, np.int64), (len(new), 1)))
        self._points[t] = ids
        return ids

    def _append(self, name: str, new: np.ndarray) -> None:
        used = len(getattr(self, name))
        self._bufs[name] = _extend(self._bufs[name], used, new)
        setattr(self, name, self._bufs[name][:used + len(new)])

    # -- triangles ---------------------------------------------------------------------------
    def _own(self, tiles: list[Tile]) -> None:
        """Triangles owned by each of ``tiles`` (one Delaunay of the samples within r of them)."""
        from scipy.spatial import Delaunay

        todo = sorted(set(tiles) - self._owned.keys())
        if not todo:
            return
        block = sorted({n for t in todo for n in _block(t)})
        ids = np.concatenate([self.tile_points(n) for n in block])
        # only samples within r of a todo tile can be corners of its triangles (a triangle with
        # its circumcentre c in the tile has an empty circle of radius <= r, as c is within r of
        # a sample); a superset is harmless, so grow the boxes by a little more than r
        p = self.points[ids]
        reach = 1.01 * self.radius
        lo = np.floor((p - reach) / self.tile).astype(np.int64)
        hi = np.floor((p + reach) / self.tile).astype(np.int64)
        tij = np.array(todo, np.int64)
        want = _key(tij[:, 0], tij[:, 1])
        corner = tij.min(0)
        is_todo = np.zeros(tuple(tij.max(0) - corner + 1), bool)     # the todo tiles on a small grid
        is_todo[tuple((tij - corner).T)] = True

        def todo_at(i: np.ndarray, j: np.ndarray) -> np.ndarray:
            i, j = i - corner[0], j - corner[1]
            inside = (i >= 0) & (i < is_todo.shape[0]) & (j >= 0) & (j < is_todo.shape[1])
            out = np.zeros(len(i), bool)
            out[inside] = is_todo[i[inside], j[inside]]
            return out

        near = (todo_at(lo[:, 0], lo[:, 1]) | todo_at(hi[:, 0], lo[:, 1]) | todo_at(lo[:, 0], hi[:, 1])
                | todo_at(hi[:, 0], hi[:, 1]))
        ids = ids[near]
        tri = ids[Delaunay(self.points[ids]).simplices]
        ti = np.floor(circumcentres(self.points, tri) / self.tile).astype(np.int64)
        mine = todo_at(ti[:, 0], ti[:, 1])
        tri, key = tri[mine], _key(ti[mine, 0], ti[mine, 1])
        order = np.argsort(key, kind="stable")
        tri, key = tri[order], key[order]
        cut = np.searchsorted(key, want)
        for t, a, b in zip(todo, cut, np.append(cut[1:], len(key))):
            self._owned[t] = tri[a:b]
        self._append("faces", tri)
        self._owned_keys = np.union1d(self._owned_keys, want)

    # -- readiness ---------------------------------------------------------------------------
    def _corner_keys(self, v: np.ndarray) -> np.ndarray:
        """(k, 4) keys of the tiles touched by the box of half-side r around each vertex: a vertex's
        triangles have circumcentres within r of it, so those tiles own all of them."""
        p = self.points[v]
        lo = np.floor((p - self.radius) / self.tile).astype(np.int64)
        hi = np.floor((p + self.radius) / self.tile).astype(np.int64)
        return np.column_stack([_key(lo[:, 0], lo[:, 1]), _key(hi[:, 0], lo[:, 1]),
                                _key(lo[:, 0], hi[:, 1]), _key(hi[:, 0], hi[:, 1])])

    def _make_ready(self, vertices: np.ndarray) -> None:
        """Own the tiles around ``vertices``, then finish the ring of every vertex whose tiles
        are all owned now."""
        need = np.unique(self._corner_keys(vertices))
        self._own([_unkey(k) for k in need])
        cand = np.concatenate([self.tile_points(t) for t in sorted({n for k in need for n in _block(_unkey(k))})])
        n = len(self.points)
        grow = n - len(self.ring_lo)
        self.ring_lo = np.concatenate([self.ring_lo, np.full(grow, -1, np.int64)])
        self.ring_hi = np.concatenate([self.ring_hi, np.full(grow, -1, np.int64)])
        self.hull = np.concatenate([self.hull, np.zeros(grow, bool)])
        cand = cand[self.ring_lo[cand] < 0]
        cand = cand[np.isin(self._corner_keys(cand), self._owned_keys).all(axis=1)]
        if not len(cand):
            return
        want = np.zeros(n, bool)
        want[cand] = True
        tiles = {_unkey(k) for k in np.unique(self._corner_keys(cand))}
        faces = np.concatenate([self._owned[t] for t in sorted(tiles)])
        faces = faces[want[faces].any(axis=1)]
        # directed edges out of the wanted vertices, each once (an inner edge lies in two faces)
        src, dst = np.repeat(faces.ravel(), 2), faces[:, [1, 2, 0, 2, 0, 1]].ravel()
        keep = want[src]
        key = np.unique(src[keep] * n + dst[keep])
        src, dst = angular_rings(self.points, key // n, key % n)
        vs = np.sort(cand)                            # src is sorted by vertex id
        count = np.bincount(src, minlength=n)[vs]
        start = len(self.ring) + np.concatenate([[0], np.cumsum(count)[:-1]])
        self.ring_lo[vs] = start
        self.ring_hi[vs] = start + count
        self._append("ring", dst)
        if self.mean_edge == 0.0:
            e = np.unique(np.sort(faces[:, [0, 1, 1, 2, 2, 0]].reshape(-1, 2), axis=1) @ np.array([n, 1]))
            self.mean_edge = float(np.hypot(*(self.points[e % n] - self.points[e // n]).T).mean())
        self.batches += 1

    def ensure(self, vertices: np.ndarray) -> bool:
        v = np.asarray(vertices, np.int64)
        pending = v[self.ring_lo[v] < 0]
        if not len(pending):
            return False
        n0 = len(self.points)
        self._make_ready(np.unique(pending))
        return len(self.points) > n0

    def ensure_box(self, x0: float, y0: float, x1: float, y1: float) -> bool:
        n0 = len(self.points)
        i0, j0 = int(np.floor(x0 / self.tile)), int(np.floor(y0 / self.tile))
        i1, j1 = int(np.floor(x1 / self.tile)), int(np.floor(y1 / self.tile))
        for j in range(j0 - 1, j1 + 2):
            for i in range(i0 - 1, i1 + 2):
                self.tile_points((i, j))
        p = self.points
        inside = np.flatnonzero((p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 1] >= y0) & (p[:, 1] <= y1))
        if len(inside) == 0:      # a point-sized box: the nearest sample
            inside = np.array([int(np.argmin(np.hypot(p[:, 0] - x0, p[:, 1] - y0)))])
        self._make_ready(inside)
        return len(self.points) > n0

    @property
    def n_tiles(self) -> int:
        return len(self._points)
