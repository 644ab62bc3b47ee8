"""Corrosion CA and weak/strong map: the digest's section 16.3 properties."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from procgen_water.corrosion import (CorrosionParams, corrosion_step, weak_cells, weakness_score)


@pytest.mark.parametrize("regroup", ["none", "linear", "square", "cubic", "x4"])
@pytest.mark.parametrize("fraction", [0.1, 0.5, 0.83])
def test_weak_fraction_matches_request(regroup, fraction):
    rng = np.random.default_rng(7)
    h = np.random.default_rng(1).random((100, 120))
    score = weakness_score((100, 120), rng, regroup=regroup, radius=5, height=h, altitude_weight=0.3)
    weak = weak_cells(score, fraction)
    assert abs(weak.mean() - fraction) <= 0.02


def test_regrouping_makes_regions_and_trace_pulls_weakness_to_paths():
    rng = np.random.default_rng(0)
    rand = weak_cells(weakness_score((80, 80), rng, regroup="none"), 0.5)
    grouped = weak_cells(weakness_score((80, 80), np.random.default_rng(0), regroup="linear", radius=6), 0.5)
    # regrouping: far fewer, larger connected weak regions than a pure random map
    assert ndimage.label(grouped)[1] * 5 < ndimage.label(rand)[1]
    trace = np.zeros((80, 80))
    trace[:, 38:42] = 100.0                      # a water path down the middle
    w = weak_cells(weakness_score((80, 80), np.random.default_rng(0), regroup="linear", radius=6,
                                  trace=trace, trace_weight=0.7), 0.2)
    assert w[:, 38:42].mean() > 0.9 and w.mean() == pytest.approx(0.2, abs=0.01)


def _run(steps=60, shape=(60, 70), covered_rect=None, **kw):
    rng = np.random.default_rng(2)
    ny, nx = shape
    weak = weak_cells(weakness_score(shape, rng, regroup="linear", radius=4), 0.6)
    metal = np.full(shape, 0.1)
    oxide = np.zeros(shape)
    covered = np.zeros(shape, bool)
    if covered_rect:
        covered[covered_rect] = True
    height = np.random.default_rng(3).random(shape)
    corroded = np.zeros(shape, bool)
    age = np.zeros(shape, np.int64)
    hole = np.zeros(shape, bool)
    p = CorrosionParams(**{"seed_rate": 0.001, "max_seeds": 8, "k1": 0.004, "k2": 0.01, "k3": 0.05,
                           "b0": 0.8, **kw})
    seeds = 0
    hist = []
    for t in range(steps):
        prev = dict(corroded=corroded.copy(), metal=metal.copy(), oxide=oxide.copy(), hole=hole.copy())
        st = corrosion_step(corroded=corroded, age=age, hole=hole, weak=weak, metal=metal, oxide=oxide,
                            covered=covered, height=height, spacing=1.0, p=p,
                            rng=np.random.default_rng(100 + t), seeds_used=seeds)
        seeds += st.new_seeds
        hist.append((prev, st, corroded.copy(), metal.copy(), oxide.copy(), hole.copy(), seeds))
    return hist, p, weak, covered


def test_corrosion_invariants_at_every_step():
    hist, p, weak, covered = _run()
    ncell = weak.size
    k8 = np.ones((3, 3), bool)
    for prev, st, corroded, metal, oxide, hole, seeds in hist:
        assert np.all(corroded >= prev["corroded"])                       # absorbing state
        assert np.all(hole >= prev["hole"])                               # holes never come back
        assert np.all(metal <= prev["metal"]) and np.all(metal >= 0)      # metal never grows
        assert np.all(oxide >= prev["oxide"]) and np.all(oxide <= p.k3 + 1e-12)
        assert np.array_equal(hole, corroded & (metal <= 0))              # hole exactly when eaten
        assert st.new_seeds <= p.seed_rate * ncell and seeds <= p.max_seeds
        assert st.max_allowed_violation == 0 and st.max_attacks_per_cell <= 7
        new = corroded & ~prev["corroded"]
        near = ndimage.binary_dilation(prev["corroded"] & ~prev["hole"], k8)
        seeded = np.zeros(ncell, bool)
        seeded[st.seed_cells] = True
        assert np.all(~new | near | seeded.reshape(new.shape))           # spread or seed only
        assert np.all(weak.ravel()[st.seed_cells])                        # seeds on weak cells
    final = hist[-1][2]
    assert 0.05 < final.mean() < 0.95 and hist[-1][5].any()               # it spreads, and holes form


def test_covered_metal_never_corrodes_and_strong_cells_slow_the_spread():
    rect = (slice(0, 60), slice(0, 35))
    hist, *_ = _run(covered_rect=rect)
    assert not hist[-1][2][rect].any()
    fast = _run(steps=40, strong_bonus=0.0)[0][-1][2].mean()
    slow = _run(steps=40, strong_bonus=1.0)[0][-1][2].mean()
    assert slow < fast
