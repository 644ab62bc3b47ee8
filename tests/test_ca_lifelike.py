"""ca.life: rule notations and codes, both semantics, agreement with a plain numpy Life."""
from __future__ import annotations

import numpy as np
import pytest
from scipy.signal import convolve2d

from procgen import Grid, InputError, State
from procgen.ca.graph import grid_graph
from procgen.ca.lifelike import LifeLike, life_step, next_age, parse_rule
from test_ca_domains import run


# -- notation ------------------------------------------------------------------------------

@pytest.mark.parametrize("text, semantics, code", [
    ("B3/S23", "literal", 224), ("23/3", "literal", 224), ("S23/B3", "table", 224), ("224", "literal", 224),
    ("25/357", "table", 52448), ("25/2356", "table", 15600),
    ("25/357", "literal", 19552), ("25/2356", "literal", 7280)])
def test_lookup_table_codes_of_the_wood_thesis(text, semantics, code):
    """Codes of the wood thesis (Table 2.1 Life = 224) and of its Tables 3.1-3.2 in both readings."""
    assert parse_rule(text, semantics).code == code


def test_tables_3_1_and_3_2_row_by_row():
    t = parse_rule("25/357", "table").lut()
    ones = {(n, c) for n in range(9) for c in (0, 1) if t[n, c]}
    assert ones == {(2, 1), (3, 0), (3, 1), (5, 0), (5, 1), (7, 0), (7, 1)}
    t = parse_rule("25/2356", "table").lut()
    assert {(n, c) for n in range(9) for c in (0, 1) if t[n, c]} == \
        {(n, c) for n in (2, 3, 5, 6) for c in (0, 1)}
    # a code is its own table: round trip for every B/S pair of Life, maze, coral
    for s in ("B3/S23", "B3/S234", "B3/S45678", "B36/S23"):
        t = parse_rule(s)
        assert parse_rule(str(t.code)) == t and parse_rule(t.bs) == t


@pytest.mark.parametrize("bad", ["B9/S23", "B33/S23", "B3/S23/C4", "life", "X3/Y23", "262144", "3/2/1", ""])
def test_bad_rule_strings_are_one_line_check_errors(bad):
    with pytest.raises(InputError) as exc:
        parse_rule(bad)
    assert "\n" not in str(exc.value)


def test_check_refuses_a_bad_rule_string_before_running(host):
    from procgen.errors import RecipeError
    from procgen.recipes import check_recipe
    recipe = {"steps": [{"rule": "grid.noise", "params": {"nx": 8, "ny": 8, "grid": "cells"}},
                        {"rule": "ca.life", "params": {"rule": "B3/S2x3"}}]}
    with pytest.raises(RecipeError, match=r"steps\[1\] \(ca.life\).*B3/S2x3"):
        check_recipe(recipe, host)


# -- agreement with an independent Life ---------------------------------------------------

def numpy_life_torus(a: np.ndarray) -> np.ndarray:
    n = sum(np.roll(np.roll(a, dy, 0), dx, 1) for dy in (-1, 0, 1) for dx in (-1, 0, 1)) - a
    return (n == 3) | (a & (n == 2))


def test_life_on_a_wrapped_grid_graph_equals_numpy_roll_life_for_200_steps():
    rng = np.random.default_rng(3)
    a = rng.random((40, 56)) < 0.35
    g = grid_graph(40, 56, wrap=True)
    lut = parse_rule("B3/S23").lut()
    x = a.ravel()
    for _ in range(200):
        x = life_step(g, x, lut)
        a = numpy_life_torus(a)
        np.testing.assert_array_equal(x.reshape(a.shape), a)
    assert 0.01 < a.mean() < 0.5          # still alive: the comparison was not of two empty boards


def test_ca_life_rule_on_a_grid_equals_zero_boundary_convolution_life():
    """The registered rule on a Grid (no wrap: outside = dead) against scipy's convolve2d Life."""
    dom = Grid((30, 45))
    rule = LifeLike.from_params({"density": 0.4})
    st = State(seed=5)
    st.add_domain("cells", dom)
    st.rule_name = rule.name
    rule.setup(st)
    ref = np.array(dom["ca__alive"])
    assert ref.shape == (30, 45) and 0.3 < ref.mean() < 0.5
    for k in range(100):
        st.iteration = k
        rule.step(st)
        n = convolve2d(ref.astype(int), np.ones((3, 3), int), mode="same") - ref
        ref = (n == 3) | (ref & (n == 2))
        np.testing.assert_array_equal(dom["ca__alive"], ref)


def test_small_patterns_life_and_the_thesis_rules():
    def board(cells, shape=(12, 12)):
        a = np.zeros(shape, bool)
        for y, x in cells:
            a[y, x] = True
        return a
    g = grid_graph(12, 12)

    def gen(a, rule, semantics="literal", steps=1):
        x, lut = a.ravel(), parse_rule(rule, semantics).lut()
        for _ in range(steps):
            x = life_step(g, x, lut)
        return x.reshape(a.shape)
    block = board([(5, 5), (5, 6), (6, 5), (6, 6)])
    blinker = board([(5, 4), (5, 5), (5, 6)])
    glider = board([(1, 2), (2, 3), (3, 1), (3, 2), (3, 3)])
    np.testing.assert_array_equal(gen(block, "B3/S23"), block)
    assert not np.array_equal(gen(blinker, "B3/S23"), blinker)
    np.testing.assert_array_equal(gen(blinker, "B3/S23", steps=2), blinker)
    np.testing.assert_array_equal(gen(glider, "B3/S23", steps=4), np.roll(glider, (1, 1), (0, 1)))
    # wood thesis 4.2: 25/357 (table) keeps the block, blinks the blinker, kills a lone cell;
    # read literally the block dies at once; 25/2356 turns the block into 12 (table) or 8 cells
    np.testing.assert_array_equal(gen(block, "25/357", "table"), block)
    np.testing.assert_array_equal(gen(blinker, "25/357", "table", steps=2), blinker)
    assert not gen(board([(5, 5)]), "25/357", "table").any()
    assert not gen(block, "25/357", "literal").any()
    assert gen(block, "25/2356", "table").sum() == 12
    assert gen(block, "25/2356", "literal").sum() == 8


def test_25_357_spreads_with_the_table_reading_and_never_with_the_literal_one():
    """Wood thesis 4.2 / digest 12.1: a random 8x8 patch of 25/357 grows under the tables'
    semantics (front ~0.27 cells/step) and never spreads read literally (B357/S25)."""
    n, steps = 90, 120
    g = grid_graph(n, n)
    res = {}
    for semantics in ("table", "literal"):
        grown, radius = [], []
        for seed in range(4):
            rng = np.random.default_rng(seed)
            a = np.zeros((n, n), bool)
            a[41:49, 41:49] = rng.random((8, 8)) < 0.5
            x, ever = a.ravel(), a.ravel().copy()
            lut = parse_rule("25/357", semantics).lut()
            for _ in range(steps):
                x = life_step(g, x, lut)
                ever |= x
            yy, xx = np.divmod(np.nonzero(ever)[0], n)
            radius.append(np.hypot(yy - 44.5, xx - 44.5).max())
            grown.append(ever.sum())
        res[semantics] = (np.mean(grown), np.mean(radius))
    assert res["table"][1] == pytest.approx(4 + 0.27 * steps, abs=12)     # ~0.27 cells/step front
    assert res["literal"][1] <= 8                                       # stays inside its patch
    assert res["table"][0] > 20 * res["literal"][0]


def test_age_modes():
    alive = np.array([[1, 1, 0, 1], [1, 0, 0, 1], [0, 0, 1, 1]], bool)     # 3 steps x 4 cells
    out = {}
    for mode in ("cumulative", "consecutive", "since_first"):
        age, ever = np.zeros(4, np.int32), np.zeros(4, bool)
        for row in alive:
            ever |= row
            age = next_age(age, row, ever, mode)
        out[mode] = age.tolist()
    assert out == {"cumulative": [2, 1, 1, 3], "consecutive": [0, 0, 1, 3],
                   "since_first": [3, 3, 1, 3]}


def test_age_field_and_start_from_a_field():
    dom = Grid((20, 20))
    start = np.zeros((20, 20), bool)
    start[9, 8:11] = True                                       # a blinker
    dom.add_field("ca__alive", start, at="cell")
    rule = LifeLike.from_params({"initial": "field", "age_mode": "cumulative"})
    assert [s.intent for s in rule.field_specs()] == ["inout", "out"]
    run(rule, dom, 4)
    np.testing.assert_array_equal(dom["ca__alive"], start)      # period 2
    age = dom["ca__age"]
    assert age[9, 9] == 4 and age[9, 8] == 2 and age[8, 9] == 2 and age.sum() == 4 + 2 * 4


# -- birth gated by a per-cell probability field --------------------------------------------

def _stepper(p: np.ndarray | None, shape=(100, 100), seed: int = 11):
    """A ca.life (Life, random start) on its own Grid, optionally with a birth probability field."""
    dom = Grid(shape)
    params = {"density": 0.3}
    if p is not None:
        dom.add_field("exposure__birth", p, at="cell")
        params["birth_field"] = "exposure__birth"
    rule = LifeLike.from_params(params)
    st = State(seed=seed)
    st.add_domain("cells", dom)
    st.rule_name = rule.name
    rule.setup(st)

    def step(k: int) -> np.ndarray:
        st.iteration = k
        rule.step(st)
        return np.array(dom["ca__alive"])
    return dom, step


def test_birth_probability_one_is_the_plain_rule_and_zero_allows_no_birth():
    shape = (100, 100)
    plain, step_plain = _stepper(None)
    ones, step_ones = _stepper(np.ones(shape))
    zeros, step_zeros = _stepper(np.zeros(shape))
    start = np.array(plain["ca__alive"])
    np.testing.assert_array_equal(ones["ca__alive"], start)      # the start draws are the same
    prev = start
    for k in range(30):
        a = step_plain(k)
        np.testing.assert_array_equal(step_ones(k), a)
        z = step_zeros(k)
        assert not np.any(z & ~prev)                             # nobody is born ...
        prev = z
    assert a.sum() > 500 and prev.sum() < start.sum()            # ... while the plain rule lives on


def test_births_happen_with_the_fields_probability_and_only_where_it_is_positive():
    shape = (100, 100)
    p = np.full(shape, 0.3)
    p[:, :50] = 0.0                                               # the west half never comes alive
    plain, step_plain = _stepper(None)
    gated, step_gated = _stepper(p)
    before = np.array(plain["ca__alive"])
    a, g = step_plain(0), step_gated(0)
    candidates = a & ~before
    born = g & ~before
    np.testing.assert_array_equal(g & before, a & before)        # survival is untouched
    assert not np.any(born & ~candidates) and not born[:, :50].any()
    n = int(candidates[:, 50:].sum())
    assert n > 500
    assert abs(born.sum() - 0.3 * n) < 4 * np.sqrt(n * 0.3 * 0.7)  # binomial(n, 0.3) within 4 sigma
    for k in range(1, 40):
        g_prev, g = g, step_gated(k)
        assert not np.any((g & ~g_prev)[:, :50])


def test_birth_field_out_of_range_is_one_line():
    with pytest.raises(InputError, match="birth_field 'exposure__birth' must be one value in \\[0, 1\\]"):
        _stepper(np.full((10, 10), 1.5), shape=(10, 10))
