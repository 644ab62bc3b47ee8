"""Lazy tiled tessellation: Poisson-disk and Delaunay properties across tile borders, order
independence, growth that follows the cloud, identical clouds on any domain size."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.spatial import Delaunay, cKDTree

from procgen_snaxel.growth import CloudGrowth
from procgen_snaxel.params import GrowthParams
from procgen_snaxel.tiles import TiledTopology, circumcentres

R, TILE = 1.0, 8.0


def tiles(seed: int = 7) -> TiledTopology:
    return TiledTopology(R, TILE, np.random.SeedSequence(seed))


@pytest.fixture(scope="module")
def made() -> TiledTopology:
    t = tiles()
    t.ensure_box(-20.0, -20.0, 20.0, 20.0)     # 5 x 5 tiles and more around them, crossing x = 0, y = 0
    return t


def test_poisson_disk_holds_across_tile_borders(made):
    p = made.points
    d, _ = cKDTree(p).query(p, k=2)
    assert d[:, 1].min() >= R                                    # minimum distance, borders included
    # maximality: every location of the ready region is within r of a sample; probe densely,
    # with extra probes in the strips along tile borders
    rng = np.random.default_rng(0)
    probe = rng.uniform(-20.0, 20.0, (40000, 2))
    edge = rng.uniform(-20.0, 20.0, (8000, 2))
    edge[:4000, 0] = np.round(edge[:4000, 0] / TILE) * TILE + rng.uniform(-0.05, 0.05, 4000)
    edge[4000:, 1] = np.round(edge[4000:, 1] / TILE) * TILE + rng.uniform(-0.05, 0.05, 4000)
    gap, _ = cKDTree(p).query(np.vstack([probe, edge]))
    assert gap.max() < R
    # the samples of a tile lie in it, and all 4 phases met their neighbours
    assert np.all(np.floor(p / TILE).astype(int) == made.vtile)


def test_triangles_are_the_global_delaunay_triangles(made):
    p = made.points
    f = made.faces
    assert len(np.unique(np.sort(f, axis=1), axis=0)) == len(f)           # each triangle owned once
    # empty circle: no sample strictly inside any triangle's circumcircle
    c = circumcentres(p, f)
    rad = np.hypot(*(p[f[:, 0]] - c).T)
    assert rad.max() <= R * (1 + 1e-9)                                     # maximal sample -> R <= r
    nearest, _ = cKDTree(p).query(c)
    assert np.all(nearest >= rad * (1 - 1e-9))
    # every ready vertex's ring equals its neighbours in one Delaunay of all the samples
    ref = Delaunay(p).simplices
    e = np.sort(np.vstack([ref[:, [0, 1]], ref[:, [1, 2]], ref[:, [2, 0]]]), axis=1)
    e = np.unique(e, axis=0)
    ready = made.ready
    mine = made.edges()
    mine = mine[ready[mine[:, 0]] & ready[mine[:, 1]]]
    ref_ready = e[ready[e[:, 0]] & ready[e[:, 1]]]
    assert np.array_equal(np.unique(mine, axis=0), ref_ready)
    for v in np.flatnonzero(ready)[:: 97]:
        ring = made.neighbours(v)
        ang = np.arctan2(*(p[ring] - p[v])[:, ::-1].T)
        turn = np.diff(np.r_[ang, ang[0]]) % (2 * np.pi)                  # counter-clockwise, once round
        assert np.all(turn > 0) and np.isclose(turn.sum(), 2 * np.pi)
        assert set(ring) == set(e[e[:, 0] == v, 1]) | set(e[e[:, 1] == v, 0])


def test_tiles_do_not_depend_on_the_order_they_are_made():
    a, b = tiles(3), tiles(3)
    a.ensure_box(-8.0, -8.0, 30.0, 14.0)
    for box in ((22.0, 6.0, 30.0, 14.0), (-8.0, -8.0, 0.0, 0.0), (5.0, -3.0, 12.0, 9.0), (-8.0, 0.0, 30.0, 14.0),
                (-8.0, -8.0, 30.0, 14.0)):
        b.ensure_box(*box)
    for t in a._points:
        pa, pb = a.points[a._points[t]], b.points[b._points[t]]
        assert pa.tobytes() == pb.tobytes(), t
    fa = {tuple(sorted(map(tuple, a.points[f]))) for f in a.faces}
    fb = {tuple(sorted(map(tuple, b.points[f]))) for f in b.faces}
    common = {t for t in a._owned if t in b._owned}
    assert common
    key = lambda top, t: {tuple(sorted(map(tuple, top.points[f]))) for f in top._owned[t]}  # noqa: E731
    assert all(key(a, t) == key(b, t) for t in common)
    assert fa & fb
    other = tiles(4)
    other.ensure_box(0.0, 0.0, 1.0, 1.0)
    assert other.points[other._points[(0, 0)]].tobytes() != a.points[a._points[(0, 0)]].tobytes()


CLOUD = dict(radius=2.0, tile=24.0, table=[[0, 12.5, 100], [12.5, 37.5, 250], [37.5, 50, 375], [50, 6.25]],
             t_max=37.5, g_min=60.0, g_max=62.5, n_c=2, c_min=1.5, source=[150.0, 150.0])


def test_cost_follows_the_cloud_and_domain_size_changes_nothing():
    """The same cloud on a 300- and a 3000-unit domain (and unbounded): identical outlines, and
    the tiles made cover the cloud plus a rim, not the domain."""
    outs = []
    for bounds in ([0.0, 0.0, 300.0, 300.0], [0.0, 0.0, 3000.0, 3000.0], None):
        topo = TiledTopology(2.0, 24.0, np.random.SeedSequence(11))
        g = CloudGrowth(topo, GrowthParams(bounds=bounds, **CLOUD), np.random.default_rng(5), bounds=None
                        if bounds is None else tuple(bounds)).run()
        xy = g.snake.xy()
        outs.append(xy)
        w, h = np.ptp(xy, axis=0)
        made = topo.n_tiles * 24.0 ** 2
        assert made < 4.0 * (w + 6 * 24.0) * (h + 6 * 24.0)     # cloud box + a rim of 3 tiles a side
    assert outs[0].tobytes() == outs[1].tobytes() == outs[2].tobytes()
    assert 100.0 * 100.0 < made < 0.2 * 3000.0 ** 2
