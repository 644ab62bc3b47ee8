"""The compiled cell-automaton steps (procgen.ca.kernels) against the numpy reference, exactly."""
from __future__ import annotations

import numpy as np
import pytest

from procgen.ca.graph import CellGraph, grid_graph
from procgen.ca.lifelike import life_step, parse_rule
from procgen.ca.propagation import VoronoiGrowth, place_seeds


def _graphs():
    g = grid_graph(37, 53)
    rng = np.random.default_rng(4)
    # an irregular graph without lattice directions: degrees 0..12, repeated links count twice
    n = 900
    deg = rng.integers(0, 13, n)
    indptr = np.concatenate([[0], np.cumsum(deg)]).astype(np.int64)
    irregular = CellGraph(indptr, rng.integers(0, n, int(deg.sum())).astype(np.int64))
    return {"grid": g, "grid-wrap": grid_graph(20, 30, wrap=True), "irregular": irregular,
            "transposed": g.incoming, "von-neumann": g.neighbourhood("von_neumann")}


GRAPHS = _graphs()


@pytest.mark.parametrize("name", sorted(GRAPHS))
@pytest.mark.parametrize("rule", ["B3/S23", "25/357", "B0123478/S01234678"])
def test_compiled_life_equals_numpy_life(name, rule):
    g = GRAPHS[name]
    lut = parse_rule(rule, "table").lut(int(g.degree.max(initial=0)))
    a = np.random.default_rng(1).random(g.n_cells) < 0.3
    b, out = a.copy(), np.empty(g.n_cells, bool)
    changes = 0
    for _ in range(30):
        na = life_step(g, a, lut, accelerate=False)
        nb = life_step(g, b, lut, out=out, accelerate=True)
        np.testing.assert_array_equal(nb, na)
        changes += int(np.sum(na != a))
        a, b = na, nb.copy()
    assert changes > 0


@pytest.mark.parametrize("name", sorted(GRAPHS))
@pytest.mark.parametrize("p_diagonal", [0.2071, 1.0])
def test_compiled_voronoi_equals_numpy_voronoi(name, p_diagonal):
    g = GRAPHS[name]
    rng = np.random.default_rng(5)
    present = rng.random(g.n_cells) > 0.1          # holes
    labels = place_seeds(g.n_cells, 6, rng, present)
    labels[~present] = -1
    ref = VoronoiGrowth(g, labels.copy(), p_diagonal, accelerate=False)
    fast = VoronoiGrowth(g, labels.copy(), p_diagonal, accelerate=True)
    r1, r2 = np.random.default_rng(9), np.random.default_rng(9)
    for _ in range(400):
        n1, n2 = ref.step(r1), fast.step(r2)
        assert n1 == n2
        np.testing.assert_array_equal(fast.labels, ref.labels)
        np.testing.assert_array_equal(fast.frontier, ref.frontier)
        if n1 == 0 and len(ref.frontier) == 0:
            break
    if name != "irregular":                          # one-way links can leave unreachable cells
        assert len(ref.frontier) == 0 and np.all(ref.labels[present] != 0)
    assert np.sum(ref.labels > 0) > 0.5 * g.n_cells
    assert r1.random() == r2.random()               # and drew the same numbers
