"""Issue 36's hostile and broken input files: each is refused by `procgen check` (or, for data
only the read sees, by `procgen run`) in one line naming the file, exit 1, never an internal
error, never a hang, never a library name, exception class or the file's bytes.

FIFOs stand in for every non-regular file (the case that hung `procgen run`); sparse files
stand in for huge ones (the size bound refuses them from their length, unread).
"""
from __future__ import annotations

import base64
import json
import os
import re
import shutil
import struct
import subprocess
import sys
import zlib

import numpy as np
import pytest
import rasterio
from rasterio.transform import from_origin

from procgen.cli import main
from procgen.data import meshes_dir
from procgen.exchange.input_files import MAX_BYTES

NS = 'xmlns="http://www.w3.org/2000/svg" xmlns:xlink="http://www.w3.org/1999/xlink"'
#: what a message must never show: an exception class, a library, bytes
LEAK = re.compile(r"\w*(Error|Exception|Warning)\b|\bPIL\b|Pillow|trimesh|svgelements|numpy|rasterio|GDAL|b'|"
                  r"Traceback|site-packages")
MESHES = meshes_dir()
TRIANGLE = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nf 1/1 2/2 3/3\n"


def _recipe(d, rule, **params):
    body = ", ".join(f"{k} = {json.dumps(v)}" for k, v in params.items())
    extra = '[[steps]]\nrule = "grid.noise"\nparams = { nx = 8, ny = 8 }\n' if rule == "grid.image_field" else ""
    (d / "r.toml").write_text(f'{extra}[[steps]]\nrule = "{rule}"\nparams = {{ {body} }}\n')
    return d / "r.toml"


#: the installed console script, as a user runs it
CLI = [shutil.which("procgen")] if shutil.which("procgen") else \
    [sys.executable, "-c", "import sys; from procgen.cli import main; sys.exit(main(sys.argv[1:]))"]


def _refused(capsys, argv, *needles):
    """Exit 1 with exactly one clean line holding every needle; the line is returned."""
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.startswith("procgen: error:"), err
    assert not LEAK.search(err.replace("procgen: error:", "")), err
    for n in needles:
        assert n in err, (n, err)
    return err


# -- 1. non-regular and oversized files, the mesh's own references included ---------------

def _fifo(d, name):
    os.mkfifo(d / name)
    return name


@pytest.mark.parametrize("rule,key,name", [("grid.load", "file", "h.npy"), ("grid.load", "file", "h.tif"),
                                           ("grid.image_field", "file", "m.png"), ("lines.load", "file", "o.svg"),
                                           ("mesh.load", "path", "m.obj")])
def test_a_fifo_as_the_input_file_is_refused_at_check(rule, key, name, tmp_path, capsys):
    _fifo(tmp_path, name)
    _refused(capsys, ["check", str(_recipe(tmp_path, rule, **{key: name}))], name, "named pipe (FIFO)")


def test_a_folder_as_the_input_file_is_refused_at_check(tmp_path, capsys):
    (tmp_path / "h.npy").mkdir()
    _refused(capsys, ["check", str(_recipe(tmp_path, "grid.load", file="h.npy"))], "h.npy", "a folder")


def _obj_with_fifo_mtllib(d):
    _fifo(d, "m.mtl")
    (d / "m.obj").write_text("mtllib m.mtl\n" + TRIANGLE)
    return "m.mtl"


def _obj_with_fifo_texture(d):
    _fifo(d, "tex.png")
    (d / "m.mtl").write_text("newmtl a\nKd 1 1 1\nmap_Kd -s 1 1 1 tex.png\n")
    (d / "m.obj").write_text("mtllib m.mtl\nusemtl a\n" + TRIANGLE)
    return "tex.png"


def _gltf(d, uri):
    doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
           "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
           "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                          "min": [0, 0, 0], "max": [1, 1, 0]}],
           "bufferViews": [{"buffer": 0, "byteLength": 36}], "buffers": [{"byteLength": 36, "uri": uri}]}
    (d / "m.gltf").write_text(json.dumps(doc))


def _gltf_with_fifo_buffer(d):
    _fifo(d, "buf.bin")
    _gltf(d, "buf.bin")
    return "buf.bin"


def _gltf_with_huge_buffer(d):
    with (d / "buf.bin").open("wb") as fh:
        fh.truncate(MAX_BYTES["mesh part"] + 1)     # sparse: no disk used
    _gltf(d, "buf.bin")
    return "MiB"


@pytest.mark.parametrize("make,mesh", [(_obj_with_fifo_mtllib, "m.obj"), (_obj_with_fifo_texture, "m.obj"),
                                       (_gltf_with_fifo_buffer, "m.gltf"), (_gltf_with_huge_buffer, "m.gltf")])
def test_a_file_a_mesh_names_is_checked_at_check_time(make, mesh, tmp_path, capsys):
    what = make(tmp_path)
    _refused(capsys, ["check", str(_recipe(tmp_path, "mesh.load", path=mesh))], mesh, what)


def test_a_glb_naming_a_fifo_buffer_is_refused(tmp_path, capsys):
    _fifo(tmp_path, "b.bin")
    js = json.dumps({"asset": {"version": "2.0"}, "buffers": [{"byteLength": 36, "uri": "b.bin"}]}).encode()
    js += b" " * (-len(js) % 4)
    (tmp_path / "m.glb").write_bytes(struct.pack("<4sII", b"glTF", 2, 20 + len(js))
                                     + struct.pack("<I4s", len(js), b"JSON") + js)
    _refused(capsys, ["check", str(_recipe(tmp_path, "mesh.load", path="m.glb"))], "m.glb", "b.bin", "FIFO")


def test_an_embedded_gltf_buffer_and_a_missing_material_still_load(tmp_path, capsys):
    """The checks refuse only what they must: data: URIs and a missing MTL are fine."""
    pos = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0]], np.float32).tobytes()
    _gltf(tmp_path, "data:application/octet-stream;base64," + base64.b64encode(pos).decode())
    assert main(["run", str(_recipe(tmp_path, "mesh.load", path="m.gltf")), "--out", str(tmp_path / "o1")]) == 0
    (tmp_path / "t.obj").write_text("mtllib gone.mtl\n" + TRIANGLE)
    assert main(["run", str(_recipe(tmp_path, "mesh.load", path="t.obj")), "--out", str(tmp_path / "o2")]) == 0


@pytest.mark.parametrize("rule,name,kind", [("lines.load", "big.svg", "SVG"), ("mesh.load", "big.obj", "mesh"),
                                            ("grid.image_field", "big.png", "image")])
def test_a_file_over_its_kinds_size_bound_is_refused_unread(rule, name, kind, tmp_path, capsys):
    with (tmp_path / name).open("wb") as fh:           # a 200 MB path, a 1 GiB mesh... all sparse
        fh.write(b'<svg xmlns="http://www.w3.org/2000/svg"><path d="M0 0' if kind == "SVG" else b"v 0 0 0\n")
        fh.truncate(max(MAX_BYTES[kind] + 1, 200 * 2**20))
    key = "path" if rule == "mesh.load" else "file"
    _refused(capsys, ["check", str(_recipe(tmp_path, rule, **{key: name}))], name, "MiB", kind)


# -- 2. SVG -------------------------------------------------------------------------------

def _svg(body, root='viewBox="0 0 100 100"'):
    return f'<svg {NS} {root}>{body}</svg>'


_GROUP = '<g id="grp">' + '<path d="M0 0 L1 1"/>' * 1000 + "</g>"
SVG_CASES = {
    "nested 10000 deep": (_svg("<g>" * 10000 + '<path d="M0 0 L1 1"/>' + "</g>" * 10000), "nested more than"),
    "use loop": (_svg('<g id="a"><use xlink:href="#b"/></g><g id="b"><use xlink:href="#a"/></g>'), "<use> loop"),
    "use of itself": (_svg('<g id="a"><path d="M0 0L1 1"/><use href="#a"/></g>'), "<use> loop"),
    "use loop via a repeated id": (_svg('<g id="a"><path d="M0 0L1 1"/><use href="#a"/></g><g id="a"/>'), "<use> loop"),
    "use of 150,000 copies": (_svg('<defs><g id="a"><path d="M0 0L1 1"/></g></defs><g>' + '<use href="#a"/>' * 150_000
                                   + "</g>"), "<use> copies counted"),
    "use amplification": (_svg(f"<defs>{_GROUP}</defs>" + '<use href="#grp"/>' * 1000), "<use> copies counted"),
    "use chain 200 deep": (_svg("<defs>" + "".join(f'<g id="g{i}"><use href="#g{i + 1}"/></g>' for i in range(200))
                                + '<g id="g200"><path d="M0 0L1 1"/></g></defs><use href="#g0"/>'), "nested more than"),
    "viewBox 0 0 0 0": (_svg('<path d="M0 0 L1 1"/>', 'viewBox="0 0 0 0"'), "viewBox '0 0 0 0' has no area"),
    "negative viewBox": (_svg('<path d="M0 0 L1 1"/>', 'viewBox="0 0 -5 10"'), "has no area"),
    "viewBox not numbers": (_svg('<path d="M0 0 L1 1"/>', 'viewBox="a b c d"'), "is not four numbers"),
    "width 0": (_svg('<path d="M0 0 L1 1"/>', 'width="0" height="10"'), "width '0' must be > 0"),
    "Bezier at 1e20": (_svg('<path d="M0 0 C 1e20 1e20 -1e20 1e20 50 50"/>'), "flattens to more than"),
    "Bezier at 1e400": (_svg('<path d="M0 0 C 1e400 0 0 1 1 1"/>'), "too large to be numbers"),
    "not XML": ("<svg><g></svg>", "not well-formed XML at line 1"),
    "entity laughs": ('<?xml version="1.0"?><!DOCTYPE svg [<!ENTITY a "<path d=\'M0 0L1 1\'/>">'
                      + "".join(f'<!ENTITY l{i} "{(f"&l{i - 1};" if i > 1 else "&a;") * 10}">' for i in range(1, 10))
                      + f']><svg {NS} viewBox="0 0 9 9">&l9;</svg>', "drawing too large"),
    "external entity": ('<?xml version="1.0"?><!DOCTYPE svg [<!ENTITY x SYSTEM "/dev/zero">]>'
                           f'<svg {NS} viewBox="0 0 9 9">&x;</svg>', "not well-formed XML"),
    "segments": (_svg('<path d="M0 0 ' + "L1 1 " * 300_000 + '"/>'), "250,000 path segments"),
}


@pytest.mark.parametrize("case", list(SVG_CASES))
def test_hostile_svg_is_refused_at_check_in_one_line(case, tmp_path, capsys):
    text, what = SVG_CASES[case]
    (tmp_path / "d.svg").write_text(text)
    _refused(capsys, ["check", str(_recipe(tmp_path, "lines.load", file="d.svg"))], "d.svg", what)


def test_a_use_tree_is_counted_without_expanding_it(tmp_path, capsys):
    """Ten levels of ten <use> each (10^9 copies): refused from the counts, at once."""
    levels = '<g id="l0"><path d="M0 0L1 1"/></g>' + "".join(
        f'<g id="l{i}">' + f'<use href="#l{i - 1}"/>' * 10 + "</g>" for i in range(1, 10))
    (tmp_path / "d.svg").write_text(_svg(f"<defs>{levels}</defs><use href='#l9'/>"))
    _refused(capsys, ["check", str(_recipe(tmp_path, "lines.load", file="d.svg"))], "d.svg", "elements")


def test_a_modest_use_of_a_group_still_loads(tmp_path, capsys):
    (tmp_path / "d.svg").write_text(_svg('<defs><g id="s"><path d="M1 1 L9 1 L9 9 Z"/></g></defs>'
                                         + "".join(f'<use href="#s" x="{10 * i}"/>' for i in range(9))))
    assert main(["check", str(_recipe(tmp_path, "lines.load", file="d.svg"))]) == 0


# -- 3. NPY, GeoTIFF, images --------------------------------------------------------------

def _npy_bytes(a):
    import io
    b = io.BytesIO()
    np.save(b, a)
    return b.getvalue()


NPY_CASES = {
    "truncated": (lambda: _npy_bytes(np.zeros((6, 7)))[:-30], "NPY file is truncated"),
    "shadow-like": (lambda: b"root:*:19000:0:99999:7:::\ndaemon:*:19000:0:99999:7:::\n", "no NPY signature"),
    "bad header": (lambda: b"\x93NUMPY\x01\x00\x16\x00{'descr': 'zz', }      \n", "NPY header is damaged"),
    "bad version": (lambda: b"\x93NUMPY\x09\x00\x16\x00" + b" " * 22, "version 9.0 is unknown"),
    "object array": (lambda: b"\x93NUMPY\x01\x00" + struct.pack("<H", 70)
                     + b"{'descr': '|O', 'fortran_order': False, 'shape': (2, 2), }".ljust(69) + b"\n", "NPY holds object"),
    "no cells": (lambda: _npy_bytes(np.zeros((0, 5))), "has no cells"),
}


@pytest.mark.parametrize("case", list(NPY_CASES))
def test_a_broken_npy_is_refused_at_check_without_echoing_it(case, tmp_path, capsys):
    make, what = NPY_CASES[case]
    (tmp_path / "h.npy").write_bytes(make())
    err = _refused(capsys, ["check", str(_recipe(tmp_path, "grid.load", file="h.npy"))], "h.npy", what)
    said = err.rsplit("h.npy", 1)[1]             # what follows the file's name
    assert "root" not in said and "daemon" not in said and "*" not in said


def _tif(d, name="t.tif"):
    with rasterio.open(d / name, "w", driver="GTiff", height=64, width=64, count=1, dtype="float32",
                       crs="EPSG:32633", transform=from_origin(0.0, 640.0, 10.0, 10.0)) as ds:
        ds.write(np.random.default_rng(0).random((1, 64, 64), dtype=np.float32))
    return (d / name).read_bytes()


@pytest.mark.parametrize("cut,what", [(0.5, "GeoTIFF is truncated: its pixel data runs to byte"),
                                      (400, "GeoTIFF is truncated"), (12, "its header is damaged")])
def test_a_truncated_geotiff_is_refused_at_check_in_one_line(cut, what, tmp_path, capsys):
    data = _tif(tmp_path)
    (tmp_path / "t.tif").write_bytes(data[: int(cut * len(data)) if cut < 1 else cut])
    _refused(capsys, ["check", str(_recipe(tmp_path, "grid.load", file="t.tif"))], "t.tif", what)


def test_damaged_geotiff_pixel_data_is_refused_at_run_in_one_line(tmp_path, capsys):
    """Blocks all there but their bytes overwritten: only the read can tell."""
    with rasterio.open(tmp_path / "t.tif", "w", driver="GTiff", height=64, width=64, count=1, dtype="float32",
                       compress="deflate", transform=from_origin(0.0, 640.0, 10.0, 10.0)) as ds:
        ds.write(np.random.default_rng(0).random((1, 64, 64), dtype=np.float32))
    with rasterio.open(tmp_path / "t.tif") as src:
        off = int(src.get_tag_item("BLOCK_OFFSET_0_0", "TIFF", bidx=1))
    data = bytearray((tmp_path / "t.tif").read_bytes())
    data[off:off + 64] = b"\xff" * 64
    (tmp_path / "t.tif").write_bytes(bytes(data))
    _refused(capsys, ["run", str(_recipe(tmp_path, "grid.load", file="t.tif")), "--out", str(tmp_path / "o")],
             "t.tif", "pixel data is damaged or truncated")


def test_a_geotiff_beside_a_fifo_sidecar_does_not_hang(tmp_path):
    """GDAL looks for t.tif.aux.xml and t.tfw beside a raster; procgen tells it not to."""
    _tif(tmp_path)
    for side in ("t.tif.aux.xml", "t.tfw", "t.tif.ovr"):
        os.mkfifo(tmp_path / side)
    r = _recipe(tmp_path, "grid.load", file="t.tif")
    done = subprocess.run([*CLI, "run", str(r), "--out", str(tmp_path / "o")],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert done.returncode == 0, done.stderr


def _png_header(w, h):
    """A PNG promising w x h grey pixels in its IHDR, with one row of pixel data."""
    ihdr = struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)
    def chunk(kind, body):
        return struct.pack(">I", len(body)) + kind + body + struct.pack(">I", zlib.crc32(kind + body))

    return b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(b"\x00" * 64)) + chunk(b"IEND", b"")


@pytest.mark.parametrize("rule", ["grid.load", "grid.image_field"])
def test_an_image_of_144_megapixels_is_refused_before_decoding(rule, tmp_path, capsys):
    (tmp_path / "m.png").write_bytes(_png_header(12000, 12000))
    _refused(capsys, ["check", str(_recipe(tmp_path, rule, file="m.png"))], "m.png", "144 Mpx", "100 Mpx")


@pytest.mark.parametrize("content,what", [(b"hello, not pixels", "not an image file"),
                                          (b"\x89PNG\r\n\x1a\n" + b"\x00" * 40, "not an image file"),
                                          (None, "damaged or truncated")])
def test_a_broken_image_names_no_library(content, what, tmp_path, capsys):
    if content is None:
        from PIL import Image

        Image.fromarray(np.random.default_rng(1).integers(0, 255, (64, 64), dtype=np.uint8)).save(tmp_path / "m.png")
        content = (tmp_path / "m.png").read_bytes()[:-200]
    (tmp_path / "m.png").write_bytes(content)
    r = _recipe(tmp_path, "grid.image_field", file="m.png")
    argv = ["run", str(r), "--out", str(tmp_path / "o")] if what.startswith("damaged") else ["check", str(r)]
    _refused(capsys, argv, "m.png", what)


# -- 4. sidecar values --------------------------------------------------------------------

@pytest.mark.parametrize("key,value,what", [
    ("spacing", "0", "'spacing' must be > 0, got 0"), ("spacing", "-2.5", "'spacing' must be > 0, got -2.5"),
    ("spacing", "NaN", "'spacing' must be a finite number, got nan"),
    ("spacing", "1e999", "'spacing' must be a finite number, got inf"),
    ("spacing", '"2 m"', "'spacing' must be a number, got text"), ("spacing", "true", "got true/false"),
    ("spacing", "null", "got null"), ("origin", "[0]", "'origin' must be [x, y]"),
    ("origin", '[0, "a"]', "'origin' must be a number"), ("z_max", "Infinity", "'z_max' must be a finite"),
    ("shape", "[4, -5]", "'shape' (two whole numbers > 0)"),
])
def test_bad_sidecar_values_are_refused_at_check(key, value, what, tmp_path, capsys):
    np.save(tmp_path / "h.npy", np.zeros((4, 5)))
    doc = {"encoding": '"npy"', "shape": "[4, 5]", "spacing": "1.0", "origin": "[0, 0]", key: value}
    (tmp_path / "h.json").write_text("{" + ", ".join(f'"{k}": {v}' for k, v in doc.items()) + "}")
    _refused(capsys, ["check", str(_recipe(tmp_path, "grid.load", file="h.npy"))], "h.json", what)


def test_a_sidecar_nested_10000_deep_is_refused(tmp_path, capsys):
    np.save(tmp_path / "h.npy", np.zeros((4, 5)))
    (tmp_path / "h.json").write_text('{"encoding": "npy", "x": ' + "[" * 10000 + "]" * 10000 + "}")
    _refused(capsys, ["check", str(_recipe(tmp_path, "grid.load", file="h.npy"))], "h.json", "not readable JSON")


# -- the worst cases through the real CLI, as a user runs it --------------------------------

@pytest.mark.parametrize("make,mesh", [(_obj_with_fifo_mtllib, "m.obj"), (_gltf_with_fifo_buffer, "m.gltf")])
def test_procgen_run_on_a_mesh_naming_a_fifo_exits_1_without_hanging(make, mesh, tmp_path):
    what = make(tmp_path)
    r = _recipe(tmp_path, "mesh.load", path=mesh)
    for argv in (["check", str(r)], ["run", str(r), "--out", str(tmp_path / "o")]):
        done = subprocess.run([*CLI, *argv], capture_output=True, text=True,
                              timeout=120, cwd=tmp_path)
        err = done.stderr.strip()
        assert done.returncode == 1 and "\n" not in err and what in err and not LEAK.search(err), (argv, err)


def _memory_cap():
    """3 GiB of address space: the worst inputs once cost 363 GiB, or gigabytes and minutes."""
    import resource

    resource.setrlimit(resource.RLIMIT_AS, (3 * 2**30, 3 * 2**30))


@pytest.mark.parametrize("case", ["use amplification", "nested 10000 deep", "Bezier at 1e20", "use loop"])
@pytest.mark.parametrize("command", ["check", "run"])
def test_procgen_on_the_worst_svgs_exits_1_under_a_memory_cap(case, command, tmp_path):
    (tmp_path / "d.svg").write_text(SVG_CASES[case][0])
    argv = [command, str(_recipe(tmp_path, "lines.load", file="d.svg"))] + (["--out", str(tmp_path / "o")]
                                                                          if command == "run" else [])
    done = subprocess.run([*CLI, *argv], capture_output=True, text=True, timeout=120, cwd=tmp_path,
                          preexec_fn=_memory_cap)
    err = done.stderr.strip()
    assert done.returncode == 1 and "\n" not in err and "d.svg" in err and SVG_CASES[case][1] in err, err
    assert not LEAK.search(err), err


# -- a mesh's size is known at check time ---------------------------------------------------

def test_a_mesh_promising_two_billion_faces_is_refused_at_check(tmp_path, capsys):
    (tmp_path / "m.ply").write_text("ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n"
                                    "property float z\nelement face 2000000000\nproperty list uchar int vertex_indices\n"
                                    "end_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n")
    _refused(capsys, ["check", str(_recipe(tmp_path, "mesh.load", path="m.ply"))], "m.ply", "2,000,000,000 faces", "GiB")


@pytest.mark.parametrize("suffix", [".obj", ".ply", ".stl", ".off", ".glb"])
def test_the_face_count_read_at_check_is_the_files(suffix, tmp_path):
    import trimesh

    from procgen.builtin.meshes import load_mesh_file
    from procgen.exchange.mesh_read import face_count

    src = load_mesh_file(MESHES / "spot.obj")
    path = tmp_path / f"spot{suffix}"
    trimesh.Trimesh(src.vertices, src.faces, process=False).export(path)
    assert face_count(path, path.read_bytes()) == src.n_faces == len(trimesh.load(path, force="mesh").faces)
