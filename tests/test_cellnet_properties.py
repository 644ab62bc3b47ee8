"""Properties of seed 002 not covered elsewhere: sphere boxes, watercolour water bound and
permutation invariance, the crack rule's end state, Young's rule against its equation."""
from __future__ import annotations

import math

import numpy as np
import pytest

from procgen import State
from _cellnet import permuted, random_young_state, young_field
from procgen_cellnet.activation import ActivatorInhibitor
from procgen_cellnet.boxes import BoxIndex, pairs_kdtree
from procgen_cellnet.cracks import CrackDerivative
from procgen_cellnet.network import CellNetwork
from procgen_cellnet.seeding import link_radius, seed_cells
from procgen_cellnet.states import (ACTIVE, INFLUENCING, RECEIVING, SLEEPING, put_states, receives,
                                    sends)
from procgen_cellnet.watercolour import flow_step


def lattice(grid="triangle", n=20.0, seed=0):
    v = np.array([[0, 0, 0], [n, 0, 0], [n, n, 0], [0, n, 0]], float)
    s = seed_cells(v, np.array([[0, 1, 2], [0, 2, 3]]), grid, 1.0, rng=np.random.default_rng(seed))
    r = link_radius(grid, 1.0, 0.01)
    net = CellNetwork(s.positions, pairs_kdtree(s.positions, r), cs=1.0, grid=grid, radius=r)
    net.add_field("cell__normal", s.normals, at="cell")
    return net


def test_sphere_box_count_lies_between_the_boxes_inside_and_the_boxes_crossed():
    """125,664 uniform cells on the unit sphere, cs = 0.01, kb = 2 (bs = 0.02).

    Exact geometry bounds the count: no box the sphere does not cross can hold a cell, and a
    crossed box holding a sphere patch of area a is empty with probability (1 - a / 4 pi)^n;
    boxes whose patch is at least 2 bs^2 (the x-columns fully inside the unit disc, each seen
    twice) are empty with probability e^-8.  The dense bounding-box array would hold 100^3.
    """
    rng = np.random.default_rng(0)
    p = rng.normal(size=(125_664, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    bs = 0.02
    idx = BoxIndex.build(p, bs)
    lo = np.arange(-50, 50) * bs                       # box low faces along an axis
    x, y, z = np.meshgrid(lo, lo, lo, indexing="ij")

    def reach(c, lo_or_hi):                           # nearest / farthest coordinate to 0
        return np.where((c < 0) & (c + bs > 0), 0.0, np.minimum(np.abs(c), np.abs(c + bs))) \
            if lo_or_hi == "near" else np.maximum(np.abs(c), np.abs(c + bs))
    near = np.sqrt(reach(x, "near") ** 2 + reach(y, "near") ** 2 + reach(z, "near") ** 2)
    far = np.sqrt(reach(x, "far") ** 2 + reach(y, "far") ** 2 + reach(z, "far") ** 2)
    crossed = int(((near <= 1) & (far >= 1)).sum())
    assert idx.n_boxes <= crossed < 100 ** 3 / 20
    assert len(idx.x_nodes) == 100
    xs, ys = np.meshgrid(lo, lo, indexing="ij")
    inside_disc = np.hypot(np.maximum(np.abs(xs), np.abs(xs + bs)),
                           np.maximum(np.abs(ys), np.abs(ys + bs))) < 1
    disc_cross = np.hypot(reach(xs, "near"), reach(ys, "near")) <= 1
    assert 0.999 * inside_disc.sum() <= idx.n_columns <= disc_cross.sum()
    assert 0.7 * crossed < idx.n_boxes          # 35,943 of 47,144 crossed boxes hold a cell


def test_watercolour_water_falls_by_at_most_dp_per_wet_cell_and_weight():
    net = lattice("triangle", 24.0)
    n = net.n_cells
    gs = np.full(n, ACTIVE, np.int8)
    send, update = sends(gs), receives(gs)
    rng = np.random.default_rng(1)
    p = np.where(rng.random(n) < 0.4, rng.random(n), 0.0)
    pig = rng.random((n, 3)).astype(np.float32)
    has = p > 0
    k1 = net.degree + 1.0
    dp = 0.02
    for _ in range(80):
        avg = (p + net.matrix @ p) / k1
        new_p, pig, has = flow_step(net, p, pig, has, send, update, dp, 0.5, 0.5)
        drop = (k1 * p).sum() - (k1 * new_p).sum()
        assert -1e-9 <= drop <= dp * k1[avg > 0].sum() + 1e-9
        assert new_p.min() >= 0 and new_p.max() <= p.max() + 1e-15
        p = new_p


def test_watercolour_commutes_with_cell_permutation():
    net = lattice("hexagon", 16.0)
    n = net.n_cells
    rng = np.random.default_rng(2)
    perm = rng.permutation(n)
    pnet = permuted(net, perm)
    gs = rng.choice([SLEEPING, RECEIVING, INFLUENCING, ACTIVE], n).astype(np.int8)
    p = np.where(rng.random(n) < 0.5, rng.random(n), 0.0)
    pig = rng.random((n, 3)).astype(np.float32)
    has = rng.random(n) < 0.7
    for _ in range(5):
        a = flow_step(net, p, pig, has, sends(gs), receives(gs), 0.01, 0.5, 0.7)
        b = flow_step(pnet, p[perm], pig[perm], has[perm], sends(gs[perm]), receives(gs[perm]),
                      0.01, 0.5, 0.7)
        assert np.allclose(a[0][perm], b[0]) and np.allclose(a[1][perm], b[1], atol=1e-6)
        assert np.array_equal(a[2][perm], b[2])
        p, pig, has = a


@pytest.mark.parametrize("width,crack_state", [("two", "sleeping"), ("one", "influencing")])
def test_crack_rule_leaves_crack_cells_asleep_and_a_second_pass_changes_nothing(width, crack_state):
    net = lattice("triangle", 40.0)
    rng = np.random.default_rng(3)
    seeds = net.positions[rng.choice(net.n_cells, 8, replace=False)]
    label = 1 + np.argmin(np.linalg.norm(net.positions[:, None] - seeds[None], axis=2), axis=1)
    net.add_field("voronoi__label", label.astype(np.int32), at="cell")
    put_states(net, np.full(net.n_cells, ACTIVE, np.int8))
    state = State(seed=1)
    state.add_domain("cells", net)
    rule = CrackDerivative.from_params({"width": width, "crack_state": crack_state}, "t")
    assert rule.step(state)
    crack = np.asarray(net["crack__mask"])
    want = SLEEPING if crack_state == "sleeping" else INFLUENCING
    assert crack.any() and np.all(np.asarray(net["cell__state"])[crack] == want)
    assert np.all(np.asarray(net["cell__state"])[~crack] == ACTIVE)
    assert not rule.step(state)                     # nothing left to crack
    assert np.array_equal(np.asarray(net["crack__mask"]), crack)


def test_young_rule_follows_its_equation_cell_by_cell():
    """p_i <- [h + J1 sum_{r_ij < R1} p_j + J2 sum_{R1 <= r_ij < R2} p_j > 0] over sending cells."""
    net = lattice("triangle", 14.0, seed=4)
    state, gs, alive = random_young_state(net, 5)
    h, j1, j2, r1, r2 = 0.3, 1.0, -0.25, 2.3, 6.0
    rule = ActivatorInhibitor.from_params({"h": h, "j1": j1, "j2": j2, "r1": r1, "r2": r2}, "t")
    rule.setup(state)
    rule.step(state)
    got = np.asarray(net["ca__alive"])
    want = np.where(receives(gs), young_field(net, gs, alive, h, j1, j2, r1, r2) > 0, alive)
    assert np.array_equal(got, want)
    assert math.isclose(got.mean(), want.mean()) and got.any() and not got.all()


def test_splats_cover_a_curved_network_without_speckles():
    """Per-face lattices on a curved mesh leave seams wider than cs; the splats grow to cover them."""
    import trimesh
    from scipy.spatial import cKDTree

    from procgen import check_recipe, get_plugin_manager, run
    from procgen_cellnet.exporters import COVER_MARGIN, cover_radius, splat_mesh

    host = get_plugin_manager()
    steps = [{"rule": "mesh.primitive", "params": {"shape": "icosphere", "subdivisions": 3}},
             {"rule": "cellnet.seed", "params": {"target_cells": 6000, "grid": "triangle"}},
             {"rule": "cellnet.link"}]
    state = run(check_recipe({"steps": steps}, host, "t.toml"), host, seed=1, progress=False).state
    net, mesh = state.domains["cells"], state.domains["mesh"]
    samples, _ = trimesh.sample.sample_surface(trimesh.Trimesh(mesh.vertices, mesh.faces, process=False),
                                               100_000, seed=0)
    d, near = cKDTree(net.positions).query(samples)
    cover = cover_radius(net)
    inscribed = np.cos(np.pi / 6) * np.clip(COVER_MARGIN * cover / np.cos(np.pi / 6), 0.8 * net.cs, 1.2 * net.cs)
    assert np.mean(d > inscribed[near]) < 1e-3
    assert np.mean(d > np.cos(np.pi / 6) * 0.8 * net.cs) > 5e-3     # fixed 0.8 cs splats: speckles
    mesh_out = splat_mesh(net, np.ones((net.n_cells, 3)))
    corners = mesh_out.vertices.reshape(-1, 6, 3)
    assert np.allclose(np.linalg.norm(corners - net.positions[:, None], axis=2).max(axis=1),
                       inscribed / np.cos(np.pi / 6))
    # a flat triangle lattice keeps its 0.8 cs splats: interior regions reach cs / sqrt 3
    flat = lattice("triangle", 12.0)
    inner = flat.degree == 6
    assert np.all(cover_radius(flat)[inner] <= flat.cs / math.sqrt(3) + 1e-9)
    assert np.all(cover_radius(flat)[inner] > 0.5 * flat.cs)


def test_normals_get_one_side_whatever_the_winding_and_melting_keeps_it():
    """Figure 8's pyramid from polygons of any winding: every normal points out (the same normals
    from every decomposition and every winding), and melting across the folds keeps them out
    (averaging an inward with an outward normal across a fold stood splats on edge: streaks)."""
    from procgen import check_recipe, get_plugin_manager, run
    from _cellnet import pyramid_variants

    host = get_plugin_manager()
    base = np.array([2.0, 2.0, 0.5])
    rng = np.random.default_rng(0)
    variants = list(pyramid_variants())
    # the concave variant again with every loop's winding reversed at random
    variants.append([[lp[::-1] if rng.random() < 0.5 else lp for lp in poly] for poly in variants[2]])
    nets = []
    for polys in variants:
        steps = [{"rule": "cellnet.polygons", "params": {"polygons": polys}},
                 {"rule": "cellnet.seed", "params": {"grid": "square8", "cs": 0.2}},
                 {"rule": "cellnet.link"}]
        net = run(check_recipe({"steps": steps}, host, "t.toml"), host, seed=1,
                  progress=False).state.domains["cells"]
        n = np.asarray(net["cell__normal"])
        assert np.all(np.einsum("ij,ij->i", n, net.positions - base) > 0)
        order = np.lexsort(np.round(net.positions / 1e-7).T[::-1])
        nets.append(n[order])
    assert all(n.shape == nets[0].shape and np.abs(n - nets[0]).max() < 1e-12 for n in nets[1:])
    steps.append({"rule": "cellnet.melt", "iterations": 10})
    melted = run(check_recipe({"steps": steps}, host, "t.toml"), host, seed=1,
                 progress=False).state.domains["cells"]
    m = np.asarray(melted["cell__normal"])
    assert np.all(np.einsum("ij,ij->i", m, melted.positions - base) > 0)


def test_an_open_box_faces_out_and_a_flat_sheet_keeps_its_winding():
    from procgen_cellnet.orientation import orient_polygons, wound, loop_normal

    sq = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    sheet = [[sq], [sq + [1, 0, 0]], [(sq + [0, 1, 0])[::-1]]]       # one of three reversed
    sheet = [wound(p, loop_normal(p[0])) for p in sheet]
    assert orient_polygons(sheet) == [False, False, True]
    # an open box (no lid) of four walls and a floor, walls wound at random
    walls = [np.array([[0, 0, 0], [1, 0, 0], [1, 0, 1], [0, 0, 1]], float),
             np.array([[1, 0, 0], [1, 1, 0], [1, 1, 1], [1, 0, 1]], float),
             np.array([[1, 1, 0], [0, 1, 0], [0, 1, 1], [1, 1, 1]], float)[::-1],
             np.array([[0, 1, 0], [0, 0, 0], [0, 0, 1], [0, 1, 1]], float),
             sq]
    polys = [wound([w], loop_normal(w)) for w in walls]
    flips = orient_polygons(polys)
    centre = np.array([0.5, 0.5, 0.5])
    for p, f in zip(polys, flips):
        n = loop_normal(p[0]) * (-1 if f else 1)
        assert n @ (p[0].mean(axis=0) - centre) > 0, (p[0], f)
