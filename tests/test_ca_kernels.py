"""The compiled cell-automaton steps (procgen.ca.kernels) against the numpy reference, exactly."""
from __future__ import annotations

import numpy as np
import pytest

from procgen import Grid, State
from procgen.ca.graph import CellGraph, grid_graph
from procgen.ca.lifelike import LifeLike, life_step, parse_rule
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
    start = labels.copy()
    ref = VoronoiGrowth(g, labels, p_diagonal, accelerate=False)      # one input, two growths:
    fast = VoronoiGrowth(g, labels, p_diagonal, accelerate=True)      # each grows its own copy
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
    np.testing.assert_array_equal(labels, start)    # the caller's labels are left alone


def _life_rule_run(accelerate: str, monkeypatch, params: dict, steps: int = 25, active_share: float | None = None,
                   threads: int | None = None) -> list[tuple]:
    """ca.life on a 40 x 60 grid with holes; the fields after every step.  ``active_share``:
    the compiled run's switch to activity tracking (1.0: from the first step on)."""
    monkeypatch.setenv("PROCGEN_ACCELERATE", accelerate)
    if accelerate == "1":
        import numba
        from procgen.ca.kernels import LifeRun
        if active_share is not None:
            monkeypatch.setattr(LifeRun, "ACTIVE_SHARE", active_share)
        if threads is not None:                      # (set back to all threads below)
            numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    rng = np.random.default_rng(2)
    dom = Grid((40, 60))
    dom.add_field("cell__alive", rng.random((40, 60)) > 0.05, at="cell")
    dom.add_field("exposure__birth", rng.random((40, 60)), at="cell")
    rule = LifeLike.from_params(params)
    st = State(seed=3)
    st.add_domain("cells", dom)
    st.rule_name = rule.name
    rule.setup(st)
    assert (rule._run is not None) == (accelerate == "1")
    out = []
    for k in range(steps):
        st.iteration = k
        changed = rule.step(st)
        out.append((changed, np.array(dom["ca__alive"]), np.array(dom["ca__age"])))
    if accelerate == "1":
        out.append(rule._run.active)
        if threads is not None:
            import numba
            numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    return out


@pytest.mark.parametrize("params", [
    {"rule": "B3/S23", "age_mode": "cumulative", "initial_age": 3},
    {"rule": "25/357", "semantics": "table", "age_mode": "consecutive", "birth_field": "exposure__birth"},
    {"rule": "B2/S", "age_mode": "since_first", "density": 0.05},
    {"rule": "B1/S012", "age_mode": "consecutive", "neighbourhood": "von_neumann", "density": 0.1}])
def test_compiled_life_rule_equals_numpy_rule(params, monkeypatch):
    """The fused compiled step (state, presence, birth draws, ever-alive, age, changed flag)."""
    ref = _life_rule_run("0", monkeypatch, params)
    fast = _life_rule_run("1", monkeypatch, params)[:-1]
    for k, ((c1, a1, g1), (c2, a2, g2)) in enumerate(zip(ref, fast)):
        assert c1 == c2, k
        np.testing.assert_array_equal(a2, a1, err_msg=f"state at step {k}")
        np.testing.assert_array_equal(g2, g1, err_msg=f"age at step {k}")
    assert any(c for c, _, _ in ref) and ref[-1][2].max() > 3


LIFE_MODES = [
    {"rule": "B3/S23", "age_mode": "cumulative", "initial_age": 3, "density": 0.3},
    {"rule": "25/357", "semantics": "table", "age_mode": "consecutive", "birth_field": "exposure__birth"},
    {"rule": "B36/S23", "age_mode": "since_first", "birth_field": "exposure__birth", "density": 0.2},
    {"rule": "B1/S012", "age_mode": "consecutive", "neighbourhood": "von_neumann", "density": 0.1}]


@pytest.mark.parametrize("params", LIFE_MODES)
@pytest.mark.parametrize("share", [1.0, 0.02])
def test_activity_tracking_equals_dense_numpy_every_step(params, share, monkeypatch):
    """The activity-tracking step (from the first step on, or switched on by the default
    share) gives the numpy path's state, age and changed flag on every one of 120 steps,
    birth draws included."""
    ref = _life_rule_run("0", monkeypatch, params, steps=120)
    fast = _life_rule_run("1", monkeypatch, params, steps=120, active_share=share)
    assert fast.pop() is True                        # the run ended on the tracking step
    for k, ((c1, a1, g1), (c2, a2, g2)) in enumerate(zip(ref, fast)):
        assert c1 == c2, k
        np.testing.assert_array_equal(a2, a1, err_msg=f"state at step {k}")
        np.testing.assert_array_equal(g2, g1, err_msg=f"age at step {k}")
    assert sum(c for c, _, _ in ref[1:]) >= 5          # tracked steps that changed cells


@pytest.mark.parametrize("params", LIFE_MODES[:2])
def test_compiled_life_rule_same_on_one_and_two_threads(params, monkeypatch):
    """The dense parallel step gives the same cells on one thread and on two."""
    one = _life_rule_run("1", monkeypatch, params, active_share=0.0, threads=1)
    two = _life_rule_run("1", monkeypatch, params, active_share=0.0, threads=2)
    assert one.pop() is False and two.pop() is False
    for (c1, a1, g1), (c2, a2, g2) in zip(one, two):
        assert c1 == c2
        np.testing.assert_array_equal(a2, a1)
        np.testing.assert_array_equal(g2, g1)
