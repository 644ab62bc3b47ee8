"""Images as fields: on a Grid (a painted weak map drives corrosion) and on a mesh through UVs."""
from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from procgen.builtin.loaders import sample_bilinear
from procgen.errors import RecipeError
from procgen.recipes import check_recipe, load_recipe
from procgen.runner import run


def _run(host, tmp_path, steps):
    recipe = check_recipe({"steps": steps}, host, str(tmp_path / "r.toml"), tmp_path)
    return run(recipe, host, progress=False).state


def test_grid_image_field_maps_black_and_white_and_keeps_north_up(host, tmp_path):
    a = np.zeros((16, 24, 3), np.uint8)
    a[:8, :, 0] = 255                              # top half red, bottom half black
    Image.fromarray(a, "RGB").save(tmp_path / "paint.png")
    st = _run(host, tmp_path, [{"rule": "grid.noise", "params": {"nx": 24, "ny": 16}},
                               {"rule": "grid.image_field", "params": {"file": "paint.png", "field": "rain__mask",
                                                                       "vmin": 1.0, "vmax": 3.0}},
                               {"rule": "grid.image_field", "params": {"file": "paint.png", "field": "paint__rgb",
                                                                       "channels": "rgb"}}])
    g = st.domains["terrain"]
    m = g["rain__mask"]
    assert np.allclose(m[8:], 1.0 + 2.0 * 0.299) and np.allclose(m[:8], 1.0)   # luma of red; north = top
    assert g["paint__rgb"].shape == (16, 24, 3) and np.allclose(g["paint__rgb"][-1], [1.0, 0.0, 0.0])


def test_painted_weak_map_decides_where_corrosion_starts(host):
    recipe = load_recipe("data/painted-corrosion", host,
                         ["steps.0.params.nx=60", "steps.0.params.ny=60", "steps.2.iterations=25",
                          "steps.2.params.seed_rate=0.002"])
    g = run(recipe, host, progress=False).state.domains["terrain"]
    weak = g["corrosion__weak"] > 0.5
    src = np.asarray(Image.open(recipe.base_dir / "weak-map.png"), float) / 255
    assert 0.1 < weak.mean() < 0.5 and abs(weak.mean() - (src > 0.5).mean()) < 0.03   # the painted share
    seeds = g["corrosion__seeded"]
    assert seeds.sum() > 0 and np.all(weak[seeds])           # every seed on a painted cell
    corroded = g["corrosion__state"] >= 1
    assert corroded[weak].mean() > 10 * max(corroded[~weak].mean(), 1e-3)


def test_bilinear_lookup_is_exact_on_a_linear_image():
    rows, cols = 20, 30
    yy, xx = np.mgrid[0:rows, 0:cols]
    img = 0.5 * xx + 2.0 * yy                       # value at pixel centre (col + .5, row + .5)
    uv = np.random.default_rng(0).uniform([1.5 / cols, 1.5 / rows], [1 - 1.5 / cols, 1 - 1.5 / rows], (200, 2))
    col = uv[:, 0] * cols - 0.5
    row = (1 - uv[:, 1]) * rows - 0.5               # v = 1 is the top row
    np.testing.assert_allclose(sample_bilinear(img, uv), 0.5 * col + 2.0 * row, atol=1e-12)


def test_mesh_image_field_through_uvs_or_a_planar_projection(host, tmp_path):
    a = np.tile((4 * np.arange(64)).astype(np.uint8), (32, 1))         # dark (left) to light (right)
    Image.fromarray(a, "L").save(tmp_path / "ramp.png")
    st = _run(host, tmp_path, [{"rule": "mesh.primitive", "params": {"shape": "plane"}},
                               {"rule": "mesh.image_field", "params": {"file": "ramp.png", "projection": "xy"}}])
    m = st.domains["mesh"]
    centre = m.vertices[m.faces].mean(axis=1)
    u = (centre[:, 0] - m.vertices[:, 0].min()) / np.ptp(m.vertices[:, 0])
    expect = np.clip(u * 64 - 0.5, 0, 63) * 4 / 255
    np.testing.assert_allclose(m["image__value"], expect, atol=1e-9)
    # the same through a vertex UV field: u from x, v from y
    m.add_field("mesh__uv", (m.vertices[:, :2] - m.vertices[:, :2].min(0)) / np.ptp(m.vertices[:, :2], 0),
                at="vertex")
    from procgen.builtin.loaders import MeshImageField
    rule = MeshImageField.from_params({"file": str(tmp_path / "ramp.png"), "field": "image__by_uv"})
    st.base_dir = tmp_path
    rule.step(st)
    np.testing.assert_allclose(m["image__by_uv"], m["image__value"], atol=1e-12)


def test_colour_channels_on_a_grey_image_fail_at_check(host, tmp_path):
    Image.fromarray(np.zeros((4, 4), np.uint8), "L").save(tmp_path / "grey.png")
    with pytest.raises(RecipeError, match=r"grey\.png: channels = 'rgb'"):
        check_recipe({"steps": [{"rule": "grid.noise", "params": {"nx": 8, "ny": 8}},
                                {"rule": "grid.image_field", "params": {"file": "grey.png", "channels": "rgb"}}]},
                     host, "r.toml", tmp_path)
