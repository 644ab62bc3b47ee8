"""The example plugin passes procgen's contract suite and behaves like Gray-Scott."""
from __future__ import annotations

import numpy as np

from procgen import get_plugin_manager
from procgen.recipes import check_recipe
from procgen.runner import run
from procgen.testing import check_rule_contract
from procgen_grayscott.rules import GrayScott, laplacian


def test_registered_through_entry_point():
    host = get_plugin_manager()
    assert host.rules["grayscott.react"] is GrayScott
    assert "grayscott/coral" in __import__("procgen.recipes", fromlist=["x"]).list_recipes(host)


def test_gallery_entry_is_contributed():
    from procgen.gallery import load_gallery

    entries = load_gallery(get_plugin_manager(), ["grayscott/*"])
    assert [e.recipe for e in entries] == ["grayscott/coral"]


def test_contract():
    check_rule_contract(GrayScott)


def test_laplacian_conserves_and_matches_stencil():
    a = np.random.default_rng(0).random((9, 7))
    assert abs(laplacian(a).sum()) < 1e-12
    assert np.isclose(laplacian(a)[4, 3], a[3, 3] + a[5, 3] + a[4, 2] + a[4, 4] - 4 * a[4, 3])


def test_uniform_state_is_a_fixed_point_and_patterns_grow():
    host = get_plugin_manager()
    r = check_recipe({"steps": [{"rule": "grayscott.react", "params": {"size": 64}, "iterations": 3000}]}, host)
    g = run(r, host, seed=2).state.get("chemicals")
    v = g["chemical__v"]
    assert 0 <= v.min() and v.max() < 1 and v.std() > 0.05       # a pattern, not a flat field
    assert np.isfinite(g["chemical__u"]).all()
