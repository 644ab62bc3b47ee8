"""The generic CA rules on every cell domain: Grid = surface cells of a flat square, synchronous
updates (invariant under a permutation of cell ids), determinism, majority, kind checks."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from procgen import Grid, PointSet, State
from procgen.ca.cells import cell_centres, cell_graph, cell_values
from procgen.ca.graph import CellGraph, grid_graph
from procgen.ca.lifelike import LifeLike, life_step, parse_rule
from procgen.ca.majority import Majority, majority_step, plurality_step
from procgen.ca.propagation import VoronoiGrowth, VoronoiPropagation
from procgen.errors import RecipeError
from procgen.recipes import check_recipe
from procgen_surface.domain import SurfaceCells

N = 16                    # lattice cells per side of the unit square


def flat_square() -> SurfaceCells:
    """Surface cells of the unit square [0, 1]^2, with lattice-aligned triangle frames.

    The mesh is the flat square [-1, 2]^2 cut along its diagonal x + y = 1, which crosses the
    unit square corner to corner.  The 3DSCA frame puts corner A at (0, 0) and AB along +y
    (thesis 3.2): face (0, 1, 2) has A = (-1, -1), B = (-1, 2), so its frame is the world's
    shifted by whole cells; face (3, 2, 1) has A = (2, 2), B = (2, -1): the world's turned by
    180 degrees about a lattice point.  With s = 1/16 both triangle grids are the world lattice;
    the diagonal passes through the corners of the lattice squares with i + j = 15, which are
    split into two half-cells, one per triangle, and unfolding across it lands on the same
    lattice square.  Cells outside the unit square are marked absent (``cell__alive`` False),
    which the CA rules treat like the Grid's outside.  The diagonal's ends lie far outside the
    unit square, so no slot there is clamped to the nearest cell of the other triangle.
    """
    v = np.array([[-1, -1, 0], [-1, 2, 0], [2, -1, 0], [2, 2, 0]], float)
    f = np.array([[0, 1, 2], [3, 2, 1]])
    sc = SurfaceCells.from_mesh(v, f, cell_size=1.0 / N)
    xy = sc.center3d[:, :2]
    sc.add_field("cell__alive", np.all((xy > 0) & (xy < 1), axis=1), at="cell")
    return sc


def lattice_ids(sc: SurfaceCells) -> np.ndarray:
    """Grid cell id (row * N + column) of the lattice square holding each surface cell's centre
    (-1 for cells outside the unit square)."""
    ij = np.floor(sc.center3d[:, :2] * N).astype(int)
    return np.where(np.asarray(sc["cell__alive"]), ij[:, 1] * N + ij[:, 0], -1)


def run(rule, dom, steps: int, seed: int = 1) -> State:
    st = State(seed=seed)
    st.add_domain("cells", dom)
    st.rule_name = rule.name
    rule.setup(st)
    for k in range(steps):
        st.iteration = k
        if not rule.step(st):
            break
    rule.finish(st)
    return st


def test_flat_square_cells_are_the_grid_lattice():
    sc = flat_square()
    ids = lattice_ids(sc)
    inside = ids >= 0
    assert inside.sum() == N * N + N                  # 16 diagonal squares counted twice (halves)
    assert np.bincount(ids[inside], minlength=N * N).tolist() == \
        [2 if i + j == N - 1 else 1 for j in range(N) for i in range(N)]
    g = cell_graph(sc)
    g = g.restrict(inside[g.rows] & inside[g.indices])
    # every cell's neighbours cover exactly its Grid neighbours' lattice squares, once each
    grid = grid_graph(N, N)
    for c in np.nonzero(inside)[0]:
        mine = ids[g.indices[g.indptr[c]:g.indptr[c + 1]]]
        want = grid.indices[grid.indptr[ids[c]]:grid.indptr[ids[c] + 1]]
        assert sorted(mine.tolist()) == sorted(want.tolist()), c


@pytest.mark.parametrize("rule, semantics, neighbourhood", [
    ("B3/S23", "literal", "moore"), ("B3/S234", "literal", "moore"), ("25/357", "table", "moore"),
    ("25/2356", "literal", "moore"), ("B2/S", "literal", "von_neumann")])
def test_same_rule_on_a_grid_and_on_the_surface_cells_of_a_flat_square(rule, semantics, neighbourhood):
    sc, grid = flat_square(), Grid((N, N), spacing=1.0 / N)
    ids = lattice_ids(sc)
    start = np.random.default_rng(9).random(N * N) < 0.4
    grid.add_field("ca__alive", start.reshape(N, N), at="cell")
    sc.add_field("ca__alive", start[ids] & (ids >= 0), at="cell")
    params = {"rule": rule, "semantics": semantics, "neighbourhood": neighbourhood, "initial": "field"}
    a, b = LifeLike.from_params(params), LifeLike.from_params(params)
    sa, sb = State(seed=1), State(seed=1)
    sa.add_domain("cells", grid), sb.add_domain("cells", sc)
    a.setup(sa), b.setup(sb)
    for k in range(40):
        a.step(sa), b.step(sb)
        g, s = cell_values(grid, "ca__alive"), cell_values(sc, "ca__alive")
        np.testing.assert_array_equal(s[ids >= 0], g[ids[ids >= 0]], err_msg=f"step {k}")
        assert not s[ids < 0].any()
    inside = ids >= 0
    np.testing.assert_array_equal(cell_values(sc, "ca__age")[inside], cell_values(grid, "ca__age")[ids[inside]])
    assert 0 < g.sum() < N * N or rule == "B2/S"


def test_voronoi_and_majority_agree_on_grid_and_flat_square():
    sc, grid = flat_square(), Grid((N, N), spacing=1.0 / N)
    ids = lattice_ids(sc)
    # one seed and p_diagonal 1: no random choice left (every label reaches a cell alone)
    pa = {"seeds": 1, "p_diagonal": 1.0, "seed_points": [[0.3, 0.2]]}
    sa = run(VoronoiPropagation.from_params(pa), grid, 100)
    sb = run(VoronoiPropagation.from_params(dict(pa, seed_points=[[0.3, 0.2, 0.0]])), sc, 100)
    # Chebyshev distance 12 from lattice square (4, 3) to (15, 15); the coverage log's entry 0
    # is the empty surface and entry 1 the seeds, so full coverage is entry 12 + 1
    assert sa.reports["cells.voronoi.steps_to_full"] == sb.reports["cells.voronoi.steps_to_full"] == 13
    np.testing.assert_array_equal(sa.domains["coverage"].points[:, 0], sb.domains["coverage"].points[:, 0])
    # labels of several seeds, then a plurality vote (deterministic) on both
    start = np.random.default_rng(2).integers(1, 4, N * N)
    grid.add_field("region__label", start.reshape(N, N), at="cell")
    inside = ids >= 0
    sc.add_field("region__label", np.where(inside, start[ids], 0), at="cell")
    p = {"field": "region__label", "initial": "field"}
    run(Majority.from_params(p), grid, 30), run(Majority.from_params(p), sc, 30)
    np.testing.assert_array_equal(cell_values(sc, "region__label")[inside],
                                  cell_values(grid, "region__label")[ids[inside]])
    # the Voronoi labels too: every present cell labelled, the same as its lattice square
    np.testing.assert_array_equal(cell_values(sb.domains["cells"], "voronoi__label")[inside],
                                  cell_values(grid, "voronoi__label")[ids[inside]])


def permuted(g: CellGraph, perm: np.ndarray) -> CellGraph:
    """The same graph with cell c renamed perm[c] (rows re-sorted, entry order shuffled too)."""
    rows, cols = perm[g.rows], perm[g.indices]
    order = np.lexsort((np.random.default_rng(0).random(len(rows)), rows))
    indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=g.n_cells))])
    return CellGraph(indptr, cols[order], g.direction[order], None)


def test_steps_are_synchronous_invariant_under_a_permutation_of_cell_ids():
    m = trimesh.creation.icosphere(subdivisions=1)
    sc = SurfaceCells.from_mesh(np.asarray(m.vertices), np.asarray(m.faces), target_cells=3000)
    g = sc.graph
    perm = np.random.default_rng(4).permutation(g.n_cells)
    gp = permuted(g, perm)
    rng = np.random.default_rng(1)
    alive = rng.random(g.n_cells) < 0.3
    labels = rng.integers(0, 5, g.n_cells)
    x, xp = alive, np.empty_like(alive)
    xp[perm] = alive
    lut = parse_rule("25/357", "table").lut()
    for _ in range(30):
        x, xp = life_step(g, x, lut), life_step(gp, xp, lut)
        np.testing.assert_array_equal(xp[perm], x)
    for step in (majority_step, plurality_step):
        s = alive if step is majority_step else labels
        sp = np.empty_like(s)
        sp[perm] = s
        for _ in range(10):
            s, sp = step(g, s), step(gp, sp)
            np.testing.assert_array_equal(sp[perm], s)
    # Voronoi with one seed and p_diagonal 0 or 1 involves no random choice: same regions
    for p in (0.0, 1.0):
        lab = np.zeros(g.n_cells, np.int32)
        lab[17] = 1
        lp = np.zeros_like(lab)
        lp[perm] = lab
        v, vp = VoronoiGrowth(g, lab, p), VoronoiGrowth(gp, lp, p)
        for _ in range(15):
            v.step(np.random.default_rng(0)), vp.step(np.random.default_rng(0))
            np.testing.assert_array_equal(vp.labels[perm], v.labels)
    # and a step never reads its own output: a Life step from a state equals the rule applied
    # to counts taken from that same state (a sequential update would differ here)
    n = np.bincount(g.rows, weights=alive[g.indices], minlength=g.n_cells).astype(int)
    np.testing.assert_array_equal(life_step(g, alive, lut), lut[n, alive.astype(int)])


def test_majority_two_sided_vote_ends_in_a_fixed_point_or_2_cycle():
    g = grid_graph(40, 40)
    x = np.random.default_rng(6).random(1600) < 0.5
    hist = [x]
    for _ in range(80):
        x = majority_step(g, x)
        hist.append(x)
    assert np.array_equal(hist[-1], hist[-3])            # Goles-Olivos: period 1 or 2
    k = g.degree
    kp = g.count(hist[-2])
    np.testing.assert_array_equal(hist[-1][2 * kp > k], True)
    np.testing.assert_array_equal(hist[-1][2 * kp < k], False)
    # plurality on labels: a lone cell inside a region takes the region's label; ties keep own
    lab = np.full(25, 2)
    lab[12] = 7
    assert plurality_step(grid_graph(5, 5), lab)[12] == 2
    line = grid_graph(1, 3)                               # the middle cell sees both ends
    assert plurality_step(line, np.array([5, 1, 3]))[1] == 3     # tie, own not in it: smallest
    assert plurality_step(line, np.array([5, 5, 3]))[1] == 5     # tie including own: kept
    assert plurality_step(line, np.array([5, -1, 3]))[1] == -1   # no cell: never changes


def test_rules_are_deterministic_and_seeded(host):
    from procgen.runner import run as run_recipe
    recipe = {"steps": [
        {"rule": "mesh.primitive", "params": {"shape": "icosphere", "subdivisions": 1}},
        {"rule": "surface.cells", "params": {"target_cells": 1500}},
        {"rule": "ca.life", "iterations": 20, "params": {"rule": "25/357", "semantics": "table", "density": 0.2,
                                                         "initial_age": 20}},
        {"rule": "ca.voronoi", "until": "stable", "params": {"seeds": 5}},
        {"rule": "ca.majority", "iterations": 5, "params": {"field": "voronoi__label", "initial": "field"}}]}
    out = []
    for seed in (3, 3, 4):
        st = run_recipe(check_recipe(recipe, host), host, seed=seed, progress=False).state
        sc = st.domains["cells"]
        out.append([np.array(sc[k]) for k in ("ca__alive", "ca__age", "voronoi__label")])
    for a, b in zip(out[0], out[1]):
        np.testing.assert_array_equal(a, b)
    assert not np.array_equal(out[0][0], out[2][0])


def test_ca_rules_refuse_a_domain_that_is_not_a_cell_domain(host):
    for made in ({"rule": "points.poisson_disk", "params": {"radius": 0.1, "domain": "cells"}},
                 {"rule": "mesh.primitive", "params": {"mesh": "cells"}}):
        for rule in ("ca.life", "ca.voronoi", "ca.majority"):
            with pytest.raises(RecipeError) as exc:
                check_recipe({"steps": [made, {"rule": rule}]}, host)
            msg = str(exc.value)
            assert "\n" not in msg and "'cells'" in msg
            assert "to be a cell domain (" in msg and "Grid" in msg and "SurfaceCells" in msg
    st = State()
    st.add_domain("cells", PointSet(np.zeros((3, 2))))
    with pytest.raises(Exception, match="not a cell domain"):
        cell_graph(st.domains["cells"])
    with pytest.raises(Exception, match="expected a cell domain"):
        st.get("cells", "CellDomain")


def test_rules_show_names_the_domain_kinds(capsys):
    from procgen.cli import main
    assert main(["rules", "show", "ca.life"]) == 0
    out = capsys.readouterr().out
    assert "{cells} (any cell domain: " in out


def test_grid_cell_centres_follow_cell_ids():
    g = Grid((3, 4), spacing=2.0, origin=(10.0, 20.0))
    c = cell_centres(g)
    assert c[1 * 4 + 2].tolist() == [10.0 + 5.0, 20.0 + 3.0]     # row 1, column 2
