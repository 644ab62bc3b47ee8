"""Exporters write files other tools open: cairosvg, trimesh, Pillow. Writes are atomic."""
from __future__ import annotations

import io
import json
import os

import cairosvg
import numpy as np
import pytest
import trimesh
from PIL import Image

from procgen import Grid, InputError, Polylines, TriMesh
from procgen.exchange.write import WriteError
from procgen.exchange import (glb_export, heightmap_npy, heightmap_png16, image_png, mesh_svg, obj_export,
                              polylines_svg, write)

PROV = {"recipe": "t", "seed": 1}


def _render(svg: bytes) -> np.ndarray:
    png = cairosvg.svg2png(bytestring=svg, output_width=200)
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGBA"))


def _circle(n=64, r=0.3):
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.column_stack([0.5 + r * np.cos(t), 0.5 + r * np.sin(t)])


def test_svg_renders_filled_shape_with_viewbox_and_metadata():
    pl = Polylines.from_list([_circle()], closed=True, bounds=(0, 1, 0, 1))
    svg = polylines_svg(pl, provenance=PROV, fill="#ff0000", stroke=None, background="#0000ff", margin=0)
    text = svg.decode()
    assert 'viewBox="0 -1 1 1"' in text and "<metadata>" in text and '"seed":1' in text
    img = _render(svg)
    centre, corner = img[100, 100], img[3, 3]
    assert tuple(centre[:3]) == (255, 0, 0)       # inside the ring: fill
    assert tuple(corner[:3]) == (0, 0, 255)       # outside: background
    red = np.all(img[:, :, :3] == (255, 0, 0), axis=2).mean()
    assert abs(red - np.pi * 0.3 ** 2) < 0.02     # area of the filled disc


def test_svg_is_y_up():
    # a triangle in the lower half of the domain must render in the lower half of the image
    pl = Polylines.from_list([np.array([[0.1, 0.1], [0.9, 0.1], [0.5, 0.3]])], closed=True, bounds=(0, 1, 0, 1))
    img = _render(polylines_svg(pl, fill="#000000", stroke=None, background="#ffffff", margin=0))
    dark = np.all(img[:, :, :3] < 50, axis=2)
    rows = np.flatnonzero(dark.any(axis=1))
    assert rows.min() > 100


def test_svg_gradient_and_mesh_wireframe_render():
    pl = Polylines.from_list([_circle()], closed=True, bounds=(0, 1, 0, 1))
    img = _render(polylines_svg(pl, gradient=["#ffffff", "#808080"], background=None))
    assert img[60, 100, 0] > img[140, 100, 0]      # lighter at the top
    m = TriMesh([[0, 0], [1, 0], [0, 1], [1, 1]], [[0, 1, 3], [0, 3, 2]])
    img = _render(mesh_svg(m, stroke="#ff0000", background="#ffffff"))
    assert (np.all(img[:, :, :3] == (255, 255, 255), axis=2)).mean() < 0.99


def test_png16_round_trip_and_sidecar():
    g = Grid((30, 40), spacing=2.0)
    h = np.linspace(-5, 20, 1200).reshape(30, 40)
    g.add_field("surface__height", h, at="cell", units="m")
    files = heightmap_png16(g, stem="h", provenance=PROV)
    img = Image.open(io.BytesIO(files["h.png"]))
    assert img.mode.startswith("I;16") or img.mode == "I"
    arr = np.asarray(img).astype(np.int64)
    assert arr.shape == (30, 40) and arr.max() == 65535 and arr.min() == 0
    side = json.loads(files["h.json"])
    back = side["z_min"] + arr / 65535 * (side["z_max"] - side["z_min"])
    np.testing.assert_allclose(np.flipud(back), h, atol=(25 / 65535))
    assert side["units"] == "m" and side["spacing"] == 2.0
    npy = heightmap_npy(g, stem="h")
    np.testing.assert_array_equal(np.flipud(np.load(io.BytesIO(npy["h.npy"]))), h)


def test_png16_refuses_nan_and_layers_need_index():
    g = Grid((3, 3))
    g.add_field("surface__height", np.full((3, 3), np.nan), at="cell")
    with pytest.raises(InputError, match="NaN"):
        heightmap_png16(g, stem="x")
    g.add_field("layer__thickness", np.ones((3, 3, 2)), at="cell")
    with pytest.raises(InputError, match="layer"):
        heightmap_png16(g, stem="x", field="layer__thickness")
    assert "x.png" in heightmap_png16(g, stem="x", field="layer__thickness", layer=1)


def test_colour_png():
    g = Grid((8, 10))
    g.add_field("surface__height", np.arange(80.0).reshape(8, 10), at="cell")
    img = Image.open(io.BytesIO(image_png(g, field="surface__height", cmap="gray")))
    arr = np.asarray(img)
    assert arr.shape == (8, 10, 3) and arr[0, -1, 0] == 255 and arr[-1, 0, 0] == 0  # north up


def _mesh_with_fields():
    tm = trimesh.creation.icosphere(subdivisions=2)
    m = TriMesh.from_trimesh(tm)
    m.add_field("surface__color", np.abs(m.vertex_normals), at="vertex")
    uv = np.tile(np.array([[0.1, 0.1], [0.9, 0.1], [0.5, 0.9]]), (m.n_faces, 1, 1))
    m.add_field("surface__uv", uv, at="face")
    tex = np.zeros((16, 16, 3))
    tex[:8] = [1, 0, 0]
    m.add_field("surface__texture", tex, at="domain")
    return m


def test_obj_with_vertex_colours_loads_in_trimesh(tmp_path):
    m = _mesh_with_fields()
    files = obj_export(m, stem="ball", provenance=PROV, color_field="surface__color")
    for name, data in files.items():
        write(tmp_path / name, data)
    back = trimesh.load(tmp_path / "ball.obj", process=False, force="mesh")
    assert len(back.vertices) == m.n_vertices and len(back.faces) == m.n_faces
    np.testing.assert_allclose(back.vertices, m.vertices, atol=1e-6)
    cols = back.visual.vertex_colors[:, :3] / 255.0
    np.testing.assert_allclose(cols, m["surface__color"], atol=1 / 255 + 1e-3)


def test_obj_with_texture_atlas_loads_in_trimesh(tmp_path):
    m = _mesh_with_fields()
    files = obj_export(m, stem="ball", uv_field="surface__uv", texture_field="surface__texture")
    assert set(files) == {"ball.obj", "ball.mtl", "ball_texture.png"}
    for name, data in files.items():
        write(tmp_path / name, data)
    back = trimesh.load(tmp_path / "ball.obj", process=False, force="mesh")
    assert len(back.faces) == m.n_faces
    assert isinstance(back.visual, trimesh.visual.TextureVisuals)
    assert back.visual.material.image is not None
    assert np.asarray(back.visual.material.image).shape[:2] == (16, 16)


def test_glb_loads_in_trimesh_with_same_counts(tmp_path):
    m = _mesh_with_fields()
    write(tmp_path / "a.glb", glb_export(m, color_field="surface__color", provenance=PROV))
    back = trimesh.load(tmp_path / "a.glb", force="mesh", process=False)
    assert len(back.vertices) == m.n_vertices and len(back.faces) == m.n_faces
    write(tmp_path / "b.glb", glb_export(m, uv_field="surface__uv", texture_field="surface__texture"))
    back = trimesh.load(tmp_path / "b.glb", force="mesh", process=False)
    assert len(back.faces) == m.n_faces
    assert glb_export(m, color_field="surface__color") == glb_export(m, color_field="surface__color")


def test_exporters_refuse_wrong_domain():
    with pytest.raises(InputError):
        polylines_svg(Grid((2, 2)))
    with pytest.raises(InputError):
        obj_export(Grid((2, 2)), stem="x")


def test_write_is_atomic_and_leaves_no_temp(tmp_path, monkeypatch):
    target = tmp_path / "sub" / "f.txt"
    write(target, "old")

    def boom(*a, **k):
        raise OSError("disk full")

    monkeypatch.setattr(os, "replace", boom)
    with pytest.raises(WriteError, match="f.txt: cannot write"):   # one line, the old file kept
        write(target, "new")
    assert target.read_text() == "old"
    assert [p.name for p in target.parent.iterdir()] == ["f.txt"]


def test_preview_png_shows_the_mesh_in_its_colours():
    from procgen.exchange import preview_png

    m = _mesh_with_fields()
    red = np.tile([1.0, 0.0, 0.0], (m.n_vertices, 1))
    m.add_field("surface__red", red, at="vertex")
    img = np.asarray(Image.open(io.BytesIO(preview_png(m, color_field="surface__red", width=200, height=160))))
    assert img.shape == (160, 200, 3)
    covered = np.any(img != 255, axis=2)
    assert 0.2 < covered.mean() < 0.9                            # a sphere in the middle, background around
    assert covered[80, 100] and not covered[2, 2]
    from scipy.ndimage import binary_erosion

    inner = img[binary_erosion(covered, iterations=2)].astype(int)   # skip anti-aliased rims
    assert len(inner) > 1000 and (inner[:, 0] > inner[:, 1] + 30).all() and (inner[:, 1] == inner[:, 2]).all()
    tex = preview_png(m, uv_field="surface__uv", texture_field="surface__texture", width=120, height=90)
    assert Image.open(io.BytesIO(tex)).size == (120, 90)
