"""GeoTIFF DEMs (extra `geo`): made here with rasterio, loaded, eroded, written back in place."""
from __future__ import annotations

import numpy as np
import pytest
import rasterio
from rasterio.transform import Affine

from procgen.errors import RecipeError
from procgen.exchange.raster_read import metres_per_degree
from procgen.recipes import check_recipe
from procgen.runner import run

UTM = "EPSG:32633"


def _dem(path, crs=UTM, transform=None, shape=(40, 56), nodata=-9999.0):
    yy, xx = np.mgrid[0:shape[0], 0:shape[1]]
    z = (400.0 + 8.0 * xx - 5.0 * yy + 30.0 * np.sin(xx / 5.0) * np.cos(yy / 7.0)).astype(np.float32)
    z[10:14, 20:26] = nodata
    transform = transform or Affine(30.0, 0.0, 510000.0, 0.0, -30.0, 5120000.0)
    with rasterio.open(path, "w", driver="GTiff", width=shape[1], height=shape[0], count=1, dtype="float32",
                       crs=crs, transform=transform, nodata=nodata) as dst:
        dst.write(z, 1)
    return z


def _run(host, tmp_path, steps, outputs=()):
    recipe = check_recipe({"steps": steps, "outputs": list(outputs)}, host, str(tmp_path / "r.toml"), tmp_path)
    return run(recipe, host, out_dir=tmp_path / "out", progress=False)


_ERODE = [
    {"rule": "water.surface", "params": {"base": "grid", "base_grid": "dem", "layers": [
        {"preset": "rock", "thickness": 20.0},
        {"preset": "soil", "thickness": 0.05, "erosion_rate": 0.15, "absorption_rate": 0.0, "capacity": 0.0,
         "weakness_threshold": 0.0}]}},
    {"rule": "water.drops", "iterations": 6, "params": {"drops": 0, "rain": 300, "sediment_capacity": 2.0}},
]
_TIF = {"domain": "terrain", "format": "geotiff", "file": "eroded.tif",
        "options": {"nodata_field": "surface__nodata"}}


def test_dem_is_loaded_eroded_and_written_back_with_its_crs_and_transform(host, tmp_path):
    z = _dem(tmp_path / "dem.tif")
    res = _run(host, tmp_path, [{"rule": "grid.load", "params": {"file": "dem.tif", "grid": "dem"}}] + _ERODE,
               [_TIF])
    g = res.state.domains["dem"]
    assert g.spacing == 30.0 and g.origin == (510000.0, 5120000.0 - 40 * 30.0)
    # a cell's centre in grid coordinates is the DEM pixel centre in the CRS
    row, col = 5, 7
    with rasterio.open(tmp_path / "dem.tif") as src:
        x, y = src.xy(row, col)
        mask = src.read_masks(1) == 0
    gi = g.shape[0] - 1 - row
    assert (g.x[col], g.y[gi]) == pytest.approx((x, y))
    assert g["surface__height"][gi, col] == pytest.approx(float(z[row, col]))
    assert np.array_equal(np.flipud(g["surface__nodata"]) == 1, mask)
    with rasterio.open(tmp_path / "out" / "eroded.tif") as out, rasterio.open(tmp_path / "dem.tif") as src:
        assert out.crs == src.crs and out.transform == src.transform and out.shape == src.shape
        back = out.read(1, masked=True)
    assert np.array_equal(np.ma.getmaskarray(back), mask)          # nodata stays nodata
    t = res.state.domains["terrain"]["surface__height"]
    np.testing.assert_allclose(back.compressed(), np.flipud(t)[~mask].astype(np.float32))
    assert np.abs(t - (g["surface__height"] + 20.05)).max() > 1e-6     # the rain changed it


def test_resampled_dem_keeps_its_footprint_and_bytes_are_reproducible(host, tmp_path):
    _dem(tmp_path / "dem.tif")
    steps = [{"rule": "grid.load", "params": {"file": "dem.tif", "grid": "terrain", "nx": 28}}]
    a = _run(host, tmp_path, steps, [dict(_TIF, file="half.tif")])
    assert a.state.domains["terrain"].shape == (20, 28)
    first = (tmp_path / "out" / "half.tif").read_bytes()
    _run(host, tmp_path, steps, [dict(_TIF, file="half.tif")])
    assert (tmp_path / "out" / "half.tif").read_bytes() == first
    with rasterio.open(tmp_path / "out" / "half.tif") as out, rasterio.open(tmp_path / "dem.tif") as src:
        assert out.crs == src.crs and tuple(out.bounds) == pytest.approx(tuple(src.bounds))
        assert out.res == pytest.approx((60.0, 60.0))


def test_a_dem_in_degrees_needs_consent_then_gets_metric_square_cells(host, tmp_path):
    t = Affine(1 / 1200, 0.0, 11.0, 0.0, -1 / 1200, 47.5)         # 3 arc-second cells near 47 N
    _dem(tmp_path / "geo.tif", crs="EPSG:4326", transform=t)
    with pytest.raises(RecipeError, match=r"geo\.tif: CRS counts in degrees") as e:
        check_recipe({"steps": [{"rule": "grid.load", "params": {"file": "geo.tif"}}]}, host, "r.toml", tmp_path)
    assert "\n" not in str(e.value)
    res = _run(host, tmp_path, [{"rule": "grid.load", "params": {"file": "geo.tif", "geographic": True}}],
               [dict(_TIF, file="back.tif")])
    g = res.state.domains["terrain"]
    east, north = metres_per_degree(47.5 - 20 / 1200)
    assert g.spacing == pytest.approx(min(east, north) / 1200)     # cells are square, in metres
    assert g.shape == (round(40 * north / east), 56)
    with rasterio.open(tmp_path / "out" / "back.tif") as out, rasterio.open(tmp_path / "geo.tif") as src:
        assert out.crs == src.crs and tuple(out.bounds) == pytest.approx(tuple(src.bounds), abs=1e-9)


def test_a_file_gdal_cannot_read_fails_at_check_time(host, tmp_path):
    (tmp_path / "broken.tif").write_bytes(b"II*\x00 truncated")
    with pytest.raises(RecipeError, match=r"broken\.tif: not a raster"):
        check_recipe({"steps": [{"rule": "grid.load", "params": {"file": "broken.tif"}}]}, host, "r.toml", tmp_path)
