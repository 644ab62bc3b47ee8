"""The compiled ca.voronoi step (procgen.ca.kernels) against the numpy reference, exactly.

The compiled step reads the graph through its own links (diagonal flag in the sign bit, the
one-way remainder of the transposed graph), keeps the frontier as a bitmap and draws from the
Generator inside the kernel: each of those must give the numpy path's labels, frontier and
random stream, on graphs with one-way links, holes and cells past several bitmap words.
"""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from procgen import Grid, State
from procgen.ca.graph import CellGraph, grid_graph
from procgen.ca.propagation import VoronoiGrowth, VoronoiPropagation, place_seeds
from procgen_surface.domain import SurfaceCells

kernels = pytest.importorskip("procgen.ca.kernels")


def _one_way_grid() -> CellGraph:
    """A 45 x 61 Moore grid (2745 cells, 43 bitmap words) with a fifth of its entries dropped:
    many links one-way, some cells with no way out or in, diagonal flags kept."""
    g = grid_graph(45, 61)
    return g.restrict(np.random.default_rng(3).random(g.indices.size) > 0.2)


def _cylinder() -> CellGraph:
    """Surface cells of a 12-sided cylinder: the one-way cross-edge links of a real mesh."""
    cyl = trimesh.creation.cylinder(radius=1.0, height=2.2, sections=12)
    return SurfaceCells.from_mesh(np.asarray(cyl.vertices), np.asarray(cyl.faces), target_cells=3000).graph


GRAPHS = {"one-way-grid": _one_way_grid(), "cylinder": _cylinder()}


@pytest.mark.parametrize("name", sorted(GRAPHS))
def test_links_are_the_ids_the_diagonals_and_the_transpose_minus_the_graph(name):
    g = GRAPHS[name]
    links = kernels.voronoi_links(g)
    np.testing.assert_array_equal(links.links & links.id_mask, g.indices)
    np.testing.assert_array_equal(links.links < 0, g.is_diagonal)
    back = g.incoming
    expect_ptr, expect = [0], []              # independent: per cell, Python sets
    for c in range(g.n_cells):
        own = set(g.indices[g.indptr[c]:g.indptr[c + 1]].tolist())
        expect += [t for t in back.indices[back.indptr[c]:back.indptr[c + 1]].tolist() if t not in own]
        expect_ptr.append(len(expect))
    np.testing.assert_array_equal(links.xptr, expect_ptr)
    np.testing.assert_array_equal(links.xidx, expect)
    assert len(expect) > 0.01 * g.indices.size    # the graph has one-way links to follow


@pytest.mark.parametrize("name", sorted(GRAPHS))
@pytest.mark.parametrize("p_diagonal", [0.2071, 0.0])
def test_compiled_step_equals_numpy_step_with_one_way_links_and_holes(name, p_diagonal):
    g = GRAPHS[name]
    rng = np.random.default_rng(5)
    present = rng.random(g.n_cells) > 0.05
    labels = place_seeds(g.n_cells, 4, rng, present)
    labels[~present] = -1
    ref = VoronoiGrowth(g, labels.copy(), p_diagonal, accelerate=False)
    fast = VoronoiGrowth(g, labels.copy(), p_diagonal, accelerate=True)
    r1, r2 = np.random.default_rng(9), np.random.default_rng(9)
    steps = 0
    while steps < 300:                        # (p = 0: cells reached only diagonally stay frontier)
        n1, n2 = ref.step(r1), fast.step(r2)
        assert n1 == n2, steps
        np.testing.assert_array_equal(fast.labels, ref.labels, err_msg=f"labels at step {steps}")
        np.testing.assert_array_equal(fast.frontier, ref.frontier, err_msg=f"frontier at step {steps}")
        assert fast.frontier.dtype == np.int64
        steps += 1
        if n1 == 0 and len(ref.frontier) == 0:
            break
    assert steps > 20 and np.sum(ref.labels > 0) > 0.5 * g.n_cells
    assert r1.random() == r2.random()         # and drew the same numbers


def test_buffers_kept_and_labels_set_from_outside_are_read_again():
    """The step keeps its per-cell buffers across steps, sizes its candidate buffer by the
    frontier (not the domain), and re-reads a labels array replaced between steps."""
    g = grid_graph(80, 90)
    labels = place_seeds(g.n_cells, 3, np.random.default_rng(1))
    ref = VoronoiGrowth(g, labels.copy(), accelerate=False)
    fast = VoronoiGrowth(g, labels.copy(), accelerate=True)
    r1, r2 = np.random.default_rng(2), np.random.default_rng(2)
    for _ in range(5):
        ref.step(r1), fast.step(r2)
    work = fast.__dict__[kernels._ATTR]
    st, words = work.st, work.words
    biggest = 0
    for k in range(200):
        if k == 10:                            # a new labels array (and frontier) from outside
            assert work.cand.size < g.indices.size / 4     # three discs' frontier, not the domain
            new = ref.labels.copy()
            new[np.nonzero(new == 0)[0][::7]] = 4
            ref.labels, fast.labels = new.copy(), new.copy()
            ref.frontier = fast.frontier = ref._frontier_of(np.nonzero(new > 0)[0])
        biggest = max(biggest, len(fast.frontier))
        assert ref.step(r1) == fast.step(r2)
        np.testing.assert_array_equal(fast.labels, ref.labels)
        np.testing.assert_array_equal(fast.frontier, ref.frontier)
    assert len(ref.frontier) == 0 and np.all(ref.labels > 0) and np.any(ref.labels == 4)
    assert work.st is st and work.words is words and not words.any()
    assert work.cand.size <= 2 * biggest * 8 + 1


def _rule_run(accelerate: str, monkeypatch) -> tuple:
    monkeypatch.setenv("PROCGEN_ACCELERATE", accelerate)
    dom = Grid((50, 70))
    rule = VoronoiPropagation.from_params({"seeds": 7})
    st = State(seed=4)
    st.add_domain("cells", dom)
    st.rule_name = rule.name
    rule.setup(st)
    k = 0
    while True:
        st.iteration = k
        if not rule.step(st):
            break
        k += 1
    rule.finish(st)
    return k, np.array(dom["voronoi__label"]), dict(st.reports)


def test_rule_gives_the_same_regions_and_reports_on_both_paths(monkeypatch):
    """ca.voronoi through State.rng (the rule's PCG64 streams) on both paths."""
    steps, lab, rep = _rule_run("0", monkeypatch)
    steps2, lab2, rep2 = _rule_run("1", monkeypatch)
    assert steps == steps2 > 5 and rep == rep2
    np.testing.assert_array_equal(lab2, lab)
    assert set(np.unique(lab)) == set(range(1, 8))
