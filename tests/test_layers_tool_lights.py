"""The virtual tool (plate D-13(b)), several lights (D-13(a)) and the thesis's plate-2.1 shading."""
from __future__ import annotations

import numpy as np
import pytest

from procgen import check_recipe
from procgen.runner import run
from procgen.testing import check_rule_contract
from procgen_layers.light import shade_stack
from procgen_layers.materials import MaterialTable, preset
from procgen_layers.rules import Tool
from procgen.lighting import light_direction, phong

STACK = {"rule": "layers.stack", "params": {"cells": "g", "layers": [
    {"preset": "copper", "thickness": 1.0}, {"preset": "patina", "thickness": 0.3}]}}


def test_tool_contract():
    check_rule_contract(Tool)


def _run(host, *steps):
    recipe = {"steps": [{"rule": "grid.noise", "params": {"grid": "g", "nx": 40, "ny": 30}}, STACK, *steps]}
    return run(check_recipe(recipe, host), host, seed=2, progress=False).state


def test_tool_cuts_top_first_along_the_path_and_conserves_volume(host):
    before = np.array(_run(host).domains["g"]["layers__thickness"])
    st = _run(host, {"rule": "layers.tool", "params": {"cells": "g", "path": [[5.0, 5.0], [30.0, 5.0], [30.0, 25.0]],
                                                       "radius": 2.0, "depth": 0.5}})
    g = st.domains["g"]
    after = np.array(g["layers__thickness"])
    yy, xx = np.meshgrid(g.y, g.x, indexing="ij")
    d = np.minimum(np.where((xx >= 5) & (xx <= 30), np.abs(yy - 5), np.inf),
                   np.where((yy >= 5) & (yy <= 25), np.abs(xx - 30), np.inf))
    for cx, cy in ((5, 5), (30, 5), (30, 25)):                  # the path's corners and ends
        d = np.minimum(d, np.hypot(xx - cx, yy - cy))
    on, off = d <= 2.0 - 1e-9, d > 2.0 + 1e-9
    np.testing.assert_array_equal(after[off], before[off])
    assert np.all(after[on][:, 1] == 0.0)                      # the thin top layer is gone first
    np.testing.assert_allclose(before[on].sum(-1) - after[on].sum(-1), 0.5)   # then copper, to depth
    removed = float(np.sum(before - after)) * g.spacing ** 2
    assert st.reports["g.tool.removed_volume"] == pytest.approx(removed)


def test_tool_path_in_the_wrong_dimension_is_one_line(host):
    from procgen.errors import ProcgenError
    with pytest.raises(ProcgenError, match="path points need 2 coordinates"):
        _run(host, {"rule": "layers.tool", "params": {"cells": "g", "path": [[0, 0, 0], [1, 1, 1]]}})


def test_extra_lights_add_their_diffuse_and_specular_terms():
    table = MaterialTable((preset("copper"),))
    normals = np.array([[0.0, 0.0, 1.0], [0.6, 0.0, 0.8], [-0.6, 0.0, 0.8]])
    t = np.ones((3, 1))
    l1, l2 = light_direction(0.0, 45.0), light_direction(180.0, 45.0)
    one = shade_stack(normals, t, table, light=l1)
    same = shade_stack(normals, t, table, light=l1, extra_lights=((l2, 0.0),))
    np.testing.assert_allclose(one, same)
    two = shade_stack(normals, t, table, light=l1, extra_lights=((l2, 0.5),))
    m = table[0]
    extra = 0.5 * phong(normals, m.color, light=l2, ambient=0.0, diffuse=m.diffuse, specular=m.specular,
                        exponent=m.exponent)
    np.testing.assert_allclose(two, np.clip(one + extra, 0, 1), atol=1e-12)
    assert two[2].sum() > one[2].sum()             # the cell facing the second light brightens most


def test_without_light_through_layers_the_top_nonempty_layer_shows():
    table = MaterialTable((preset("copper"), preset("patina")))
    t = np.array([[1.0, 0.2], [1.0, 0.0], [0.0, 0.0]])
    n = np.tile([0.0, 0.0, 1.0], (3, 1))
    light = light_direction(135.0, 50.0)
    c = shade_stack(n, t, table, light=light, through=False, background=(0.1, 0.2, 0.3))
    ref = shade_stack(n, np.array([[0.0, 1.0], [1.0, 0.0], [0.0, 0.0]]), table, light=light,
                      background=(0.1, 0.2, 0.3))
    np.testing.assert_allclose(c[1], ref[1])                   # copper alone: same either way
    lit_patina = shade_stack(n[:1], np.array([[0.0, 1.0]]), table, light=light)[0]
    np.testing.assert_allclose(c[0], lit_patina)               # thin patina hides the copper fully
    np.testing.assert_allclose(c[2], [0.1, 0.2, 0.3])
    assert not np.allclose(shade_stack(n, t, table, light=light)[0], c[0])   # through-layers differs
