"""The compiled corrosion step (procgen_layers.corrosion_kernels) against the numpy one, exactly."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from procgen.ca.graph import grid_graph
from procgen_layers import corrosion as cz
from procgen_layers.rules import Corrode

from test_layers_corrode import fresh_state

FIELDS = ("status", "consumable", "product", "age", "strong", "seeds_used", "attacks", "valid_neighbours",
          "ledger")
STATS = ("changed", "new_seeds", "newly_corroded", "new_holes", "attacks", "max_attacks_per_cell",
         "max_allowed_violation")


@pytest.mark.parametrize("variant", ["plain", "tilt-blocked", "floor-seeding", "fractional-age-step"])
def test_compiled_corrosion_equals_numpy_corrosion(variant):
    g = grid_graph(45, 60) if variant != "plain" else grid_graph(90, 100)   # 2 chunks of cells
    n = g.n_cells
    rng = np.random.default_rng(3)
    st = fresh_state(n, rng, metal=0.5, layers=1 if variant == "floor-seeding" else 2)
    prm = Corrode(k1=0.03, k2=0.05, k3=0.3, seed_rate=1e-3, max_seeds=30, b0=1.0, noise=0.8,
                  seeding="floor" if variant == "floor-seeding" else "binomial",
                  age_step=2.5 if variant == "fractional-age-step" else 12.0)   # f1 = 1 + age // 2.5
    w = cz.direction_weights(cz.gaussian_matrix(prm.sigma))
    if variant != "plain":                              # the solid ledger, booked where cells thin
        st.ledger, st.area = np.zeros(n), np.random.default_rng(5).uniform(0.5, 1.5, n)
    kw = {}
    if variant == "tilt-blocked":
        kw = {"edge_logw": rng.normal(0.0, 0.7, g.indices.size), "blocked": rng.random(n) < 0.1}
    a, b = st, copy.deepcopy(st)
    seen = 0
    for it in range(120):
        oa = cz.corrosion_step(g, a, prm, np.random.default_rng(it), weights=w, accelerate=False, **kw)
        ob = cz.corrosion_step(g, b, prm, np.random.default_rng(it), weights=w, accelerate=True, **kw)
        for f in FIELDS:
            np.testing.assert_array_equal(getattr(b, f), getattr(a, f), err_msg=f"{f} at step {it}")
        for f in STATS:
            assert getattr(ob, f) == getattr(oa, f), (f, it)
        np.testing.assert_array_equal(np.sort(ob.seed_cells), np.sort(oa.seed_cells))
        np.testing.assert_array_equal(ob.seed_cells, oa.seed_cells)
        np.testing.assert_array_equal(np.sort(ob.newly_cells), oa.newly_cells)   # numpy: cell order
        assert len(oa.newly_cells) == oa.newly_corroded
        seen += oa.attacks
    assert seen > 1000 and np.sum(a.status == cz.HOLE) > 0 and a.seeds_used > 0
    assert a.ledger is None or (a.ledger != 0).sum() > 100


def test_compiled_corrosion_same_on_one_and_two_threads():
    """The parallel passes (front lists, target choice, attacks) give the same run on one
    thread and on two (every list in the numpy path's order; 2 chunks of cells)."""
    import numba
    g = grid_graph(90, 100)
    prm = Corrode(k1=0.03, k2=0.05, k3=0.3, seed_rate=1e-3, max_seeds=30, b0=1.0, noise=0.8)
    w = cz.direction_weights(cz.gaussian_matrix(prm.sigma))
    runs = []
    try:
        for threads in (1, 2):
            numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
            st = fresh_state(g.n_cells, np.random.default_rng(3), metal=0.5, layers=2)
            for it in range(120):
                cz.corrosion_step(g, st, prm, np.random.default_rng(it), weights=w, accelerate=True)
            runs.append(st)
    finally:
        numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    for f in FIELDS:
        np.testing.assert_array_equal(getattr(runs[1], f), getattr(runs[0], f), err_msg=f)
    assert np.sum(runs[0].status == cz.HOLE) > 0
