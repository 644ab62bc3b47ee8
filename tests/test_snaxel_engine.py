"""Snaxel cloud engine: snake invariants, speed fixtures, curves, clusters, determinism."""
from __future__ import annotations

import numpy as np
import pytest
from shapely.geometry import LineString, Polygon

from procgen_snaxel.params import GrowthParams
from procgen_snaxel.growth import CloudGrowth
from procgen_snaxel.snake import UNVISITED, U, V
from procgen_snaxel.speeds import base_speed, circular_profile, circular_profile_by_rays
from procgen_snaxel.tables import THESIS_TABLES, parse_table
from procgen_snaxel.tessellate import poisson_tessellation

SCALE = 0.25   # the thesis's pixel lengths scaled to a 300-unit domain (1200 px / 4)


def scaled(table: str) -> list[list[float]]:
    return [[x * SCALE for x in row[:-1]] + [row[-1] * SCALE] for row in THESIS_TABLES[table]]


def small_cfg(**kw) -> GrowthParams:
    base = dict(table=scaled("4.5"), t_min=0.0, t_max=150 * SCALE, g_min=240 * SCALE, g_max=250 * SCALE,
                c_min=3 * SCALE * 2, margin=4.0, n_c=4)
    base.update(kw)
    return GrowthParams(**base)


@pytest.fixture(scope="module")
def topo():
    return poisson_tessellation(160.0, 160.0, 1.6, np.random.default_rng(5))


def check_snake(g: CloudGrowth, previous: Polygon | None) -> Polygon:
    """The digest's section-17 invariants 4-9 and 15 for the current chain."""
    s, topo = g.snake, g.topo
    u, v = s.ints[:, U], s.ints[:, V]
    pos, elen = s.flts[:, 0], s.flts[:, 2]
    # 4: on an edge, strictly between a visited origin and an unvisited destination
    assert np.all(s.state[u] != UNVISITED) and np.all(s.state[v] == UNVISITED)
    assert np.all(pos > 0) and np.all(pos < elen)
    # every visited-unvisited edge carries exactly one snaxel (no gaps, no duplicates)
    nv = topo.n_vertices
    src, ring = topo.rings_of(np.flatnonzero(topo.ready))
    front = (s.state[src] != UNVISITED) & (s.state[ring] == UNVISITED)
    assert sorted((src[front] * nv + ring[front]).tolist()) == sorted((u * nv + v).tolist())
    # 5: consecutive snaxels share a triangle and follow the right-hand rule (visited on the left)
    third = topo.left_vertex(u, v)
    assert np.all(third >= 0)
    nxt_u = np.where(s.state[third] != UNVISITED, third, u)
    nxt_v = np.where(s.state[third] != UNVISITED, v, third)
    assert np.array_equal(np.roll(u, -1), nxt_u) and np.array_equal(np.roll(v, -1), nxt_v)
    # 6: closed, simple, counter-clockwise
    xy = s.xy()
    poly = Polygon(xy)
    assert poly.is_valid and poly.exterior.is_simple
    assert poly.exterior.is_ccw
    # 7: each vertex entered at most once: births == visited vertices - source
    assert s.births == int(np.count_nonzero(s.state == 1)) - 1
    # 8: silhouettes nest
    if previous is not None:
        assert previous.buffer(-1e-7).within(poly)
    # 15: curves are contiguous runs partitioning the chain
    c = s.ints[:, 2]
    runs = g.runs(xy)
    assert len(np.unique(runs.curve)) == len(runs.curve)
    assert runs.count.sum() == len(c)
    return poly


def test_invariants_hold_after_every_step(topo):
    g = CloudGrowth(topo, small_cfg(n_c=3), np.random.default_rng(3))
    prev = None
    holes_seen = 0
    t_before = None
    while g.step():
        prev = check_snake(g, prev)
        holes_seen = g.snake.holes
        t = g.snake.flts[:, 1]
        act = g.cluster_of[g.snake.ints[:, 2]] == g.active
        # 19: inside the running cluster nothing travels past g + one step of the fastest snaxel
        if not g.done and act.any():
            assert t[act].max() <= g.g + g.cfg.v_max * g.cfg.dt + 1e-9
        # 14: travelled distances never decrease (per surviving edge) except at a cluster reset
        key = g.snake.ints[:, 0] * topo.n_vertices + g.snake.ints[:, 1]
        if t_before is not None and len(g.stats.cluster_log) == resets:
            common, i_new, i_old = np.intersect1d(key, t_before[0], return_indices=True)
            assert np.all(t[i_new] >= t_before[1][i_old] - 1e-12)
        t_before, resets = (key, t.copy()), len(g.stats.cluster_log)
    # the run must have exercised births, head-on merges and at least one hole
    assert g.snake.births > 300 and g.snake.merges > g.snake.births and holes_seen > 0
    assert g.snake.hole_rule_disagreements == 0


def test_circular_profile_matches_the_ray_construction():
    row = circular_profile(np.arange(11.0), 10.0, np.full(11, 5.0))
    assert np.allclose(row, [0, 1.41, 2.74, 3.90, 4.71, 5.00, 4.71, 3.90, 2.74, 1.41, 0], atol=0.006)
    for h in (2.0, 5.0, 10.0, 25.0, 30.0):
        for x in np.linspace(0.0, 10.0, 23):
            assert circular_profile(np.array([x]), 10.0, np.array([h]))[0] == pytest.approx(
                circular_profile_by_rays(x, 10.0, h), abs=1e-9)
    # Eq 3.5/3.6: k = 1 at t = 0 and e^-1 at t = 1/r; with w_s = 1 and t = 0 the speed is b_v
    from procgen_snaxel.speeds import blend, effect_coefficient
    assert effect_coefficient(np.array([0.0, 10.0]), 0.1) == pytest.approx([1.0, np.exp(-1.0)])
    assert blend(np.array([7.0]), np.array([3.0]), effect_coefficient(np.array([0.0]), 0.1), 1.0)[0] == 7.0
    ratio = circular_profile(np.array([1.0, 2.5, 4.0]), 10.0, np.full(3, 25.0)) / 25.0
    assert np.allclose(ratio, [0.087, 0.279, 0.679], atol=6e-4)


def test_base_speed_fixture_through_the_chain_geometry(topo):
    """Digest 6.2: L_A = 10, gap 2, L_B = 20, v_A = 5, v_B = 10 -> b_v(first of B) = 120/17."""
    g = CloudGrowth(topo, small_cfg(), np.random.default_rng(0))
    x = np.array([0.0, 5.0, 10.0, 12.0, 17.0, 22.0, 27.0, 32.0, 34.0, 39.0, 44.0])
    curve = np.array([0, 0, 0, 1, 1, 1, 1, 1, 2, 2, 2])
    g.snake.ints = np.zeros((len(x), 3), np.int64)
    g.snake.ints[:, 2] = curve
    f = np.zeros((len(x), 7))
    f[:, 0] = x          # pos along a unit x direction from the origin
    f[:, 5] = 1.0
    g.snake.flts = f
    runs = g.runs()
    assert np.allclose(runs.length, [10.0, 20.0, 10.0])          # gaps belong to no curve (A6)
    vb = np.array([5.0, 10.0, 7.0])
    bv = base_speed(runs.s, runs.s[runs.starts], runs.length, vb[runs.curve], runs.perimeter)
    assert bv[3] == pytest.approx(120.0 / 17.0, abs=1e-12)
    assert bv[5] == pytest.approx(10.0, abs=1e-12)                 # B's mid-point
    assert np.all((bv >= 5.0) & (bv <= 10.0))


def test_tables_lookup_and_rejects_bad_rows():
    t = parse_table(THESIS_TABLES["4.5"])
    assert list(t.limit([0, 49.9, 50, 149, 150, 200, 1e6])) == [400, 400, 1000, 1000, 1500, 25, 25]
    t41 = parse_table(THESIS_TABLES["4.1"])   # no open row: the last row extends (A20)
    assert t41.limit([300.0])[0] == 50
    for bad, word in [([[0, 50, 400], [40, 100, 30]], "overlapping"), ([[0, 50, 400], [60, 25]], "gap"),
                      ([[10, 50, 400]], "start"), ([[0, 50, 400], [50, 40, 25]], "reversed"),
                      ([[0, 50, 0]], "> 0")]:
        with pytest.raises(ValueError, match=word):
            parse_table(bad)


def test_bad_parameters_are_rejected():
    from procgen import RecipeError

    for kw, word in [(dict(v_min=0.0), "v_min"), (dict(g_min=30.0, g_max=37.5, t_max=37.5), "g_max"),
                     (dict(w_s=1.5), "w_s"), (dict(details="spline"), "details"),
                     (dict(seed_policy="tallest"), "seed_policy"), (dict(radius=4.0, tile=6.0), "tile")]:
        with pytest.raises(RecipeError, match=word):
            GrowthParams.from_params(kw)


def test_curves_split_by_table_and_short_curves_merge(topo):
    g = CloudGrowth(topo, small_cfg(n_c=2), np.random.default_rng(11))
    checked = 0
    while not g.done:
        g.step()
        xy = g.snake.xy()
        runs = g.runs(xy)
        seg = np.hypot(*(np.roll(xy, -1, 0) - xy).T)
        # after the next maintenance pass each active curve fits its limit (+ the step's growth)
        if g.maintain(runs, g.snake.flts[:, 1]):
            g.normalise()
        xy = g.snake.xy()
        runs = g.runs(xy)
        tmax = np.maximum.reduceat(g.snake.flts[:, 1], runs.starts)
        lim = g.limits.limit(tmax)
        active = g.cluster_of[runs.curve] == g.active
        assert np.all(runs.length[active] <= lim[active] + seg.max())
        if len(runs.starts) > 1:
            short = np.flatnonzero(active & (runs.length < g.cfg.c_min))
            for r in short:   # a short active curve may remain only without an active neighbour
                nb = [runs.curve[(r - 1) % len(runs.curve)], runs.curve[(r + 1) % len(runs.curve)]]
                assert all(g.cluster_of[x] != g.active for x in nb)
        checked += 1
    assert g.stats.splits > 10 and checked > 50


def test_huge_limit_never_splits(topo):
    g = CloudGrowth(topo, small_cfg(table=[[0, 100000.0]], n_c=1), np.random.default_rng(2)).run()
    assert g.stats.splits == 0 and g.report()["curves"] == 1


def test_exactly_n_c_clusters_and_bounded_steps(topo):
    for seed in (1, 2):
        g = CloudGrowth(topo, small_cfg(n_c=5), np.random.default_rng(seed)).run()
        assert g.stats.clusters_grown == 5 and len(g.stats.cluster_log) == 5
        assert all(e["end"] in ("reached", "no progress", "step cap", "vanished") for e in g.stats.cluster_log)
        assert g.stats.steps < g.cfg.max_steps


def test_progress_guard_ends_a_crawling_cluster(topo):
    """With speeds near zero the cluster cannot reach g; the guard must end it, not the step cap."""
    cfg = small_cfg(v_min=0.001, v_max=0.002, n_c=2, guard_steps=50, init_offset=0.5)
    g = CloudGrowth(topo, cfg, np.random.default_rng(4)).run()
    assert [e["end"] for e in g.stats.cluster_log] == ["no progress", "no progress"]
    assert g.stats.steps < 200


def test_margin_stops_growth(topo):
    cfg = small_cfg(n_c=2, g_min=400.0, g_max=420.0, source=[80.0, 30.0], margin=10.0)
    g = CloudGrowth(topo, cfg, np.random.default_rng(6)).run()
    pts = topo.points
    visited = g.snake.state == 1
    assert pts[visited, 1].min() >= 10.0 and pts[visited, 1].max() <= 150.0
    xy = g.snake.xy()
    # no snaxel crosses the margin (digest property 21), and the front stops on the margin line
    # itself: the straight cut of Fig 3.22 ("the snaxels are stopped when they reach the boundaries")
    x0, y0 = g.bounds[0] + 10.0, g.bounds[1] + 10.0   # the mesh's box (no bounds given) minus the margin
    assert xy[:, 1].min() >= y0 - 1e-9 and xy[:, 0].min() >= x0 - 1e-9
    on = np.abs(xy[:, 1] - y0) <= 1e-9
    assert on.sum() >= 5 and g.report()["cut_snaxels"] >= on.sum()
    # heading-out snaxels never arrive and their speed is 0 once on the line
    assert np.all(g.speeds(g.runs())[on] == 0.0)


def test_same_seed_same_cloud_other_seed_other_cloud(topo):
    a = CloudGrowth(topo, small_cfg(n_c=2), np.random.default_rng(8)).run().snake.xy()
    b = CloudGrowth(topo, small_cfg(n_c=2), np.random.default_rng(8)).run().snake.xy()
    c = CloudGrowth(topo, small_cfg(n_c=2), np.random.default_rng(9)).run().snake.xy()
    assert a.tobytes() == b.tobytes()
    assert a.shape != c.shape or not np.allclose(a, c)


def test_speeds_bounded_and_stopped_snaxels_still(topo):
    g = CloudGrowth(topo, small_cfg(n_c=2), np.random.default_rng(12))
    while g.step():
        v = g.last_speed
        assert np.all(v >= 0) and np.all(v <= g.cfg.v_max + 1e-9)
    # at the end every curve of the finished clusters is stopped
    runs = g.runs()
    assert np.all(g.speeds(runs)[g.cluster_of[g.snake.ints[:, 2]] != g.active] == 0)


def test_sketch_is_engulfed_first(topo):
    stroke = [60.0, 50.0, 80.0, 90.0, 100.0, 50.0]
    from procgen_snaxel.sketch import mark_vertices
    marked = mark_vertices(topo, [np.array(stroke).reshape(-1, 2)], c_t=1.0)
    cfg = small_cfg(n_c=1, strokes=[stroke], g_min=60 * SCALE, g_max=60 * SCALE, t_max=0.0)
    g = CloudGrowth(topo, cfg, np.random.default_rng(1), marked=marked)
    while g.phase == "sketch":
        g.step()
    assert np.all(g.snake.state[marked & ~g.snake.blocked] != UNVISITED)
    g.run()
    poly = Polygon(g.snake.xy())
    assert poly.contains(LineString(np.array(stroke).reshape(-1, 2)))


@pytest.mark.slow
def test_resolution_changes_detail_not_size():
    """Digest property 24: only the Poisson radius changes -> mean area and bounding box within 20%."""
    from procgen_snaxel.tables import THESIS_TABLES as TT

    def stats(radius: float) -> np.ndarray:
        out = []
        for seed in (1, 2, 3):
            topo = poisson_tessellation(800.0, 800.0, radius, np.random.default_rng(100 + seed))
            cfg = GrowthParams(table=TT["4.1"], v_min=2.0, v_max=25.0, t_max=50.0, g_min=240.0, g_max=250.0, n_c=2)
            xy = CloudGrowth(topo, cfg, np.random.default_rng(seed)).run().snake.xy()
            w, h = xy.max(0) - xy.min(0)
            out.append([Polygon(xy).area, w, h])
        return np.mean(out, axis=0)

    fine, coarse = stats(4.0), stats(6.0)
    assert np.all(np.abs(coarse / fine - 1.0) < 0.2), (fine, coarse)


def test_thesis_literal_head_on_merges(topo):
    """merge = "head_on" (thesis section 3.2.2): a snaxel heading into a vertex just entered lives
    on until it meets the child sent back along its edge; meanwhile the pair shares one edge,
    moving towards each other, and the outline stays a simple CCW polygon that only grows. The
    topology ends as with immediate merges: no snaxel left heading into a visited vertex."""
    g = CloudGrowth(topo, small_cfg(n_c=2, merge="head_on"), np.random.default_rng(3))
    prev, pairs_seen = None, 0
    while g.step():
        s = g.snake
        u, v = s.ints[:, U], s.ints[:, V]
        pair = (u == np.roll(v, -1)) & (v == np.roll(u, -1))
        pairs_seen += int(pair.sum())
        # a pair is two neighbours on one edge, not met yet; every other snaxel heads out
        assert np.all(s.flts[pair, 0] + np.roll(s.flts[:, 0], -1)[pair] < s.flts[pair, 2])
        lone = ~(pair | np.roll(pair, 1))
        assert np.all(s.state[v[lone]] == UNVISITED)
        poly = Polygon(s.xy())
        assert poly.is_valid and poly.exterior.is_ccw
        if prev is not None:
            assert prev.area <= poly.area + 1e-6
        prev = poly
    assert pairs_seen > 100 and g.snake.merges > 0
    immediate = CloudGrowth(topo, small_cfg(n_c=2), np.random.default_rng(3)).run()
    assert 0.5 < prev.area / Polygon(immediate.snake.xy()).area < 2.0
