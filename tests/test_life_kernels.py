"""The compiled ca.life step's compact neighbour layout (procgen.ca.kernels.Neighbours: int16
deltas plus int32 escape rows) against the numpy reference, exactly, on graphs whose far
neighbours and short rows need the escape."""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")

import numba  # noqa: E402

from procgen import Grid, State  # noqa: E402
from procgen.ca import automaton  # noqa: E402
from procgen.ca.graph import CellGraph, grid_graph  # noqa: E402
from procgen.ca.kernels import LifeRun, Neighbours  # noqa: E402
from procgen.ca.lifelike import LifeLike, life_step, parse_rule  # noqa: E402

NY, NX = 180, 200          # 36,000 cells: the wrapped rows' links span 35,800 ids (> int16)


def _far_graph(n: int = 70_000, k: int = 8) -> CellGraph:
    """Degree k everywhere; a tenth of the rows link far (beyond +-32767), the rest near."""
    rng = np.random.default_rng(6)
    c = np.repeat(np.arange(n), k)
    ids = (c + rng.integers(-300, 301, c.size)) % n
    far = np.repeat(rng.random(n) < 0.1, k) & (rng.random(c.size) < 0.3)
    ids[far] = rng.integers(0, n, int(far.sum()))
    return CellGraph(np.arange(0, n * k + 1, k, dtype=np.int64), ids.astype(np.int64))


def test_compact_layout_is_the_graph():
    """Every plain row's deltas and every escape row's ids give back the graph's rows."""
    g = _far_graph()
    nb = Neighbours(g)
    n, k = g.n_cells, nb.delta.shape[1]
    plain = np.ones(n, bool)
    plain[nb.esc_rows] = False
    rows = g.indices.reshape(n, k)
    np.testing.assert_array_equal(nb.delta[plain] + np.flatnonzero(plain)[:, None], rows[plain])
    np.testing.assert_array_equal(nb.esc_table, rows[nb.esc_rows])
    assert nb.delta.dtype == np.int16 and 0.05 < nb.esc_rows.size / n < 0.2
    starts = np.minimum(np.arange(nb.esc_ptr.size) * nb.BLOCK, n)
    for b in range(nb.esc_ptr.size - 1):         # the block pointers bracket each block's escapes
        inside = nb.esc_rows[nb.esc_ptr[b]:nb.esc_ptr[b + 1]]
        assert np.all((inside >= starts[b]) & (inside < starts[b + 1]))


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("graph", ["far", "wrap", "holes"])
def test_compact_life_step_equals_numpy(graph, threads):
    if graph == "far":
        g = _far_graph()
    elif graph == "wrap":
        g = grid_graph(NY, NX, wrap=True)
    else:                                        # short rows (grid borders, dropped links)
        g = grid_graph(NY, NX)
        g = g.restrict(np.random.default_rng(2).random(g.indices.size) > 0.05)
    nb = Neighbours(g)
    assert nb.delta.shape[1] and nb.esc_rows.size > 0      # the compact layout, with escapes
    lut = parse_rule("B3/S23").lut(int(g.degree.max()))
    a = np.random.default_rng(1).random(g.n_cells) < 0.3
    b, out = a.copy(), np.empty(g.n_cells, bool)
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        for _ in range(12):
            na = life_step(g, a, lut, accelerate=False)
            nb_ = life_step(g, b, lut, out=out, accelerate=True)
            np.testing.assert_array_equal(nb_, na)
            a, b = na, nb_.copy()
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    assert 0.05 < a.mean() < 0.6


def _run(accelerate: str, monkeypatch, params: dict, threads: int = 1, share: float | None = None,
         steps: int = 40) -> tuple[list, dict]:
    """ca.life on a 180 x 200 grid with holes whose graph wraps around (far links): the state,
    age and changed flag after every step, and the final reports."""
    monkeypatch.setenv("PROCGEN_ACCELERATE", accelerate)
    monkeypatch.setattr(automaton, "cell_graph", lambda dom, hood, where="": grid_graph(NY, NX, wrap=True)
                        if hood == "moore" else grid_graph(NY, NX, wrap=True).neighbourhood(hood))
    if share is not None:
        monkeypatch.setattr(LifeRun, "ACTIVE_SHARE", share)
    rng = np.random.default_rng(2)
    dom = Grid((NY, NX))
    dom.add_field("exposure__birth", rng.random((NY, NX)), at="cell")
    dom.add_field("cell__alive", rng.random((NY, NX)) > 0.03, at="cell")   # present cells
    rule = LifeLike.from_params(params)
    st = State(seed=3)
    st.add_domain("cells", dom)
    st.rule_name = rule.name
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        rule.setup(st)
        assert (rule._run is not None) == (accelerate == "1")
        if rule._run is not None:
            assert rule._run.nb.esc_rows.size >= 2 * NX     # the wrapped rows are escapes
        out = []
        for k in range(steps):
            st.iteration = k
            out.append((rule.step(st), np.array(dom["ca__alive"]), np.array(dom["ca__age"])))
        rule.finish(st)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    return out, dict(st.reports)


MODES = [
    {"rule": "B3/S23", "age_mode": "cumulative", "initial_age": 3, "density": 0.3},
    {"rule": "25/357", "semantics": "table", "age_mode": "consecutive", "birth_field": "exposure__birth"},
    {"rule": "B36/S23", "age_mode": "since_first", "birth_field": "exposure__birth", "density": 0.2},
    {"rule": "B2/S", "age_mode": "cumulative", "birth_field": "exposure__birth", "density": 0.05},
    {"rule": "B1/S012", "age_mode": "consecutive", "neighbourhood": "von_neumann", "density": 0.1}]


@pytest.mark.parametrize("params", MODES)
def test_compact_life_rule_equals_numpy_on_far_links(params, monkeypatch):
    """Every mode (ages, birth draws, presence) on 1 and 2 threads, dense and tracked steps:
    the numpy path's state, age, changed flag and ever-alive report (derived from the age in
    cumulative mode), step by step."""
    ref, ref_rep = _run("0", monkeypatch, params)
    assert any(c for c, _, _ in ref[1:]) and ref[-1][2].max() > 3
    for threads, share in ((1, 0.0), (2, 0.0), (2, None)):
        fast, rep = _run("1", monkeypatch, params, threads, share)
        for k, ((c1, a1, g1), (c2, a2, g2)) in enumerate(zip(ref, fast)):
            assert c1 == c2, (threads, k)
            np.testing.assert_array_equal(a2, a1, err_msg=f"state, step {k}, {threads} threads")
            np.testing.assert_array_equal(g2, g1, err_msg=f"age, step {k}, {threads} threads")
        assert rep == ref_rep
