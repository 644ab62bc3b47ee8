"""The attack/defence corrosion kernel and rule (thesis 2.4.1, 4.2; digest 16.3) and the layer stack
(16.5), on a raster grid and on mesh surface cells."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from procgen import RecipeError

from procgen.ca.graph import grid_graph
from procgen.noise import value_noise_3d
from procgen_layers import corrosion as cz
from procgen_layers.rules import Corrode
from procgen_layers.stack import noisy_layer, stacked_heights
from procgen_surface.domain import SurfaceCells


def step(g, st, prm: Corrode, rng, **kw):
    g3 = cz.gaussian_matrix(prm.sigma) if prm.gaussian is None else np.asarray(prm.gaussian, float)
    return cz.corrosion_step(g, st, prm, rng, weights=cz.direction_weights(g3), **kw)


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
    prm = Corrode(k1=0.02, k2=0.05, k3=0.3, seed_rate=2e-3, max_seeds=25, b0=1.2)
    ever_hole = np.zeros(n, bool)
    for it in range(160):
        before = {k: np.array(getattr(st, k), copy=True) for k in ("status", "consumable", "product")}
        seeds_before = st.seeds_used
        had_corroded_nbr = g.count(before["status"] == cz.CORRODED) > 0
        step(g, st, prm, np.random.default_rng(it))
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
    prm = Corrode(seed_rate=0.0, b0=1.6)
    for it in range(3000):
        step(g, st, prm, np.random.default_rng(seed * 10000 + it))
        if np.mean(st.status != cz.NORMAL) >= 0.5:
            return it
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
    w = cz.direction_weights([[0, 5, 0], [1, 0, 2], [0, 0, 0]])   # slots (di, dj): (-1,-1) (0,-1) ...
    np.testing.assert_array_equal(w, [0, 5, 0, 1, 2, 0, 0, 0])
    with pytest.raises(RecipeError, match="max_attacks"):
        Corrode.from_params({"max_attacks": 8})
    with pytest.raises(RecipeError, match="gaussian"):
        Corrode.from_params({"gaussian": [[0, 0, 0], [0, 1, 0], [0, 0, 0]]})


def test_attacks_follow_the_direction_weights():
    """A matrix that only allows 'up' (dj = -1) attacks grows a column, never sideways."""
    g = grid_graph(41, 41)
    rng = np.random.default_rng(0)
    st = fresh_state(g.n_cells, rng, strong=0.0)
    st.status[20 * 41 + 20] = cz.CORRODED
    prm = Corrode(seed_rate=0, a0=5.0, gaussian=[[0, 1, 0], [0, 0, 0], [0, 0, 0]])
    for it in range(10):
        step(g, st, prm, np.random.default_rng(it))
    ys, xs = np.divmod(np.nonzero(st.status != cz.NORMAL)[0], 41)
    assert set(xs.tolist()) == {20} and ys.min() == 10 and ys.max() == 20


def test_layers_are_non_negative_stacked_and_seamless():
    m = trimesh.creation.icosphere(subdivisions=2)
    sc = SurfaceCells.from_mesh(np.asarray(m.vertices), np.asarray(m.faces), cell_size=0.03)
    rng = np.random.default_rng(4)
    t = np.column_stack([noisy_layer(sc.center3d, sc.graph, rng, nominal=nom, noise=nz, smoothing=sm, scale=0.5)
                         for nom, nz, sm in ((1.0, 0.2, 2), (0.2, 3.0, 0), (0.5, 0.5, 5))])
    assert np.all(t >= 0) and t.shape == (sc.n_cells, 3)
    assert np.all(np.diff(stacked_heights(t), axis=1) >= 0)
    assert (t[:, 1] == 0).any()                         # strong noise clips a thin layer to 0
    # noise is a function of position: cross-edge neighbours differ as little as in-grid ones
    nz = value_noise_3d(sc.center3d, np.random.default_rng(1), scale=0.3)
    rows = sc.graph.rows
    d = np.abs(nz[rows] - nz[sc.indices]) / np.linalg.norm(sc.center3d[rows] - sc.center3d[sc.indices], axis=1)
    assert d[sc.cross].mean() < 1.3 * d[~sc.cross].mean()
    assert 0.5 < nz.std() < 2.0


# -- the rule, on a 2.5-D grid and on mesh cells ----------------------------------------------

def _grid_recipe(corrode: dict, layers=None, iterations=40):
    layers = layers or [{"preset": "copper", "thickness": 0.1}, {"preset": "patina", "thickness": 0.0}]
    return [{"rule": "water.surface", "params": {"nx": 60, "ny": 70, "base": "fbm", "base_amplitude": 1.0,
                                                 "layers": layers}},
            {"rule": "water.weak_map", "params": {"weak_fraction": 0.6, "radius": 4.0}},
            {"rule": "layers.corrode", "iterations": iterations,
             "params": {"cells": "terrain", "seed_rate": 0.001, "max_seeds": 8, "k1": 0.004, "k2": 0.01,
                        "k3": 0.05, "b0": 0.8, "seeding": "fixed", "initial_seeds": 0, "downhill": 2.0,
                        "strong_from": "mask", "strong_field": "corrosion__weak", "strong_high": False,
                        **corrode}}]


def _run(host, steps, seed=3, on_step=None, out_dir=None):
    from procgen.recipes import check_recipe
    from procgen.runner import run

    return run(check_recipe({"steps": steps}, host), host, seed=seed, progress=False, on_step=on_step,
               out_dir=out_dir).state


def test_rule_on_a_grid_keeps_the_invariants_and_the_solid_ledger(host, tmp_path):
    """Step by step: the state and the source ledger as the runner's observer reads them (the
    rule keeps them current), the thickness from a frame of every step (published for it)."""
    seen = []

    def watch(state, rec):
        if rec.rule == "layers.corrode":
            g = state.get("terrain")
            seen.append({k: np.array(g[k]) for k in ("corrosion__state", "layers__source")})

    steps = _grid_recipe({})
    steps[-1]["frames"] = {"every": 1, "domain": "terrain", "format": "npy",
                           "options": {"field": "layers__thickness"}}
    st = _run(host, steps, on_step=watch, out_dir=tmp_path)
    frames = sorted((tmp_path / "frames" / "step2").glob("frame_*.npy"))
    assert len(frames) == len(seen) == 40
    for s, f in zip(seen, frames):
        s["layers__thickness"] = np.flipud(np.load(f))              # frames are north-up
    g = st.get("terrain")
    for k in ("corrosion__state", "layers__thickness", "layers__source"):   # finish publishes the last
        assert np.array_equal(g[k], seen[-1][k])
    weak = g["corrosion__weak"] > 0.5
    assert np.array_equal(g["corrosion__strong"], ~weak)                  # the weak map is the mask
    assert np.all(weak[g["corrosion__seeded"]])                           # seeds on weak cells only
    t0 = np.stack([np.full((70, 60), 0.1), np.zeros((70, 60))], axis=-1)
    for a, b in zip([None] + seen[:-1], seen):
        prev_state = a["corrosion__state"] if a else np.zeros((70, 60))
        prev_t = a["layers__thickness"] if a else t0
        assert np.all(b["corrosion__state"] >= prev_state)                # absorbing
        assert np.all(b["layers__thickness"][..., 0] <= prev_t[..., 0] + 1e-15)
        assert np.all(b["layers__thickness"][..., 1] <= 0.05 + 1e-12)
        assert np.array_equal(b["corrosion__state"] == 2, b["layers__thickness"][..., 0] <= 0)
        # every change of the solid is booked in the source ledger (cell area 1)
        np.testing.assert_allclose(b["layers__thickness"].sum(-1) - t0.sum(-1), b["layers__source"], atol=1e-12)
    final = seen[-1]["corrosion__state"]
    assert 0.05 < np.mean(final >= 1) < 0.95 and (final == 2).any()


def test_covering_paint_protects_the_metal(host):
    layers = [{"preset": "copper", "thickness": 0.1}, {"preset": "patina", "thickness": 0.0},
              {"preset": "paint", "thickness": 0.2, "rect": [0.0, 0.0, 0.5, 1.0], "edge": 0.0}]
    g = _run(host, _grid_recipe({}, layers)).get("terrain")
    covered = g["layers__thickness"][..., 2] > 0
    assert covered[:, :25].all() and not covered[:, 35:].any()
    assert not (g["corrosion__state"][covered] > 0).any() and (g["corrosion__state"][~covered] > 0).any()


def test_strong_cells_slow_the_rule_and_a_second_step_resumes(host):
    fast = _run(host, _grid_recipe({"strong_bonus": 0.0}, iterations=30)).get("terrain")["corrosion__state"]
    slow = _run(host, _grid_recipe({"strong_bonus": 1.0}, iterations=30)).get("terrain")["corrosion__state"]
    assert np.mean(slow > 0) < np.mean(fast > 0)
    steps = _grid_recipe({}, iterations=15)
    one = _run(host, steps).get("terrain")
    two = _run(host, steps + [dict(steps[-1], iterations=15)]).get("terrain")
    assert np.all(two["corrosion__state"] >= one["corrosion__state"])
    assert np.sum(two["corrosion__state"] > 0) > np.sum(one["corrosion__state"] > 0)
    assert two["corrosion__seeded"].sum() <= 8                             # max_seeds counts both steps
    t = two["corrosion__time"]
    assert t.max() >= 15 and np.all((t >= 0) == (two["corrosion__state"] > 0))


def test_one_rule_on_mesh_cells_consumes_several_layers_top_first(host):
    steps = [{"rule": "mesh.primitive", "params": {"shape": "icosphere", "subdivisions": 2}},
             {"rule": "surface.cells", "params": {"target_cells": 3000}},
             {"rule": "layers.stack", "params": {"layers": [
                 {"name": "wood", "color": [0.6, 0.4, 0.3], "thickness": 0.05},
                 {"preset": "paint", "thickness": 0.03}, {"name": "char", "color": [0.1, 0.1, 0.1]}]}},
             {"rule": "layers.corrode", "iterations": 40, "params": {
                 "consume": ["wood", "paint"], "product": "char", "k1": 0.01, "k2": 0.01, "k3": 0.5,
                 "seed_rate": 0.0, "initial_seeds": 3, "max_seeds": 3, "a0": 1.5, "strong_fraction": 0.15}}]
    sc = _run(host, steps).get("cells")
    t, state = sc["layers__thickness"], sc["corrosion__state"]
    assert (state == 2).any() and np.array_equal(state == 2, t[:, :2].sum(1) <= 0)
    # paint (the top consumed layer) goes before the wood under it
    assert np.all((t[:, 0] < 0.05 - 1e-12) <= (t[:, 1] == 0))
    assert np.array_equal(sc["cell__alive"], state != 2)
    np.testing.assert_allclose(sc["layers__source"], (t.sum(1) - 0.08) * sc.area, atol=1e-12)


def test_check_refuses_a_domain_without_cells_and_an_unknown_material(host):
    from procgen import RecipeError
    from procgen.recipes import check_recipe

    pts = [{"rule": "points.poisson_disk", "params": {"radius": 0.1, "domain": "pts"}}]
    with pytest.raises(RecipeError, match=r"steps\[1\] \(layers.stack\): needs domain 'pts' to be a cell domain .*made it a PointSet"):
        check_recipe({"steps": pts + [{"rule": "layers.stack", "params": {"cells": "pts"}}]}, host)
    grid = [{"rule": "grid.noise", "params": {"grid": "cells", "nx": 8, "ny": 8}}]
    with pytest.raises(RecipeError, match="unknown material preset 'coper'.*did you mean 'copper'"):
        check_recipe({"steps": grid + [{"rule": "layers.stack", "params": {"layers": ["coper"]}}]}, host)
