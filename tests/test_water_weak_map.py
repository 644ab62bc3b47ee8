"""Weak/strong maps for corrosion: the digest's section 16.3 properties (the CA: test_layers_corrode)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from procgen_water.weak_map import weak_cells, weakness_score


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
