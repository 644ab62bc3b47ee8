"""Cellular network construction (seed 002 sections 3-4): lattices, box index, links, inputs."""
from __future__ import annotations

import math

import numpy as np
import pytest

from procgen import InputError, RecipeError, check_recipe, run
from procgen.ca.cells import cell_graph, is_cell_domain
from procgen.ca.graph import grid_graph

from _cellnet import pyramid_variants
from procgen_cellnet.boxes import BoxIndex, pairs_brute, pairs_kdtree, pairs_within
from procgen_cellnet.network import CellNetwork
from procgen_cellnet.polygons import polygons_mesh
from procgen_cellnet.seeding import DEGREE, DENSITY, link_radius, seed_cells

L = 40.0
SQUARE = (np.array([[0, 0, 0], [L, 0, 0], [L, L, 0], [0, L, 0]], float), np.array([[0, 1, 2], [0, 2, 3]]))
LATTICES = ("square4", "square8", "triangle", "hexagon")


def _net(grid, v=SQUARE[0], f=SQUARE[1], cs=1.0, seed=0):
    s = seed_cells(v, f, grid, cs, rng=np.random.default_rng(seed))
    r = link_radius(grid, cs, 0.01)
    return s, pairs_within(s.positions, r, BoxIndex.build(s.positions, 2 * cs))


@pytest.mark.parametrize("grid", LATTICES)
def test_interior_degree_density_and_hygiene(grid):
    s, links = _net(grid)
    p = s.positions
    deg = np.bincount(links.ravel(), minlength=len(p))
    inner = np.all((p[:, :2] > 2) & (p[:, :2] < L - 2), axis=1)
    assert inner.sum() > 500 and np.all(deg[inner] == DEGREE[grid])
    # density: ideal per cs^2, plus at most one boundary row per side
    assert DENSITY[grid] * (L - 2) ** 2 <= len(p) <= DENSITY[grid] * (L + 2) ** 2
    assert abs(len(p) / L ** 2 / DENSITY[grid] - 1) < 0.05
    # hygiene: i < j, unique, shorter than r_i, nothing closer than cs
    assert np.all(links[:, 0] < links[:, 1]) and len(np.unique(links, axis=0)) == len(links)
    d = np.linalg.norm(p[links[:, 0]] - p[links[:, 1]], axis=1)
    assert d.max() < link_radius(grid, 1.0, 0.01) and d.min() > 1 - 1e-9


def test_random_grid_has_round_area_cells_per_plane():
    s, _ = _net("random", cs=0.7)
    assert len(s.positions) == round(L * L / 0.49)


@pytest.mark.parametrize("accelerate", [False, True], ids=["numpy", "numba"])
@pytest.mark.parametrize("layout", ["random", "clustered", "far", "scattered"])
def test_every_method_gives_identical_links(layout, accelerate):
    if accelerate:
        pytest.importorskip("numba")
    rng = np.random.default_rng(3)
    if layout == "scattered":       # clusters 1e13 boxes apart: keys too spread to pack in int64
        a = rng.random((500, 3)) * [10, 10, 4]
        p = np.concatenate([a + np.array(o) * 2e13 for o in ([0, 0, 0], [1, -1, 1], [-1, 1, 0])])
    elif layout == "random":
        p = rng.random((1500, 3)) * [20, 20, 4]
    elif layout == "clustered":     # two objects 1e-3 cs apart
        a = rng.random((700, 3)) * [10, 10, 0.2]
        p = np.concatenate([a, a + [10.001, 0, 0]])
    else:                            # +-1e6 boxes from the origin
        p = rng.random((1500, 3)) * [20, 20, 4] + np.array([1e6, -1e6, 3e5]) * 2.0
    r = math.sqrt(3) - 0.01
    boxes = pairs_within(p, r, BoxIndex.build(p, 2.0), accelerate=accelerate)
    assert len(boxes) > 1000
    assert np.array_equal(boxes, pairs_kdtree(p, r))
    assert np.array_equal(boxes, pairs_brute(p, r))
    # translating by a whole number of boxes changes neither boxes nor links (boundless)
    moved = p + np.array([-7, 1234567, 89]) * 2.0
    ib, im = BoxIndex.build(p, 2.0), BoxIndex.build(moved, 2.0)
    assert ib.n_boxes == im.n_boxes and np.array_equal(ib.counts, im.counts)
    assert np.array_equal(pairs_within(moved, r, im, accelerate=accelerate), boxes)
    # the packed-key lookup and the walk down the x -> y -> z levels agree, present or not
    assert (ib._packed is None) == (layout == "scattered")
    q = np.concatenate([ib.keys, ib.keys + [0, 0, 1], ib.keys + [3, -2, 0], ib.keys * 2])
    assert np.array_equal(ib.lookup(q), ib._walk(q))
    assert np.array_equal(ib.lookup(ib.keys), np.arange(ib.n_boxes))


def test_stencil_guard_catches_what_kb_1_misses():
    p = seed_cells(*SQUARE, "random", 1.0, rng=np.random.default_rng(2)).positions
    r = link_radius("square8", 1.0, 0.01)
    truth = pairs_kdtree(p, r)
    small = BoxIndex.build(p, 1.0)
    lost = pairs_within(p, r, small, guard=False)
    assert len(lost) < len(truth)          # kb = 1: partners two boxes away are missed
    with pytest.raises(InputError, match="would miss links"):
        pairs_within(p, r, small)
    with pytest.raises(RecipeError, match="kb >= 2"):
        _recipe([{"rule": "cellnet.seed", "params": {"target_cells": 300, "grid": "square8"}},
                 {"rule": "cellnet.link", "params": {"kb": 1.0}}])


def _recipe(steps, mesh=None):
    from procgen import get_plugin_manager
    first = mesh or {"rule": "mesh.primitive", "params": {"shape": "cube"}}
    host = get_plugin_manager()
    return run(check_recipe({"steps": [first] + steps}, host, "t.toml"), host, seed=1,
               progress=False).state


def test_box_counts_and_membership():
    s, _ = _net("square4")
    for bs in (2.0, 3.0, 5.0):
        idx = BoxIndex.build(s.positions, bs)
        keys = np.floor(s.positions / bs).astype(np.int64)
        assert idx.n_boxes == len(np.unique(keys, axis=0))
        assert np.array_equal(np.sort(idx.order), np.arange(len(s.positions)))
        assert np.all(idx.keys[idx.cell_box] == keys)
        assert np.all(idx.counts > 0)
        assert idx.n_boxes == math.ceil(L / bs) ** 2
        assert idx.n_columns == idx.n_boxes and len(idx.x_nodes) == math.ceil(L / bs)


def test_figure_4_fixture_lookup_and_lists():
    keys = np.array([[5, 5, 0], [5, 5, -4], [5, 5, -7], [4, 5, 0], [5, 3, 2], [7, -1, -7]])
    idx = BoxIndex.from_keys(keys, 1.0)
    assert idx.lookup(np.array([[5, 5, -4], [5, 5, -5], [5, 4, 0]])).tolist()[1:] == [-1, -1]
    assert tuple(idx.keys[idx.lookup(np.array([[5, 5, -4]]))[0]]) == (5, 5, -4)
    text = idx.dump()
    assert "X[5] -> Y[3]: Z[2] | Y[5]: Z[-7] <-> Z[-4] <-> Z[0]" in text
    assert text.splitlines()[0].startswith("X[4]") and len(idx.x_nodes) == 3


def test_dynamic_moves_equal_a_rebuild():
    rng = np.random.default_rng(5)
    p = rng.random((3000, 3)) * 30 - 15
    idx = BoxIndex.build(p, 2.0)
    for _ in range(6):
        p = p.copy()
        k = rng.choice(len(p), 300, replace=False)
        p[k] += rng.normal(0, 3, (300, 3))
        idx = idx.moved(p)
        ref = BoxIndex.build(p, 2.0)
        for name in ("keys", "start", "order", "cell_box"):
            assert np.array_equal(getattr(idx, name), getattr(ref, name)), name
        assert np.all(idx.counts > 0)      # no empty box survives


def test_figure_8_decomposition_gives_the_same_network():
    results = []
    for polys in pyramid_variants():
        m = polygons_mesh(polys, None, None)
        s = seed_cells(m.vertices, m.faces, "square8", 0.25)
        order = np.lexsort(np.round(s.positions / 1e-7).T[::-1])
        p = s.positions[order]
        idx = BoxIndex.build(p, 0.5)
        results.append((p, idx.keys, pairs_within(p, link_radius("square8", 0.25, 0.01), idx)))
    ref = results[0]
    assert len(ref[0]) > 600
    for p, keys, links in results[1:]:
        assert p.shape == ref[0].shape and np.abs(p - ref[0]).max() < 1e-9 * 0.25
        assert np.array_equal(keys, ref[1]) and np.array_equal(links, ref[2])


def test_holes_gaps_and_objects():
    outer = [[0, 0, 0], [10, 0, 0], [10, 10, 0], [0, 10, 0]]
    hole = [[3, 3, 0], [7, 3, 0], [7, 7, 0], [3, 7, 0]]
    m = polygons_mesh([[outer, hole]], None, None)
    s = seed_cells(m.vertices, m.faces, "triangle", 0.5)
    p = s.positions
    assert not np.any(np.all((p[:, :2] > 3 + 1e-9) & (p[:, :2] < 7 - 1e-9), axis=1))
    assert np.any(np.all(p[:, :2] < 3, axis=1))
    # two objects: near ones link across, far ones do not
    sq = [[0, 0, 0], [4, 0, 0], [4, 4, 0], [0, 4, 0]]
    for gap, expect in ((0.2, True), (3.0, False)):
        other = [[x + 4 + gap, y, z + 0.3] for x, y, z in sq]     # a parallel plane above
        m = polygons_mesh([[sq], [other]], [0, 1], None)
        s = seed_cells(m.vertices, m.faces, "square8", 0.5)
        obj = m["face__object"][s.face]
        links = pairs_kdtree(s.positions, link_radius("square8", 0.5, 0.01))
        assert bool(np.any(obj[links[:, 0]] != obj[links[:, 1]])) is expect


def test_bunny_with_a_missing_triangle_builds_and_links():
    st = _recipe([{"rule": "cellnet.seed", "params": {"target_cells": 4000, "normals": "vertex"}},
                  {"rule": "cellnet.link"}],
                 mesh={"rule": "mesh.load", "params": {"path": "bunny-4k.obj", "normalize": True}})
    net = st.domains["cells"]
    assert isinstance(net, CellNetwork) and is_cell_domain(net)
    assert 3000 < net.n_cells < 5000 and net.n_links > 2 * net.n_cells
    n = net["cell__normal"]
    assert np.allclose(np.linalg.norm(n, axis=1), 1)


def test_cell_graph_directions_are_moore_slots_on_square8():
    """A square-8 network hands out the Moore graph of a plain grid (cells in row-major order)."""
    nx = ny = 12
    v = np.array([[0, 0, 0], [nx, 0, 0], [nx, ny, 0], [0, ny, 0]], float)
    s = seed_cells(v, np.array([[0, 1, 2], [0, 2, 3]]), "square8", 1.0)
    order = np.lexsort((s.positions[:, 0], s.positions[:, 1]))
    p = s.positions[order]
    net = CellNetwork(p, pairs_kdtree(p, link_radius("square8", 1.0, 0.01)), cs=1.0, grid="square8",
                      radius=1.99)
    ref = grid_graph(ny, nx)
    g = cell_graph(net, "moore")
    assert np.array_equal(g.indptr, ref.indptr)
    key = lambda gr: np.lexsort((gr.indices, gr.rows))
    assert np.array_equal(g.indices[key(g)], ref.indices[key(ref)])
    assert np.array_equal(g.direction[key(g)], ref.direction[key(ref)])
    vn = cell_graph(net, "von_neumann")
    assert np.all(vn.degree[(p[:, 0] > 1) & (p[:, 0] < nx - 1) & (p[:, 1] > 1) & (p[:, 1] < ny - 1)] == 4)


@pytest.mark.parametrize("bad,match", [
    ([[[[0, 0, 0], [1, 0, 0]]]], "at least 3 vertices"),
    ([[[[0, 0, 0], [1, 1, 0], [1, 0, 0], [0, 1, 0]]]], "self-intersecting"),
    ([[[[0, 0, 0], [1, 0, 0], [1, 1, 0.5], [0, 1, 0]]]], "not planar"),
])
def test_bad_polygons_are_one_line_errors(bad, match):
    with pytest.raises(InputError, match=match) as info:
        polygons_mesh(bad, None, None)
    assert "\n" not in str(info.value)


def test_bad_sizes_are_refused_before_allocating():
    with pytest.raises(InputError, match="larger than the object"):
        seed_cells(*SQUARE, "triangle", 50.0)
    with pytest.raises(InputError, match=r"~1\.6e\+11 cells"):
        seed_cells(*SQUARE, "square4", 1e-4, max_bytes=2**30)
    with pytest.raises(RecipeError, match="GiB"):
        _recipe([{"rule": "cellnet.seed", "params": {"target_cells": 190_000_000}}])
