"""Crack birth: Pot-Crack, Table 5.3 types, the dominant-axis direction (thesis 5.2.4.a)."""
from __future__ import annotations

import numpy as np
import pytest

from procgen.ca.graph import grid_graph
from procgen.ca.subcell import slot_table, wrap_angle
from procgen_cracks import birth as bt


def test_pot_crack_is_sorted_and_unstable():
    rng = np.random.default_rng(2)
    imax = rng.uniform(0, 2, 500)
    eligible = rng.uniform(size=500) < 0.8
    pot = bt.pot_crack(imax, 1.0, eligible)
    assert np.all(np.diff(imax[pot]) <= 0)
    assert np.all(imax[pot] > 1.0) and eligible[pot].all()
    assert len(pot) == int(np.sum(eligible & (imax > 1.0)))


@pytest.mark.parametrize("spec,code,kind", [
    ([1.5, 0.0, 0.0, 0.0], "M000", bt.I),
    ([0.5, 0.0, 1.5, 0.0], "M0S0", bt.I),       # read from the strongest axis on
    ([1.5, 0.0, 1.5, 0.0], "M0M0", bt.X),
    ([1.5, 0.5, 1.5, 0.5], "MSMS", bt.X),
    ([1.5, 1.5, 1.5, 1.5], "MMMM", bt.Y),
    ([1.5, 0.5, 1.5, 0.0], "MSM0", bt.I),
])
def test_table_5_3_codes_and_types(spec, code, kind):
    s = np.array([spec])
    assert bt.codes(s, 1.0, 0.1) == [code]
    types = bt.crack_types(s, 1.0, 0.1, 0.0, {bt.I, bt.T, bt.Y, bt.X}, np.random.default_rng(0))
    assert types[0] == kind


def test_i_or_t_rows_and_allowed_types():
    s = np.array([[1.5, 0.5, 0.5, 0.0]])               # MSS0: "I or T"
    everything = {bt.I, bt.T, bt.Y, bt.X}
    assert bt.crack_types(s, 1.0, 0.1, 1.0, everything, np.random.default_rng(0))[0] == bt.T
    assert bt.crack_types(s, 1.0, 0.1, 0.0, everything, np.random.default_rng(0))[0] == bt.I
    y = np.array([[1.5, 1.5, 1.5, 1.5]])
    assert bt.crack_types(y, 1.0, 0.1, 0.0, {bt.I}, np.random.default_rng(0))[0] == bt.I   # plate 5.10


@pytest.mark.parametrize("spec,direction", [
    ([0.1, 0.0, 0.9, 0.0], 0.0),                 # plate 5.5: vertical stress, horizontal crack
    ([1.2, 0.5, 1.2, 0.0], 3 * np.pi / 4),       # MSM0 (digest examples of the table's column)
    ([1.2, 0.0, 1.2, 0.5], np.pi / 4),           # M0MS
    ([1.2, 1.2, 0.5, 0.5], 5 * np.pi / 8),       # MMSS
])
def test_crack_runs_across_the_dominant_axis(spec, direction):
    got = bt.crack_axis(np.array([spec]), 0.1, 1.0)[0]
    assert abs(wrap_angle(2 * (got - direction))) < 0.3     # axial: compare doubled angles


@pytest.mark.parametrize("kind,gaps", [(bt.I, [np.pi]), (bt.T, [np.pi / 2, np.pi / 2, np.pi]),
                                       (bt.Y, [2 * np.pi / 3] * 3), (bt.X, [np.pi / 2] * 4)])
def test_initial_heads_per_type(kind, gaps):
    who, ang = bt.initial_heads(np.array([kind]), np.array([0.3]))
    assert np.all(who == 0)
    a = np.sort(np.mod(ang, 2 * np.pi))
    spacing = np.sort(np.diff(np.concatenate([a, [a[0] + 2 * np.pi]])))
    if len(gaps) == 1:
        assert len(a) == 2 and spacing[0] == pytest.approx(np.pi)
    else:
        np.testing.assert_allclose(spacing, np.sort(gaps), atol=1e-12)


def test_births_of_one_series_are_spaced():
    g = grid_graph(30, 30, False)
    slots = slot_table(g)
    rng = np.random.default_rng(5)
    imax = rng.uniform(size=900)
    cand = np.argsort(-imax, kind="stable")[:400]
    chosen = bt.spaced(cand, slots, 3)
    assert chosen[0] == cand[0]
    yx = np.column_stack(np.divmod(chosen, 30))
    cheb = np.abs(yx[:, None, :] - yx[None, :, :]).max(axis=2)
    np.fill_diagonal(cheb, 99)
    assert cheb.min() > 3
