"""grid.load: PNG (16/8-bit, procgen's sidecar), NPY, resampling, nodata, and check-time refusals."""
from __future__ import annotations

import json

import numpy as np
import pytest
from PIL import Image

from procgen.domains import Grid
from procgen.errors import RecipeError
from procgen.exchange import heightmap_npy, heightmap_png16, write_many
from procgen.recipes import check_recipe, load_recipe
from procgen.runner import run


def _load(host, tmp_path, **params):
    steps = [{"rule": "grid.load", "params": params}]
    recipe = check_recipe({"steps": steps}, host, str(tmp_path / "r.toml"), tmp_path)
    return run(recipe, host, progress=False).state.domains[params.get("grid", "terrain")]


def _grid(rng, shape=(37, 53), spacing=2.5, origin=(100.0, -40.0)) -> Grid:
    g = Grid(shape, spacing, origin)
    yy, xx = np.meshgrid(g.y, g.x, indexing="ij")
    g.add_field("surface__height", 0.3 * xx - 0.2 * yy + rng.normal(0, 3, shape), at="cell", units="length")
    return g


def test_png16_export_then_import_gives_heights_back_within_one_step(host, tmp_path):
    g = _grid(np.random.default_rng(1))
    write_many(tmp_path, heightmap_png16(g, stem="h"))
    got = _load(host, tmp_path, file="h.png")
    h = g["surface__height"]
    step = (h.max() - h.min()) / 65535
    assert got.shape == g.shape and got.spacing == g.spacing and got.origin == g.origin
    assert np.abs(got["surface__height"] - h).max() <= step     # row order, scale and offset right
    assert np.abs(got["surface__height"] - h).max() > 0          # it really went through 16 bits
    assert not got["surface__nodata"].any()


def test_npy_export_then_import_is_exact(host, tmp_path):
    g = _grid(np.random.default_rng(2))
    write_many(tmp_path, heightmap_npy(g, stem="h"))
    got = _load(host, tmp_path, file="h.npy")
    assert np.array_equal(got["surface__height"], g["surface__height"])
    assert got.origin == g.origin and got.spacing == g.spacing


def test_8bit_png_without_sidecar_scales_black_to_white_and_north_is_the_top_row(host, tmp_path):
    a = np.zeros((20, 30), np.uint8)
    a[0] = 255                                 # the image's top row: the north edge
    a[:, 0] = 51
    Image.fromarray(a, "L").save(tmp_path / "m.png")
    got = _load(host, tmp_path, file="m.png", z_min=-10.0, z_max=40.0, spacing=5.0)
    h = got["surface__height"]
    assert got.spacing == 5.0 and got.origin == (0.0, 0.0)
    assert np.all(h[-1, 1:] == 40.0)           # Grid row -1 = largest y = north
    assert np.allclose(h[:, 0], -10.0 + 51 / 255 * 50.0) and np.all(h[:-1, 1:] == -10.0)


def test_nodata_holes_are_filled_by_interpolation_and_marked(host, tmp_path):
    a = np.add.outer(16.0 * np.arange(12), 0.5 * np.arange(16))     # a plane: interpolation is exact
    truth = a.copy()
    a[3:6, 6:10] = np.nan                                             # an inner hole
    a[9:, :2] = np.nan                                                # a hole at a corner
    a[0, :] = np.nan                                                  # a whole edge row
    np.save(tmp_path / "d.npy", a)
    got = _load(host, tmp_path, file="d.npy")
    h, nd = np.flipud(got["surface__height"]), np.flipud(got["surface__nodata"])
    assert np.array_equal(nd == 1, np.isnan(a))
    assert np.array_equal(h[~np.isnan(a)], a[~np.isnan(a)])
    np.testing.assert_allclose(h[3:6, 6:10], truth[3:6, 6:10], atol=1e-9)
    corner = h[9:, :2]                                                # partly outside the rim's hull
    assert np.all((corner >= np.nanmin(a[8:, :3])) & (corner <= np.nanmax(a[8:, :3])))
    assert np.array_equal(h[0], h[1])                                 # beyond the rim's hull: nearest


def test_resampling_keeps_extent_square_cells_and_a_linear_ramp(host, tmp_path):
    g = Grid((40, 60), 1.5, (10.0, 20.0))
    yy, xx = np.meshgrid(g.y, g.x, indexing="ij")
    g.add_field("surface__height", 2.0 * xx + 0.5 * yy, at="cell")
    write_many(tmp_path, heightmap_npy(g, stem="ramp"))
    for nx in (30, 150):                      # shrink (low-pass first) and grow
        got = _load(host, tmp_path, file="ramp.npy", nx=nx)
        assert got.shape == (round(40 * nx / 60), nx)
        assert got.spacing == pytest.approx(60 * 1.5 / nx) and got.origin == (10.0, 20.0)
        gy, gx = np.meshgrid(got.y, got.x, indexing="ij")
        inner = (slice(8, -8), slice(8, -8))
        np.testing.assert_allclose(got["surface__height"][inner], (2.0 * gx + 0.5 * gy)[inner], atol=1e-9)
    with pytest.raises(RecipeError, match="square"):
        _load(host, tmp_path, file="ramp.npy", nx=30, ny=30)


def test_shipped_png_is_eroded_and_written_back_as_a_heightmap(host, tmp_path):
    recipe = load_recipe("data/terrain-from-png", host, ["steps.3.iterations=8", "steps.3.params.rain=300"])
    res = run(recipe, host, out_dir=tmp_path, progress=False)
    side = json.loads((tmp_path / "height.json").read_text())
    out = np.asarray(Image.open(tmp_path / "height.png"))
    assert out.dtype == np.uint16 and out.shape == (128, 128) and side["spacing"] == 2.0
    # the loaded heights are the substrate; soil lies on top and rain moved some of it
    g = res.state.domains["terrain"]
    src = json.loads((recipe.base_dir / "mesa-png16.json").read_text())
    base = g["surface__base"]
    assert src["z_min"] - 1e-9 <= base.min() and base.max() <= src["z_max"] + 1e-9
    eroded = g["surface__height"] - base - g["layers__thickness"].sum(axis=-1)
    assert np.abs(eroded).max() < 1e-9                       # height = base + layers, always
    assert np.abs(g["sediment__deposit"]).sum() > 0


@pytest.mark.parametrize("content, match", [
    (b"hello, not an image", r"bad\.png: not an image"),
    (None, r"colour\.png: a colour image"),
])
def test_bad_images_fail_at_check_time_naming_the_file(host, tmp_path, content, match):
    if content is None:
        Image.fromarray(np.zeros((4, 4, 3), np.uint8), "RGB").save(tmp_path / "colour.png")
        name = "colour.png"
    else:
        (tmp_path / "bad.png").write_bytes(content)
        name = "bad.png"
    with pytest.raises(RecipeError, match=match) as e:
        check_recipe({"steps": [{"rule": "grid.load", "params": {"file": name}}]}, host, "r.toml", tmp_path)
    assert "\n" not in str(e.value) and "steps[0]" in str(e.value)


def test_a_raster_bigger_than_memory_is_refused_before_reading(host, tmp_path):
    # an NPY header promising 200000 x 200000 float64 (320 GB) and no data behind it
    with (tmp_path / "huge.npy").open("wb") as fh:
        np.lib.format.write_array_header_1_0(fh, {"descr": "<f8", "fortran_order": False, "shape": (200000, 200000)})
    with pytest.raises(RecipeError, match=r"huge\.npy: a 200000 x 200000 raster needs about .* GiB"):
        check_recipe({"steps": [{"rule": "grid.load", "params": {"file": "huge.npy"}}]}, host, "r.toml", tmp_path)


def test_the_shipped_heightmap_is_what_its_recipe_makes(host, tmp_path):
    run(load_recipe("data/make-mesa", host), host, out_dir=tmp_path, progress=False)
    shipped = load_recipe("data/terrain-from-png", host).base_dir
    made = np.asarray(Image.open(tmp_path / "mesa-png16.png"))
    assert np.array_equal(made, np.asarray(Image.open(shipped / "mesa-png16.png")))
    a = json.loads((tmp_path / "mesa-png16.json").read_text())
    b = json.loads((shipped / "mesa-png16.json").read_text())
    # bit for bit on every CPU: the fBm's spectrum is procgen.portable.power, not np.power
    assert {k: a[k] for k in ("z_min", "z_max", "spacing", "shape")} == {k: b[k] for k in ("z_min", "z_max", "spacing", "shape")}


@pytest.mark.parametrize("params, match", [
    ({"base": "flat", "base_grid": "dem"}, "needs base = 'grid'"),
    ({"base": "grid", "base_grid": "dem"}, "made by an earlier step"),
])
def test_water_surface_on_a_loaded_grid_is_checked_before_running(host, params, match):
    with pytest.raises(RecipeError, match=match):
        check_recipe({"steps": [{"rule": "water.surface", "params": params}]}, host, "r.toml")
