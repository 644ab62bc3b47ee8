"""Issue 18's bad inputs, all in one place: each is one line from `procgen check` naming the
file, before anything runs (a colour image as heights, a file that is not an image, a DEM in
degrees, a raster bigger than memory, an SVG with no closed path to extrude)."""
from __future__ import annotations

import numpy as np
import pytest
import rasterio
from PIL import Image
from rasterio.transform import from_origin

from procgen.cli import main


def _colour(d):
    Image.fromarray(np.zeros((8, 8, 3), np.uint8)).save(d / "photo.png")
    return "photo.png", [{"rule": "grid.load", "params": {"file": "photo.png"}}], "a colour image"


def _not_image(d):
    (d / "notes.png").write_text("these are notes, not pixels\n")
    return "notes.png", [{"rule": "grid.load", "params": {"file": "notes.png"}}], "not an image"


def _degrees(d):
    with rasterio.open(d / "wgs84.tif", "w", driver="GTiff", height=8, width=8, count=1, dtype="float32",
                       crs="EPSG:4326", transform=from_origin(10.0, 50.0, 0.01, 0.01)) as ds:
        ds.write(np.zeros((1, 8, 8), np.float32))
    return "wgs84.tif", [{"rule": "grid.load", "params": {"file": "wgs84.tif"}}], "degrees"


def _too_large(d):
    with (d / "huge.npy").open("wb") as fh:         # a header promising 320 GB, no data behind it
        np.lib.format.write_array_header_1_0(fh, {"descr": "<f8", "fortran_order": False, "shape": (200000, 200000)})
    return "huge.npy", [{"rule": "grid.load", "params": {"file": "huge.npy"}}], "GiB"


def _svg_open_only(d):
    (d / "strokes.svg").write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 10 10">'
                                   '<path d="M 1 1 C 3 0 5 9 9 9"/></svg>')
    return "strokes.svg", [{"rule": "lines.load", "params": {"file": "strokes.svg"}},
                           {"rule": "mesh.extrude"}], "no closed path"


@pytest.mark.parametrize("make", [_colour, _not_image, _degrees, _too_large, _svg_open_only])
def test_procgen_check_says_what_and_which_file_in_one_line(make, tmp_path, capsys):
    name, steps, what = make(tmp_path)
    (tmp_path / "r.toml").write_text("".join(
        f'[[steps]]\nrule = "{s["rule"]}"\nparams = {{ {", ".join(f"{k} = {v!r}" for k, v in s.get("params", {}).items())} }}\n'
        .replace("'", '"') for s in steps))
    assert main(["check", str(tmp_path / "r.toml")]) == 1
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and name in err and what in err, err
    assert err.startswith("procgen: error:") and "Traceback" not in err
