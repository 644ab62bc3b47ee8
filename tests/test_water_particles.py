"""Water particles on the 2.5D surface: the digest's section 16.4 properties, step by step."""
from __future__ import annotations

import copy

import numpy as np
import pytest

from procgen_layers.materials import parse_materials
from procgen_water import particles as P
from procgen_water.layers import base_surface
from procgen_water.reference import step_loop
from procgen_water.rules import WaterDrops


def _thesis_case(seed=3, n=400, crowd=60, evaporation=0.01, threshold=0.3):
    """Absorbent non-erodible stone under an erodible absorbent patina patch on a slope."""
    tab = parse_materials(["stone", {"preset": "red_patina", "erosion_rate": 0.05,
                                     "weakness_threshold": threshold}])
    ny, nx = 24, 20
    rng = np.random.default_rng(seed)
    base = base_surface("fbm", (ny, nx), 1.0, rng, amplitude=3.0, tilt_deg=20)
    t = np.zeros((ny, nx, 2))
    t[..., 0] = 0.5
    t[4:16, 4:16, 1] = 0.3
    s = P.make_surface(base, t, tab)
    p = WaterDrops(evaporation=evaporation, adhesion=0.2)
    d = P.emit(s, p, rng, n, "uniform")
    d.pos[:crowd] = d.pos[0]                 # many drops in one cell: the sharing must conserve
    d.pos[crowd:2 * crowd] = np.array([10.5, 10.5])   # and a crowd on the patina patch
    return s, d, p, tab


def _capacity_case(seed=5, footprint="bilinear", fade=False):
    """Classic terrain use: non-absorbent rock, sediment capacity, thick enough not to hole."""
    tab = parse_materials(["rock"])
    ny, nx = 24, 20
    rng = np.random.default_rng(seed)
    base = base_surface("fbm", (ny, nx), 1.0, rng, amplitude=4.0, tilt_deg=15)
    s = P.make_surface(base, np.full((ny, nx, 1), 5.0), tab)
    p = WaterDrops(sediment_capacity=2.0, footprint=footprint, max_age=15, evaporation=0.0,
                      capacity_fade=fade)
    d = P.emit(s, p, rng, 300, "uniform")
    d.pos[:40] = d.pos[0]
    return s, d, p, tab


@pytest.mark.parametrize("case", ["thesis", "capacity"])
def test_ledgers_and_bounds_hold_at_every_step(case):
    s, d, p, tab = _thesis_case() if case == "thesis" else _capacity_case()
    baseline = float(s.thickness.sum() * s.cell_area)
    emitted = float(s.emitted.sum())
    assert emitted == pytest.approx(len(d) * p.drop_volume)
    cap_per = tab.array("capacity")
    for it in range(40):
        if it == 10:
            d = d.concat(P.emit(s, p, np.random.default_rng(it), 100, "top", 0.2))
        d = P.step(s, d, p)
        w = P.water_ledger(s, d)
        sl = P.sediment_ledger(s, d, baseline)
        assert w["error"] <= 1e-12 * w["emitted"], (it, w)
        assert sl["error"] <= 1e-12 * baseline, (it, sl)
        cap = cap_per[None, :] * s.thickness * s.cell_area
        assert np.all(s.held >= 0) and np.all(s.held <= cap * (1 + 1e-12) + 1e-15)
        assert np.all(s.thickness >= 0)
        assert np.all(d.volume > 0)                      # empty drops are removed
        assert np.all(d.sediment >= 0)
        assert np.all(d.sediment <= p.max_concentration * d.volume * (1 + 1e-9) + 1e-15)
        assert np.all((d.kind == -1) <= (d.sediment == 0))   # sediment always has a type
    # something actually happened: erosion, deposition, drainage
    assert s.deposit.sum() > 0 and s.drained_sediment.sum() > 0


def test_non_erodible_layer_never_loses_thickness_and_erosion_needs_saturation():
    s, d, p, tab = _thesis_case(evaporation=0.0, threshold=0.6)
    theta = tab["red_patina"].weakness_threshold
    cap_per = tab.array("capacity")
    stone0 = s.thickness[:, 0].copy()
    eroded_any = False
    for _ in range(40):
        before = s.thickness.copy()
        d = P.step(s, d, p)
        assert np.all(s.thickness[:, 0] >= stone0 - 1e-15)      # stone is absorbent, not erodible
        lost = (s.thickness[:, 1] < before[:, 1] - 1e-15) & (s.thickness[:, 1] > 0)
        if np.any(lost):
            eroded_any = True
            cap = cap_per[1] * s.thickness[lost, 1] * s.cell_area
            sat = s.held[lost, 1] / cap
            assert np.all(sat >= theta - 1e-9)          # only saturated (weak) cells eroded
    assert eroded_any


def test_dry_grid_without_drops_is_unchanged_and_drops_never_evaporate():
    s, _, p, _ = _thesis_case()
    snap = copy.deepcopy(s)
    d = P.Drops.empty()
    for _ in range(5):
        d = P.step(s, d, p)
    for k in ("thickness", "held", "deposit", "evaporated", "drained", "path", "base"):
        assert np.array_equal(getattr(s, k), getattr(snap, k)), k
    # non-absorbent surface: drops lose no water to the air, only to the edges
    tab = parse_materials(["rock"])
    s = P.make_surface(np.zeros((10, 10)), np.ones((10, 10, 1)), tab)
    p = WaterDrops(evaporation=0.5)
    d = P.emit(s, p, np.random.default_rng(0), 50, "uniform")
    for _ in range(5):
        d = P.step(s, d, p)
    assert s.evaporated.sum() == 0 and d.volume.sum() == pytest.approx(50.0)


def test_evaporation_only_where_held_and_proportional_to_true_area():
    tab = parse_materials(["stone"])
    ny, nx = 8, 10
    base = np.tile(np.arange(nx, dtype=float), (ny, 1))          # a 45-degree plane z = x
    s = P.make_surface(base, np.ones((ny, nx, 1)), tab)
    held = s.held.reshape(ny, nx)                               # a view of the (ncell, 1) array
    held[:] = 0.3
    held[::2] = 0.0                                             # every other row dry
    p = WaterDrops(evaporation=0.01)
    P.step(s, P.Drops.empty(), p)
    ev = s.evaporated.reshape(ny, nx)
    assert np.all(ev[::2] == 0)
    inner = ev[1::2, 1:-1]                                      # central differences: slope 1
    assert np.allclose(inner, 0.01 * np.sqrt(2.0))
    flat = P.make_surface(np.zeros((ny, nx)), np.ones((ny, nx, 1)), tab, held=np.full((ny, nx, 1), 0.3))
    P.step(flat, P.Drops.empty(), p)
    assert np.allclose(flat.evaporated, 0.01)


def test_drops_on_a_45_degree_plane_run_down_the_slope():
    tab = parse_materials([{"preset": "rock", "erosion_rate": 0.0}])
    ny, nx = 60, 40
    base = base_surface("tilt", (ny, nx), 1.0, None, tilt_deg=45.0)     # high at large y
    s = P.make_surface(base, np.ones((ny, nx, 1)), tab)
    p = WaterDrops()
    d = P.emit(s, p, np.random.default_rng(1), 500, "top", 0.2)
    y0, x0 = d.pos[:, 1].mean(), d.pos[:, 0].mean()
    for _ in range(10):
        d = P.step(s, d, p)
    assert len(d) == 500
    assert d.pos[:, 1].mean() < y0 - 3.0                     # moved downhill (towards y = 0)
    assert abs(d.pos[:, 0].mean() - x0) < 0.2                # not sideways
    assert np.all(d.vel[:, 1] <= 0)


@pytest.mark.parametrize("case,footprint,fade", [("thesis", "cell", False), ("capacity", "bilinear", False),
                                                 ("capacity", "disc", True)])
def test_batch_equals_one_drop_at_a_time_reference(case, footprint, fade):
    s1, d1, p, _ = _thesis_case() if case == "thesis" else _capacity_case(footprint=footprint, fade=fade)
    s2, d2 = copy.deepcopy(s1), copy.deepcopy(d1)
    for _ in range(20):
        d1 = P.step(s1, d1, p)
        d2 = step_loop(s2, d2, p)
    assert len(d1) == len(d2)
    for k in ("thickness", "held", "deposit", "evaporated", "drained", "drained_sediment", "path"):
        assert np.allclose(getattr(s1, k), getattr(s2, k), rtol=1e-9, atol=1e-9), k
    assert np.allclose(d1.pos, d2.pos, atol=1e-9) and np.allclose(d1.sediment, d2.sediment, atol=1e-9)
    assert np.array_equal(d1.moving, d2.moving) and np.array_equal(d1.kind, d2.kind)


def test_same_seed_same_arrays():
    outs = []
    for _ in range(2):
        s, d, p, _ = _thesis_case(seed=11)
        for _ in range(15):
            d = P.step(s, d, p)
        outs.append((s.thickness.copy(), s.held.copy(), d.pos.copy()))
    for a, b in zip(*outs):
        assert np.array_equal(a, b)


def test_emission_modes_put_drops_where_asked():
    tab = parse_materials(["rock"])
    s = P.make_surface(np.zeros((30, 40)), np.ones((30, 40, 1)), tab)
    p = WaterDrops()
    rng = np.random.default_rng(0)
    top = P.emit(s, p, rng, 400, "top", 0.2)
    assert np.all(top.pos[:, 1] >= 24) and np.all(top.pos[:, 1] < 30)
    mask = np.zeros((30, 40))
    mask[5:10, 20:25] = 1.0
    w = P.emit(s, p, rng, 400, "weights", weights=mask)
    assert np.all((w.pos[:, 0] >= 20) & (w.pos[:, 0] < 25) & (w.pos[:, 1] >= 5) & (w.pos[:, 1] < 10))
    assert s.emitted.sum() == pytest.approx(800.0)
    em = s.emitted.reshape(30, 40)
    assert em[:24][mask[:24] == 0].sum() == 0 and em[5:10, 20:25].sum() == pytest.approx(400.0)


def test_one_drop_one_step_matches_hand_computation():
    """Absorption, erosion with saturation weakening and the liquid term, by hand."""
    tab = parse_materials([{"preset": "red_patina", "capacity": 0.5, "absorption_rate": 0.3,
                            "erosion_rate": 0.05, "weakness_threshold": 0.2, "roughness": 0.2}])
    s = P.make_surface(np.zeros((5, 5)), np.ones((5, 5, 1)), tab, held=np.full((5, 5, 1), 0.4))
    p = WaterDrops(evaporation=0.0, friction=0.05, gravity=1.0)
    d = P.Drops(np.array([[2.2, 2.5]]), np.array([[0.5, 0.0]]), np.array([1.0]), np.array([0.0]),
                np.array([-1]), np.array([True]), np.array([0]))
    d = P.step(s, d, p)
    v = 0.5 * (1 - 0.05) - 0.2 * 1.0                 # viscous damping, then Coulomb (mu g)
    assert d.pos[0] == pytest.approx([2.2 + v, 2.5]) and d.moving[0]
    absorbed = 1.0 * 0.3 * (1 - 0.4 / 0.5) / (1 + v / 0.5)
    held = 0.4 + absorbed
    vol = 1.0 - absorbed
    eroded = 0.05 * ((held / 0.5 - 0.2) / 0.8) * (vol + held)
    c = 2 * 5 + 2
    assert s.held[c, 0] == pytest.approx(held, rel=1e-12)
    assert d.volume[0] == pytest.approx(vol, rel=1e-12)
    assert s.thickness[c, 0] == pytest.approx(1.0 - eroded, rel=1e-12)
    assert d.sediment[0] == pytest.approx(eroded, rel=1e-12) and d.kind[0] == 0
    others = np.delete(np.arange(25), c)
    assert np.all(s.thickness[others] == 1.0) and np.all(s.held[others] == 0.4)


@pytest.mark.parametrize("accelerate", [False, True])
def test_step_returns_drops_in_cell_order_ties_in_their_previous_order(accelerate):
    """The canonical drop order: by cell, drops sharing a cell in their order before the step
    (volumes label the drops: non-absorbent rock on a flat plane keeps them and the drops)."""
    if accelerate:
        pytest.importorskip("numba")
    tab = parse_materials(["rock"])
    s = P.make_surface(np.zeros((10, 10)), np.ones((10, 10, 1)), tab)
    pos = np.array([[5.5, 5.5], [1.5, 1.5], [9.5, 0.5], [5.2, 5.7], [1.1, 1.9], [5.9, 5.1]])
    n = len(pos)
    d = P.Drops(pos.copy(), np.zeros((n, 2)), np.arange(1.0, n + 1), np.zeros(n), np.full(n, -1),
                np.ones(n, bool), np.zeros(n, np.int64))
    d = P.step(s, d, WaterDrops(evaporation=0.0), accelerate=accelerate)
    assert d.volume.tolist() == [3.0, 2.0, 5.0, 1.0, 4.0, 6.0]    # cells 9, 11, 11, 55, 55, 55
    assert np.array_equal(d.pos, pos[[2, 1, 4, 0, 3, 5]])           # at rest on the flat plane


def test_derived_fields_match_their_definitions_cell_by_cell():
    """update_derived (vectorized, in place where it can) against the definitions, one cell at
    a time: each layer's top is base + the thicknesses up to it, the height the last top, the
    saturation the exposed layer's held water over its capacity (capacity * thickness * cell
    area), clipped to [0, 1], 0 over a hole or a layer that holds nothing."""
    from procgen.domains import Grid
    from procgen_water.state_io import update_derived
    s, d, p, tab = _thesis_case()
    for _ in range(6):
        d = P.step(s, d, p)
    s.thickness[::7, 1] = 0.0                  # bare patina cells, and holes through both layers
    s.thickness[::11, :] = 0.0
    s.held[::5, 0] += 1.0                      # above capacity somewhere (clipped to 1)
    g = Grid(s.shape)
    update_derived(g, s, tab)
    cap = tab.array("capacity")
    tops, height, sat = g["layers__top"].reshape(s.ncell, -1), g["surface__height"].ravel(), \
        g["water__saturation"].ravel()
    assert 0 < (sat == 1).sum() and 0 < (sat == 0).sum() < s.ncell
    for c in range(s.ncell):
        t = s.thickness[c]
        want = [s.base[c] + sum(t[:l + 1]) for l in range(s.n_layers)]
        np.testing.assert_allclose(tops[c], want, rtol=1e-12)
        assert height[c] == tops[c, -1]
        on = [l for l in range(s.n_layers) if t[l] > 0]
        held_cap = cap[on[-1]] * t[on[-1]] * s.cell_area if on else 0.0
        want_sat = min(max(s.held[c, on[-1]] / held_cap, 0.0), 1.0) if held_cap > 0 else 0.0
        assert sat[c] == pytest.approx(want_sat, rel=1e-12, abs=0), c
