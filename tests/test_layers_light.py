"""Light through layers and Phong: the digest section 16.5 properties."""
import numpy as np
import pytest
from hypothesis import given, settings, strategies as st

from procgen.errors import InputError
from procgen.lighting import heightfield_normals, light_direction, phong
from procgen_layers.light import layer_weights, opacity_factor, through_layers, through_layers_loop


def _direct_sum(lc, t, o):
    """The n-layer formula written literally (no expm1), as an independent reference."""
    f = o / (1 - o)
    s = np.concatenate([[0.0], np.cumsum(t * f)])
    w = (np.exp(-s[:-1]) - np.exp(-s[1:])) / (1 - np.exp(-s[-1]))
    return w @ lc


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 6), seed=st.integers(0, 10_000))
def test_loop_equals_direct_sum_and_vectorised(n, seed):
    rng = np.random.default_rng(seed)
    lc = rng.random((n, 3))
    t = rng.uniform(0.05, 3.0, n)
    o = rng.uniform(0.05, 0.95, n)
    ref = _direct_sum(lc, t, o)
    assert np.allclose(through_layers_loop(lc, t, o), ref, atol=1e-10)
    assert np.allclose(through_layers(lc, t, o), ref, atol=1e-12)


def test_result_is_convex_combination():
    rng = np.random.default_rng(3)
    lc = rng.random((500, 4, 3))
    t = rng.uniform(0, 2, (500, 4))
    o = rng.uniform(0, 0.99, (500, 4))
    w = layer_weights(t, o)
    assert np.all(w >= 0)
    assert np.allclose(w.sum(-1), 1.0)
    c = through_layers(lc, t, o)
    assert np.all(c >= lc.min(axis=1) - 1e-12) and np.all(c <= lc.max(axis=1) + 1e-12)


def test_single_layer_returns_its_colour():
    lc = np.array([[0.2, 0.7, 0.4]])
    for t, o in [(0.01, 0.1), (1.0, 0.5), (10.0, 0.99)]:
        assert np.allclose(through_layers(lc, [t], [o]), lc[0])


def test_opaque_top_wins_and_transparent_limit_is_thickness_mean():
    lc = np.array([[1.0, 0, 0], [0, 0, 1.0]])
    c = through_layers(lc, [1.0, 1.0], [0.999, 0.5])
    assert c[0] > 0.99 and c[2] < 0.01
    # all opacities -> 0 with equal opacity: thickness-weighted mean
    t = np.array([1.0, 3.0])
    c = through_layers(lc, t, [1e-7, 1e-7])
    assert np.allclose(c, (t / t.sum()) @ lc, atol=1e-6)


def test_empty_stack_gets_background_and_bad_input_rejected():
    lc = np.zeros((2, 2, 3))
    c = through_layers(lc, np.zeros((2, 2)), [0.5, 0.5], empty=[0.1, 0.2, 0.3])
    assert np.allclose(c, [0.1, 0.2, 0.3])
    with pytest.raises(InputError):
        opacity_factor(1.5)
    with pytest.raises(InputError):
        layer_weights([-1.0], [0.5])


def test_phong_matches_hand_computation_and_normals():
    n = np.array([[0.0, 0.0, 1.0]])
    L = light_direction(0.0, 45.0)
    c = phong(n, [1.0, 0.5, 0.25], light=L, ambient=0.1, diffuse=0.8, specular=0.5, exponent=2)
    ndl = np.sin(np.radians(45))
    r = 2 * ndl * n[0] - L
    expect = (0.1 + 0.8 * ndl + 0.5 * max(r[2], 0) ** 2) * np.array([1.0, 0.5, 0.25])
    assert np.allclose(c[0], expect)
    # a face turned away from the light only gets ambient
    c = phong(-n, [1, 1, 1], light=L, eye=(0, 0, -1), ambient=0.2, diffuse=0.8, specular=1.0)
    assert np.allclose(c, 0.2)
    # normals of a 45-degree plane z = x
    h = np.tile(np.arange(5.0), (4, 1))
    nn = heightfield_normals(h)
    assert np.allclose(nn, [-np.sqrt(0.5), 0, np.sqrt(0.5)])


def test_shade_rule_on_a_flat_grid_is_phong_of_the_layer_and_holes_show_background(host):
    from procgen.recipes import check_recipe
    from procgen.runner import run
    from procgen_layers.materials import PRESETS

    steps = [{"rule": "water.surface", "params": {"nx": 8, "ny": 6, "layers": [{"preset": "patina", "thickness": 1.0}]}},
             {"rule": "layers.shade", "params": {"cells": "terrain", "light_azimuth": 30.0, "light_elevation": 60.0,
                                                 "background": [0.1, 0.2, 0.3]}}]
    g = run(check_recipe({"steps": steps}, host), host, seed=1, progress=False).state.get("terrain")
    m = PRESETS["patina"]
    expect = phong(np.array([0.0, 0.0, 1.0]), m.color, light=light_direction(30, 60), ambient=m.ambient,
                   diffuse=m.diffuse, specular=m.specular, exponent=m.exponent)
    np.testing.assert_allclose(g["surface__color"], np.broadcast_to(np.clip(expect, 0, 1), (6, 8, 3)), atol=1e-12)
    alive = np.ones((6, 8), bool)
    alive[2, 3] = False
    g.add_field("cell__alive", alive, at="cell")
    from procgen_layers.rules import Shade
    from procgen.state import State

    st = State(seed=1)
    st.add_domain("terrain", g)
    Shade(cells="terrain", background=[0.1, 0.2, 0.3]).step(st)
    assert np.allclose(g["surface__color"][2, 3], [0.1, 0.2, 0.3])
    assert np.allclose(g["surface__color"][0, 0], np.clip(phong(np.array([0.0, 0.0, 1.0]), m.color,
                       light=light_direction(135, 50), ambient=m.ambient, diffuse=m.diffuse,
                       specular=m.specular, exponent=m.exponent), 0, 1))
