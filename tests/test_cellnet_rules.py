"""Behaviours on a cellular network (seed 002 section 5, Table 1, Equation 1): invariants."""
from __future__ import annotations

import math

import numpy as np
import pytest

from _cellnet import permuted
from procgen_cellnet.activation import ring_matrices
from procgen_cellnet.boxes import pairs_kdtree
from procgen_cellnet.colour import spread
from procgen_cellnet.corrosion import countdown
from procgen_cellnet.cracks import crack_cells
from procgen_cellnet.harmonize import force, force_literal, harmonize_step, prune_links
from procgen_cellnet.melting import melt_step
from procgen_cellnet.network import CellNetwork
from procgen_cellnet.seeding import link_radius, seed_cells
from procgen_cellnet.states import (ACTIVE, INFLUENCING, RECEIVING, SLEEPING, TRANSPARENT, put_states,
                                    receives, sends)
from procgen_cellnet.watercolour import flow_step, humidity_rgb


def lattice(grid="triangle", nx=20.0, ny=None, cs=1.0, seed=0, z=None):
    ny = nx if ny is None else ny
    v = np.array([[0, 0, 0], [nx, 0, 0], [nx, ny, 0], [0, ny, 0]], float)
    s = seed_cells(v, np.array([[0, 1, 2], [0, 2, 3]]), grid, cs, rng=np.random.default_rng(seed))
    p = s.positions if z is None else np.column_stack([s.positions[:, :2], z(s.positions)])
    r = link_radius(grid, cs, 0.01)
    net = CellNetwork(p, pairs_kdtree(p, r), cs=cs, grid=grid, radius=r)
    net.add_field("cell__normal", s.normals, at="cell")
    return net


def active(n):
    gs = np.full(n, ACTIVE, np.int8)
    return sends(gs), receives(gs)


def weighted(net, x):
    k = net.degree.astype(float)
    return ((k + 1)[:, None] * x.reshape(len(k), -1)).sum(axis=0)


# -- Equation (1), harmonization and pruning ---------------------------------------------------
def test_force_shape_and_reconstruction():
    cs, ri, k = 1.0, math.sqrt(3), 1.3
    assert force(np.array([0.0]), cs, ri, k)[0] == pytest.approx(k)
    assert np.allclose(force(np.array([cs, ri]), cs, ri, k), 0, atol=1e-15)
    d = np.linspace(cs, ri, 1001)[1:-1]
    f = force(d, cs, ri, k)
    assert np.all(f < 0)
    assert d[np.argmin(f)] == pytest.approx((cs + ri) / 2, abs=2e-3)
    assert f.min() == pytest.approx(-k * (ri - cs) ** 2 / (4 * cs * ri), rel=1e-5)
    dd = np.linspace(0, 2.5, 500)
    assert np.abs(force(dd, cs, ri, k) - force_literal(dd, cs, ri, k)).max() < 1e-12


def test_harmonization_evens_spacing_in_the_tangent_plane():
    net = lattice("random", 30.0, seed=4)
    p, links = net.positions, net.links
    n = net.normals()
    movable = np.ones(net.n_cells, bool)
    err0 = None
    errs = []
    for it in range(400):
        p, links, disp = harmonize_step(p, n, links, movable, 1.0, net.radius, 1.0, 2.0, 0.2, True)
        assert np.abs(np.einsum("ij,ij->i", disp, n)).max() < 1e-12
        d = np.linalg.norm(p[links[:, 0]] - p[links[:, 1]], axis=1)
        errs.append(np.abs(d - 1).mean())
        if err0 is None:
            err0 = errs[0]
    d = np.linalg.norm(p[links[:, 0]] - p[links[:, 1]], axis=1)
    assert d.max() < 2.0 + 0.5                     # released at dmax before the last step
    windows = np.array(errs).reshape(8, 50).mean(axis=1)
    assert np.all(np.diff(windows) <= 1e-9)
    assert errs[-1] < 0.6 * err0


@pytest.mark.parametrize("mode", ["mutual", "union"])
def test_pruning_keeps_the_best_links(mode):
    net = lattice("random", 20.0, seed=2)
    lg = 6
    kept = prune_links(net.positions, net.links, 1.0, lg, mode)
    deg0 = np.bincount(net.links.ravel(), minlength=net.n_cells)
    deg = np.bincount(kept.ravel(), minlength=net.n_cells)
    assert np.all(kept[:, 0] < kept[:, 1]) and len(np.unique(kept, axis=0)) == len(kept)
    if mode == "mutual":
        assert deg.max() <= lg
    else:
        # every cell keeps at least its own min(lg, degree) best links
        err = np.abs(net.link_lengths - 1)
        kept_set = {tuple(r) for r in kept}
        for c in range(0, net.n_cells, 37):
            mine = np.nonzero((net.links == c).any(axis=1))[0]
            best = mine[np.argsort(err[mine], kind="stable")][:min(lg, deg0[c])]
            assert all(tuple(net.links[b]) in kept_set for b in best)


# -- update discipline ---------------------------------------------------------------------------
def test_synchronous_rules_commute_with_cell_permutation():
    net = lattice("triangle", 16.0, z=lambda p: 0.3 * np.sin(p[:, 0]))
    rng = np.random.default_rng(1)
    perm = rng.permutation(net.n_cells)
    pnet = permuted(net, perm)
    gs = rng.choice([SLEEPING, RECEIVING, INFLUENCING, ACTIVE], net.n_cells).astype(np.int8)
    color = rng.random((net.n_cells, 3)).astype(np.float32)
    colored = rng.random(net.n_cells) < 0.3
    a = spread(net, color, colored, sends(gs), receives(gs))
    b = spread(pnet, color[perm], colored[perm], sends(gs[perm]), receives(gs[perm]))
    assert np.allclose(a[0][perm], b[0], atol=1e-6) and np.array_equal(a[1][perm], b[1])
    a = melt_step(net, sends(gs), receives(gs))
    b = melt_step(pnet, sends(gs[perm]), receives(gs[perm]))
    assert np.allclose(a[0][perm], b[0]) and np.allclose(a[1][perm], b[1])
    p = np.where(rng.random(net.n_cells) < 0.5, rng.random(net.n_cells), np.nan)
    mp = np.ones(net.n_cells)
    a = countdown(p, gs, sends(gs), receives(gs), net, mp, 0.1)
    b = countdown(p[perm], gs[perm], sends(gs[perm]), receives(gs[perm]), pnet, mp, 0.1)
    assert np.allclose(a[0][perm], b[0], equal_nan=True) and np.array_equal(a[1][perm], b[1])


def test_general_states_gate_who_changes_and_who_counts():
    net = lattice("square4", 10.0)
    n = net.n_cells
    rng = np.random.default_rng(3)
    gs = rng.choice([SLEEPING, RECEIVING, INFLUENCING, ACTIVE, TRANSPARENT], n).astype(np.int8)
    color = rng.random((n, 3)).astype(np.float32)
    colored = np.ones(n, bool)
    new, _ = spread(net, color, colored, sends(gs), receives(gs))
    fixed = np.isin(gs, [SLEEPING, TRANSPARENT, INFLUENCING])
    assert np.array_equal(new[fixed], color[fixed])
    # a receiving cell's new colour uses only ACTIVE / INFLUENCING neighbours
    A = net.graph.matrix
    for c in np.nonzero(gs == RECEIVING)[0][:20]:
        nb = A[c].indices
        src = nb[np.isin(gs[nb], [ACTIVE, INFLUENCING])]
        want = (color[c] + color[src].sum(axis=0)) / (len(src) + 1)
        assert np.allclose(new[c], want, atol=1e-6)
    # a RECEIVING neighbour is never counted: changing its colour changes nobody else
    other = color.copy()
    other[gs == RECEIVING] = 0.5
    again, _ = spread(net, other, colored, sends(gs), receives(gs))
    keep = gs != RECEIVING
    assert np.allclose(again[keep], new[keep])


# -- colour ---------------------------------------------------------------------------------------
def test_spreading_is_convex_and_conserves_the_weighted_sum():
    net = lattice("triangle", 14.0)
    n = net.n_cells
    send, update = active(n)
    rng = np.random.default_rng(0)
    color = np.zeros((n, 3), np.float32)
    colored = np.zeros(n, bool)
    seeds = rng.choice(n, 6, replace=False)
    color[seeds] = rng.random((6, 3))
    colored[seeds] = True
    lo, hi = color[seeds].min(axis=0), color[seeds].max(axis=0)
    for _ in range(40):
        color, colored = spread(net, color, colored, send, update)
        c = color[colored]
        assert np.all(c.min(axis=0) >= lo - 1e-6) and np.all(c.max(axis=0) <= hi + 1e-6)
    assert colored.all()
    total = weighted(net, color.astype(float))
    for _ in range(1500):
        color, colored = spread(net, color.astype(np.float64), colored, send, update)
    assert np.allclose(weighted(net, color.astype(float)), total, rtol=1e-5)
    mean = total / (net.degree + 1).sum()
    assert np.abs(color - mean).max() < 1e-3


# -- cracks ----------------------------------------------------------------------------------------
def _voronoi_labels(net, k, seed=0):
    rng = np.random.default_rng(seed)
    seeds = net.positions[rng.choice(net.n_cells, k, replace=False)]
    return 1 + np.argmin(np.linalg.norm(net.positions[:, None] - seeds[None], axis=2), axis=1)


def test_crack_cells_are_exactly_the_border_cells():
    net = lattice("triangle", 100.0, 86.6)
    label = _voronoi_labels(net, 12)
    send, update = active(net.n_cells)
    two = crack_cells(net, label, send, update, "two")
    A = net.graph.matrix.tocoo()
    border = np.zeros(net.n_cells, bool)
    border[A.row[label[A.row] != label[A.col]]] = True
    assert np.array_equal(two, border)
    one = crack_cells(net, label, send, update, "one")
    assert np.all(two[one]) and one.sum() < two.sum()
    # every two-sided crack cell's differing neighbour: exactly one side is in the one-sided set
    both = (label[A.row] != label[A.col])
    assert np.all(one[A.row[both]] ^ one[A.col[both]] | (one[A.row[both]] & one[A.col[both]]))
    assert 0.08 < two.mean() < 0.15              # [sim] band 8.5-14.8 % for 12 seeds, 1e4 cells
    # a lone region touching nobody has no crack cell
    assert not crack_cells(net, np.ones(net.n_cells, int), send, update, "two").any()


def test_sleeping_cracks_stop_colour_and_conserve_each_region():
    from procgen_cellnet.colour import put_colours
    net = lattice("triangle", 30.0)
    label = _voronoi_labels(net, 5, seed=2)
    send, update = active(net.n_cells)
    crack = crack_cells(net, label, send, update, "two")
    gs = np.where(crack, SLEEPING, ACTIVE).astype(np.int8)
    rng = np.random.default_rng(1)
    color = rng.random((net.n_cells, 3))
    color[crack] = 0.1
    colored = np.ones(net.n_cells, bool)
    k_send = net.graph.matrix @ sends(gs).astype(float)
    region = 1
    inside = (label == region) & ~crack
    before = ((k_send + 1)[inside, None] * color[inside]).sum(axis=0)
    for _ in range(100):
        color, colored = spread(net, color, colored, sends(gs), receives(gs))
    after = ((k_send + 1)[inside, None] * color[inside]).sum(axis=0)
    assert np.allclose(before, after, rtol=1e-5)
    assert np.allclose(color[crack], 0.1)
    put_colours(net, color, colored)


# -- corrosion -------------------------------------------------------------------------------------
def test_corrosion_countdown_timing_and_absorption():
    net = lattice("square4", 12.0)
    n = net.n_cells
    gs = np.full(n, ACTIVE, np.int8)
    p = np.full(n, np.nan)
    dp = 1 / 64
    start = np.argmin(np.linalg.norm(net.positions - [6, 6, 0], axis=1))
    p[start] = 1.0
    mp = np.ones(n)
    transparent_at = None
    n_transparent = 0
    for t in range(1, 80):
        old_p = p
        p, gs = countdown(p, gs, sends(gs), receives(gs), net, mp, dp)
        rose = (p > old_p) | (np.isnan(old_p) & ~np.isnan(p))
        assert np.all(np.isnan(old_p[rose]))           # only null -> Max_p ever rises
        now = int((gs == TRANSPARENT).sum())
        assert now >= n_transparent
        n_transparent = now
        if transparent_at is None and gs[start] == TRANSPARENT:
            transparent_at = t
    assert transparent_at == math.ceil(1 / dp) + 1
    assert n_transparent == 1                            # an isolated cell infects nobody


def test_majority_spread_fills_notches_but_never_advances_a_front():
    net = lattice("square4", 12.0)
    n = net.n_cells
    x, y = net.positions[:, 0], net.positions[:, 1]
    gs = np.full(n, ACTIVE, np.int8)
    mp = np.full(n, 1.0)
    p = np.where(x < 6, 1.0, np.nan)                     # a straight front at x = 6
    for _ in range(5):
        p, gs = countdown(p, gs, sends(gs), receives(gs), net, mp, 0.01)
    assert np.all(np.isnan(p[x > 6]))
    # a one-cell notch: 3 of its 4 neighbours corroding
    p = np.where(x < 6, 1.0, np.nan)
    notch = np.argmin(np.linalg.norm(net.positions - [5.5, 5.5, 0], axis=1))
    p[notch] = np.nan
    new_p, _ = countdown(p, np.full(n, ACTIVE, np.int8), *active(n), net, mp, 0.01)
    assert new_p[notch] == 1.0


# -- melting -------------------------------------------------------------------------------------
def test_melting_conserves_weighted_positions_and_shrinks():
    rng = np.random.default_rng(0)
    net = lattice("triangle", 20.0, z=lambda p: rng.normal(0, 0.5, len(p)))
    send, update = active(net.n_cells)
    total = weighted(net, net.positions)
    lo, hi = net.positions.min(axis=0), net.positions.max(axis=0)
    k1 = net.degree + 1.0
    var = None
    for _ in range(30):
        pos, nrm = melt_step(net, send, update)
        net = net.with_positions(pos)
        net.add_field("cell__normal", nrm, at="cell")
        assert np.allclose(weighted(net, net.positions), total, rtol=1e-12, atol=1e-9)
        assert np.all(net.positions.min(axis=0) >= lo - 1e-12) and np.all(net.positions.max(axis=0) <= hi + 1e-12)
        lo, hi = net.positions.min(axis=0), net.positions.max(axis=0)
        mean = (k1[:, None] * net.positions).sum(0) / k1.sum()
        v = (k1[:, None] * (net.positions - mean) ** 2).sum()
        assert var is None or v <= var + 1e-9
        var = v
        assert np.allclose(np.linalg.norm(nrm, axis=1), 1)
    flat = lattice("triangle", 10.0, z=lambda p: np.full(len(p), 2.5))
    pos, _ = melt_step(flat, *active(flat.n_cells))
    assert np.all(pos[:, 2] == 2.5)


def test_melting_removes_small_details_first():
    net = lattice("triangle", 40.0, z=lambda p: 0.3 * np.sin(p[:, 0] * 2 * np.pi / 3)
                  + 0.3 * np.sin(p[:, 0] * 2 * np.pi / 20))
    send, update = active(net.n_cells)
    inner = (net.positions[:, 0] > 12) & (net.positions[:, 0] < 28)
    x = net.positions[inner, 0]
    basis = np.column_stack([np.sin(x * 2 * np.pi / 3), np.cos(x * 2 * np.pi / 3),
                             np.sin(x * 2 * np.pi / 20), np.cos(x * 2 * np.pi / 20), np.ones_like(x)])

    def amps(z):
        c = np.linalg.lstsq(basis, z, rcond=None)[0]
        return np.hypot(c[0], c[1]), np.hypot(c[2], c[3])
    small0, large0 = amps(net.positions[inner, 2])
    for _ in range(10):
        pos, _ = melt_step(net, send, update)
        net = net.with_positions(pos)
    small, large = amps(net.positions[inner, 2])
    assert small / small0 < 0.1 < 0.8 < large / large0


def test_melting_moves_keep_the_box_index_equal_to_a_rebuild():
    from procgen_cellnet.boxes import BoxIndex
    net = lattice("triangle", 20.0, z=lambda p: np.sin(p[:, 0]))
    idx = net.box_index(2.0)
    assert idx.n_boxes > 0
    for _ in range(5):
        pos, _ = melt_step(net, *active(net.n_cells))
        net = net.with_positions(pos)
    ref = BoxIndex.build(net.positions, 2.0)
    assert np.array_equal(net.box_index(2.0).keys, ref.keys)
    assert np.array_equal(net.box_index(2.0).order, ref.order)


# -- watercolour -----------------------------------------------------------------------------------
def test_watercolour_water_bounds_and_pigment_settles():
    net = lattice("triangle", 30.0)
    n = net.n_cells
    send, update = active(n)
    disc = np.linalg.norm(net.positions - [15, 15, 0], axis=1) < 5
    p = np.where(disc, 1.0, 0.0)
    pig = np.ones((n, 3), np.float32)
    pig[disc] = (0.2, 0.4, 0.9)
    has = disc.copy()
    dp = 0.01
    steps = 0
    while p.max() > 0:
        old_p, old_pig = p, pig
        p, pig, has = flow_step(net, p, pig, has, send, update, dp, 0.5, 0.5)
        steps += 1
        assert p.min() >= 0 and p.max() <= old_p.max() + 1e-15
        dry = old_p == 0
        assert np.array_equal(pig[dry], old_pig[dry])          # settled pigment never moves
        assert np.all(pig >= np.array([0.2, 0.4, 0.9]) - 1e-6) and np.all(pig <= 1 + 1e-6)
        assert steps <= math.ceil(1 / dp)
    reached = np.any(pig != 1, axis=1)
    assert reached.sum() > disc.sum()                          # pigment moved out with the water
    far = np.linalg.norm(net.positions - [15, 15, 0], axis=1) > 12
    assert not reached[far].any()
    h = humidity_rgb(np.array([0.0, 0.25, 0.5, 0.9]), 0.5)
    assert np.allclose(h[0], 1) and np.allclose(h[2], h[3]) and h[1, 0] == pytest.approx(0.5)


# -- Young's activator / inhibitor -----------------------------------------------------------------
def test_young_activator_inhibitor_settles_into_spots():
    from scipy.sparse.csgraph import connected_components
    net = lattice("triangle", 96.0, 83.0)
    a1, a2 = ring_matrices(net, 2.3, 6.0)
    assert np.all(a1.diagonal() == 1)
    p = np.random.default_rng(0).random(net.n_cells) < 0.5
    for step in range(100):
        new = (a1 @ p + -0.2 * (a2 @ p)) > 0
        if np.array_equal(new, p):
            break
        p = new
    assert np.array_equal(new, p), "not fixed within 100 steps"
    assert 0.3 < p.mean() < 0.55
    alive = np.nonzero(p)[0]
    sub = net.graph.matrix[alive][:, alive]
    assert connected_components(sub, directed=False)[0] > 20


def test_put_states_marks_transparent_cells_absent():
    net = lattice("square4", 4.0)
    gs = np.full(net.n_cells, ACTIVE, np.int8)
    gs[:3] = TRANSPARENT
    put_states(net, gs)
    assert net["cell__alive"].sum() == net.n_cells - 3
