"""Fuzzing the input readers (issue 36): bytes of small valid SVG, OBJ, PNG, NPY and GeoTIFF
files are overwritten, deleted, inserted and cut by hypothesis, and each load must either
succeed or raise a ProcgenError whose message is one line naming the file and no exception
class, library or file bytes; any other exception is a failure, and so is a hang (hypothesis's
deadline, generous for a shared machine, bounds each example).
"""
from __future__ import annotations

import io
import re
import tempfile
from datetime import timedelta
from pathlib import Path

import numpy as np
import pytest
import rasterio
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from PIL import Image
from rasterio.transform import from_origin

from procgen.builtin.meshes import load_mesh_file
from procgen.errors import ProcgenError
from procgen.exchange.raster_read import read_raster
from procgen.exchange.svg_read import read_svg

LEAK = re.compile(r"\w*(Error|Exception|Warning)\b|\bPIL\b|Pillow|trimesh|svgelements|numpy|rasterio|GDAL|b'|"
                  r"Traceback|site-packages")


def _svg() -> bytes:
    return (b'<svg xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink" '
            b'width="20mm" height="10mm" viewBox="0 0 20 10"><defs><g id="a"><path d="M1 1 C 3 0 5 9 9 9 Z"/>'
            b'</g></defs><use xlink:href="#a" transform="rotate(30)"/><rect x="2" y="2" width="3" height="4" '
            b'rx="1"/><circle cx="5" cy="5" r="2"/><polygon points="1,1 4,1 3,3"/>'
            b'<path d="M0 0 A 3 2 0 0 1 5 5 Q 6 6 7 5"/></svg>')


def _obj() -> bytes:
    return b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvt 1 1\nf 1/1 2/2 4/4 3/3\n"


def _png() -> bytes:
    b = io.BytesIO()
    Image.fromarray((np.arange(64).reshape(8, 8) * 4).astype(np.uint8), "L").save(b, "PNG")
    return b.getvalue()


def _npy() -> bytes:
    b = io.BytesIO()
    np.save(b, np.arange(20.0).reshape(4, 5))
    return b.getvalue()


def _tif() -> bytes:
    with tempfile.TemporaryDirectory() as d:
        with rasterio.open(Path(d) / "s.tif", "w", driver="GTiff", height=8, width=8, count=1, dtype="float32",
                           crs="EPSG:32633", transform=from_origin(0.0, 80.0, 10.0, 10.0)) as ds:
            ds.write(np.arange(64, dtype=np.float32).reshape(1, 8, 8))
        return (Path(d) / "s.tif").read_bytes()


SEEDS = {"svg": _svg, "obj": _obj, "png": _png, "npy": _npy, "tif": _tif}
#: what mutated SVG/OBJ text tends to need to reach the deep cases: numbers, nesting, refs
TOKENS = [b"9", b"e99", b"-", b"\x00", b"<g>", b"</g>", b'<use href="#a"/>', b"#a", b"0", b"1e400", b" "]

mutation = st.one_of(
    st.tuples(st.just("set"), st.integers(0, 10**6), st.integers(0, 255)),
    st.tuples(st.just("delete"), st.integers(0, 10**6), st.integers(1, 32)),
    st.tuples(st.just("insert"), st.integers(0, 10**6), st.sampled_from(TOKENS)),
    st.tuples(st.just("cut"), st.integers(0, 10**6), st.just(0)),
)


def _mutate(data: bytes, edits: list[tuple]) -> bytes:
    out = bytearray(data)
    for op, pos, arg in edits:
        at = pos % (len(out) + 1)
        if op == "set" and out:
            out[min(at, len(out) - 1)] = arg
        elif op == "delete":
            del out[at:at + arg]
        elif op == "insert":
            out[at:at] = arg
        elif op == "cut":
            del out[at:]
    return bytes(out)


def _load(kind: str, path: Path) -> None:
    if kind == "svg":
        read_svg(path)
    elif kind == "obj":
        load_mesh_file(path)
    else:
        read_raster(path)


@pytest.mark.parametrize("kind", list(SEEDS))
def test_mutated_input_files_load_or_are_refused_in_one_clean_line(kind):
    seed = SEEDS[kind]()

    @settings(max_examples=200, deadline=timedelta(seconds=20), derandomize=True, database=None,
              suppress_health_check=[HealthCheck.too_slow])
    @given(st.lists(mutation, min_size=1, max_size=6))
    def check(edits):
        with tempfile.TemporaryDirectory() as d:
            path = Path(d) / f"fuzzed.{kind}"
            path.write_bytes(_mutate(seed, edits))
            try:
                _load(kind, path)
            except ProcgenError as exc:
                message = str(exc)
                assert "\n" not in message and "fuzzed" in message, message
                assert not LEAK.search(message), message

    check()


def test_the_seed_files_themselves_load():
    """The fuzz starts from files that are valid: otherwise it only tests refusals."""
    with tempfile.TemporaryDirectory() as d:
        for kind, make in SEEDS.items():
            path = Path(d) / f"seed.{kind}"
            path.write_bytes(make())
            _load(kind, path)
