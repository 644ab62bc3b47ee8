"""Corrosion / patina state machine (digest 16.3) and layers (16.5)."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from procgen.ca import corrosion as cz
from procgen_surface.domain import SurfaceCells
from procgen_surface.layers import layer_stack, stacked_heights, value_noise_3d
from procgen.ca.graph import grid_graph


def fresh_state(n: int, rng: np.random.Generator, strong: float = 0.3, metal: float = 1.0,
                layers: int = 1) -> cz.CorrosionState:
    return cz.CorrosionState(status=np.zeros(n, np.int8), consumable=np.full((n, layers), metal / layers),
                             product=np.zeros(n), age=np.zeros(n, np.int32),
                             strong=cz.strong_mask(n, strong, rng))


def test_state_machine_invariants_step_by_step():
    g = grid_graph(60, 60)
    n = g.n_cells
    rng = np.random.default_rng(2)
    st = fresh_state(n, rng, metal=0.6, layers=2)
    prm = cz.CorrosionParams(k1=0.02, k2=0.05, k3=0.3, seed_rate=2e-3, max_seeds=25, b0=1.2)
    prm.check()
    ever_hole = np.zeros(n, bool)
    for step in range(160):
        before = {k: np.array(getattr(st, k), copy=True) for k in ("status", "consumable", "product")}
        seeds_before = st.seeds_used
        had_corroded_nbr = g.count(before["status"] == cz.CORRODED) > 0
        cz.corrosion_step(g, st, prm, np.random.default_rng(step))
        s0, s1 = before["status"], st.status
        # corroded is absorbing, holes never come back
        assert np.all(s1[s0 == cz.CORRODED] != cz.NORMAL)
        assert np.all(s1[s0 == cz.HOLE] == cz.HOLE)
        ever_hole |= s1 == cz.HOLE
        assert np.all(s1[ever_hole] == cz.HOLE)
        # metal never grows, never negative; a hole exactly where it is gone
        assert np.all(st.consumable <= before["consumable"] + 1e-15)
        assert np.all(st.consumable >= 0)
        metal = st.consumable.sum(1)
        assert np.array_equal(s1 == cz.HOLE, metal <= 0)
        # the top layer goes first
        assert np.all((st.consumable[:, 0] < before["consumable"][:, 0]) <= (st.consumable[:, 1] == 0))
        # oxide never decreases and stays capped
        assert np.all(st.product >= before["product"] - 1e-15) and np.all(st.product <= prm.k3 + 1e-12)
        # new corrosion only next to corrosion, or as a counted seed
        newly = (s0 == cz.NORMAL) & (s1 == cz.CORRODED)
        orphans = newly & ~had_corroded_nbr
        assert orphans.sum() <= st.seeds_used - seeds_before
        assert st.seeds_used <= prm.max_seeds
        # attacks per corroded cell never exceed min(n_VC, 7)
        assert np.all(st.attacks <= np.minimum(st.valid_neighbours, 7))
        assert np.all(st.attacks[s0 != cz.CORRODED] == 0)
    assert ever_hole.any() and (st.status == cz.CORRODED).any()


def steps_to_half(strong: float, seed: int) -> int:
    g = grid_graph(80, 80)
    rng = np.random.default_rng(seed)
    st = fresh_state(g.n_cells, rng, strong=strong)
    st.status[rng.choice(np.nonzero(~st.strong)[0], 4, replace=False)] = cz.CORRODED
    prm = cz.CorrosionParams(seed_rate=0.0, b0=1.6)
    for step in range(3000):
        cz.corrosion_step(g, st, prm, np.random.default_rng(seed * 10000 + step))
        if np.mean(st.status != cz.NORMAL) >= 0.5:
            return step
    return 3000


def test_more_strong_cells_slow_the_spread():
    weak = np.mean([steps_to_half(0.1, s) for s in range(3)])
    strong = np.mean([steps_to_half(0.6, s) for s in range(3)])
    assert strong > 1.3 * weak


def test_strong_fraction_is_exact_and_noise_picks_the_highest():
    rng = np.random.default_rng(0)
    for frac in (0.0, 0.25, 0.7):
        assert cz.strong_mask(10000, frac, rng).sum() == round(frac * 10000)
    noise = rng.random(1000)
    m = cz.strong_mask(1000, 0.1, rng, noise)
    assert noise[m].min() >= noise[~m].max()


def test_gaussian_direction_weights():
    g = cz.gaussian_matrix(1.0)
    assert g[1, 1] == 0 and g[0, 1] == pytest.approx(np.exp(-0.5)) and g[0, 0] == pytest.approx(np.exp(-1))
    prm = cz.CorrosionParams(gaussian=((0, 5, 0), (1, 0, 2), (0, 0, 0)))
    w = prm.direction_weights()               # slots (di, dj): (-1,-1) (0,-1) (1,-1) (-1,0) (1,0) ...
    np.testing.assert_array_equal(w, [0, 5, 0, 1, 2, 0, 0, 0])
    with pytest.raises(Exception, match="7"):
        cz.CorrosionParams(max_attacks=8).check()


def test_attacks_follow_the_direction_weights():
    """A matrix that only allows 'up' (dj = -1) attacks grows a column, never sideways."""
    g = grid_graph(41, 41)
    rng = np.random.default_rng(0)
    st = fresh_state(g.n_cells, rng, strong=0.0)
    st.status[20 * 41 + 20] = cz.CORRODED
    prm = cz.CorrosionParams(seed_rate=0, a0=5.0, gaussian=((0, 1, 0), (0, 0, 0), (0, 0, 0)))
    for step in range(10):
        cz.corrosion_step(g, st, prm, np.random.default_rng(step))
    ys, xs = np.divmod(np.nonzero(st.status != cz.NORMAL)[0], 41)
    assert set(xs.tolist()) == {20} and ys.min() == 10 and ys.max() == 20


def test_layers_are_non_negative_stacked_and_seamless():
    m = trimesh.creation.icosphere(subdivisions=2)
    sc = SurfaceCells.from_mesh(np.asarray(m.vertices), np.asarray(m.faces), cell_size=0.03)
    rng = np.random.default_rng(4)
    t = layer_stack(sc.center3d, sc.graph, rng, nominal=[1.0, 0.2, 0.5], noise=[0.2, 3.0, 0.5],
                    smoothing=[2, 0, 5], scale=0.5)
    assert np.all(t >= 0) and t.shape == (sc.n_cells, 3)
    assert np.all(np.diff(stacked_heights(t), axis=1) >= 0)
    assert (t[:, 1] == 0).any()                         # strong noise clips a thin layer to 0
    # noise is a function of position: cross-edge neighbours differ as little as in-grid ones
    nz = value_noise_3d(sc.center3d, np.random.default_rng(1), scale=0.3)
    rows = sc.graph.rows
    d = np.abs(nz[rows] - nz[sc.indices]) / np.linalg.norm(sc.center3d[rows] - sc.center3d[sc.indices], axis=1)
    assert d[sc.cross].mean() < 1.3 * d[~sc.cross].mean()
    assert 0.5 < nz.std() < 2.0
