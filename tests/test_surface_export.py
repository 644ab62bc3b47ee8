"""Exports (OBJ/MTL/atlas, GLB, preview, coverage) and end-to-end recipes of the surface family."""
from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest
import trimesh
from PIL import Image

from procgen import RecipeError, State, load_recipe, run
from procgen_surface.domain import SurfaceCells
from procgen_surface.export_mesh import displaced_mesh, obj_files, pack_atlas
from procgen.exchange.preview import render_mesh_png
from procgen_surface.primitives import cup, lattice
from procgen_layers.materials import parse_materials
from procgen_layers.rules import cell_stack_colors
from procgen_layers.stack import put_thickness, store_table

ROOT = Path(__file__).resolve().parents[1]


def sphere_cells(level: int = 2, s: float = 0.04) -> SurfaceCells:
    m = trimesh.creation.icosphere(subdivisions=level)
    return SurfaceCells.from_mesh(np.asarray(m.vertices), np.asarray(m.faces), cell_size=s)


def test_primitives_are_closed_and_outward():
    for v, f in (cup(sections=16, rings=5), lattice((2, 2, 1), 3)):
        tm = trimesh.Trimesh(v, f, process=False)
        assert tm.is_watertight and tm.is_winding_consistent and tm.volume > 0


def test_displaced_mesh_is_watertight_and_offset_by_the_stack():
    sc = sphere_cells()
    h = np.full(sc.n_cells, 0.5)
    rgb = np.tile([0.2, 0.4, 0.6], (sc.n_cells, 1))
    alive = np.ones(sc.n_cells, bool)
    atlas = pack_atlas(sc, rgb, alive, texels=2)
    dm = displaced_mesh(sc, h, rgb, alive, atlas, level=6, exaggerate=0.1)
    tm = trimesh.Trimesh(dm.vertices, dm.faces, process=False)
    assert tm.is_watertight
    # a rough, random stack: shared edge vertices average both sides, so still no cracks
    rough = np.random.default_rng(0).random(sc.n_cells)
    dm2 = displaced_mesh(sc, rough, rgb, alive, atlas, level=5, exaggerate=0.1)
    tm2 = trimesh.Trimesh(dm2.vertices, dm2.faces, process=False)
    assert tm2.is_watertight and tm2.is_winding_consistent
    # every input vertex reappears moved by 0.5 * 0.1 along its (area-weighted) vertex normal
    assert len(dm.faces) == 36 * len(sc.faces)
    from scipy.spatial import cKDTree
    from procgen.geometry import vertex_normals
    want = sc.vertices + 0.05 * vertex_normals(sc.vertices, sc.faces)
    d, _ = cKDTree(dm.vertices).query(want)
    assert d.max() < 1e-9
    r = np.linalg.norm(dm.vertices, axis=1)
    assert np.all(r > 0.98) and np.all(r < 1.0501)
    # texture: every corner UV maps into the atlas onto a texel of its face's cell colour
    img = atlas.image
    uv = dm.corner_uv.reshape(-1, 2)
    assert np.all((uv >= 0) & (uv <= 1))
    px = np.clip((uv[:, 0] * img.shape[1]).astype(int), 0, img.shape[1] - 1)
    py = np.clip(((1 - uv[:, 1]) * img.shape[0]).astype(int), 0, img.shape[0] - 1)
    np.testing.assert_allclose(img[py, px, :3], np.tile([0.2, 0.4, 0.6], (len(uv), 1)), atol=1e-12)


def test_holes_are_cut_out_of_the_mesh_and_the_atlas():
    sc = sphere_cells()
    alive = sc.center3d[:, 2] < 0.5                     # remove a cap
    rgb = np.full((sc.n_cells, 3), 0.5)
    atlas = pack_atlas(sc, rgb, alive)
    dm = displaced_mesh(sc, np.zeros(sc.n_cells), rgb, alive, atlas, level=8)
    cen = dm.vertices[dm.faces].mean(axis=1)
    assert cen[:, 2].max() < 0.55 and cen[:, 2].min() < -0.9
    assert not trimesh.Trimesh(dm.vertices, dm.faces, process=False).is_watertight
    assert np.all(alive[dm.face_cell])
    a = atlas.image[..., 3]
    assert (a == 0).any() and (a == 1).any()


def test_obj_and_glb_load_back_with_the_expected_counts(tmp_path):
    sc = sphere_cells(1, 0.08)
    rgb = np.random.default_rng(0).random((sc.n_cells, 3))
    alive = np.ones(sc.n_cells, bool)
    atlas = pack_atlas(sc, rgb, alive)
    dm = displaced_mesh(sc, np.zeros(sc.n_cells), rgb, alive, atlas, level=3)
    files = obj_files(dm, atlas, name="s")
    for k, b in files.items():
        (tmp_path / k).write_bytes(b)
    assert set(files) == {"s.obj", "s.mtl", "s_texture.png"}
    tm = trimesh.load(tmp_path / "s.obj", process=False, force="mesh")
    assert len(tm.faces) == len(dm.faces)
    assert tm.visual.kind == "texture" and tm.visual.uv is not None
    lines = files["s.obj"].decode().splitlines()
    assert sum(l.startswith("v ") for l in lines) == len(dm.vertices)
    assert sum(l.startswith("f ") for l in lines) == len(dm.faces)
    assert "map_Kd s_texture.png" in files["s.mtl"].decode()
    from procgen_surface.export_mesh import glb_bytes
    g = trimesh.load(io.BytesIO(glb_bytes(dm, atlas)), file_type="glb", force="mesh")
    assert len(g.faces) == len(dm.faces)


def test_shading_single_layer_and_opaque_top():
    sc = sphere_cells(1, 0.1)
    table = parse_materials(["copper", "patina"])
    store_table(sc, table)
    t = np.zeros((sc.n_cells, 2))
    t[:, 0] = 1.0
    put_thickness(sc, t, table)
    rgb = cell_stack_colors(sc, lit=False, light=np.zeros(3), eye=np.zeros(3))
    np.testing.assert_allclose(rgb, np.tile(table[0].color, (sc.n_cells, 1)), atol=1e-12)
    t[:, 1] = 50.0                                      # thick, fairly opaque patina hides copper
    put_thickness(sc, t, table)
    rgb = cell_stack_colors(sc, lit=False, light=np.zeros(3), eye=np.zeros(3))
    np.testing.assert_allclose(rgb, np.tile(table[1].color, (sc.n_cells, 1)), atol=1e-6)


def test_preview_renders_something_like_the_mesh():
    v, f = cup(sections=16, rings=4)
    png = render_mesh_png(trimesh.Trimesh(v, f, process=False), (160, 120))
    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))
    assert img.shape == (120, 160, 3)
    covered = np.any(img < 250, axis=2).mean()
    assert 0.2 < covered < 0.9


SMALL = """
[recipe]
name = "tiny-patina"
seed = 4

[[steps]]
rule = "surface.cup"
params = { sections = 10, rings = 3 }

[[steps]]
rule = "surface.cells"
params = { target_cells = 6000 }

[[steps]]
rule = "layers.stack"
params = { layers = [ { preset = "copper", thickness = 0.3, noise = 0.05 }, { preset = "patina", thickness = 0.0 } ] }

[[steps]]
rule = "layers.corrode"
iterations = 60
params = { k1 = 0.01, seed_rate = 0.001, b0 = 1.3 }
frames = { every = 30, domain = "cells", format = "surface_png", options = { width = 120, height = 100 } }

[[steps]]
rule = "layers.shade"

[[outputs]]
domain = "cells"
format = "surface_obj"
file = "cup.obj"

[[outputs]]
domain = "cells"
format = "surface_glb"
file = "cup.glb"

[[outputs]]
domain = "coverage"
format = "coverage_png"
file = "coverage.png"
"""


def run_small(host, tmp_path: Path, name: str):
    p = tmp_path / f"{name}.toml"
    p.write_text(SMALL)
    return run(load_recipe(p, host), host, out_dir=tmp_path / name, progress=False, save_state=True)


def test_recipe_end_to_end_is_deterministic_and_readable(host, tmp_path):
    a = run_small(host, tmp_path, "a")
    b = run_small(host, tmp_path, "b")
    for f in ("cup.obj", "cup.mtl", "cup_texture.png", "coverage.png", "frames/step3/frame_0030.png"):
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes(), f
    st = State.load(tmp_path / "a" / "state.npz")
    sc = st.get("cells", SurfaceCells)
    status = sc["corrosion__state"]
    t = sc["layers__thickness"]
    assert np.array_equal(status == 2, t[:, 0] <= 0)
    assert (status == 2).any() and (status == 1).any()
    assert np.all(t[:, 1] <= 1.0 + 1e-12)
    tm = trimesh.load(tmp_path / "a" / "cup.obj", force="mesh", process=False)
    assert tm.visual.kind == "texture" and len(tm.faces) > 100
    g = trimesh.load(tmp_path / "a" / "cup.glb", force="mesh")
    assert len(g.faces) == len(tm.faces)
    info = json.loads((tmp_path / "a" / "run.json").read_text())
    assert info["reports"]["cells.n_cells"] == sc.n_cells
    cov = st.get("coverage")
    assert np.all(np.diff(cov.line(0)[:, 1]) >= -1e-12)


def test_bad_recipe_parameters_are_refused(host, tmp_path):
    p = tmp_path / "bad.toml"
    p.write_text(SMALL.replace("target_cells = 6000", "target_cells = 6000, k = 3"))
    with pytest.raises(Exception, match="exactly one"):
        load_recipe(p, host)
    p.write_text(SMALL.replace('{ preset = "patina", thickness = 0.0 }', '{ preset = "patina", thikness = 0.0 }'))
    with pytest.raises(RecipeError, match=r"steps\[2\] \(layers.stack\).*thikness"):
        load_recipe(p, host)            # refused by procgen check, before any compute


def test_vertex_colour_and_untextured_exports():
    from procgen_surface.exporters import surface_glb, surface_obj
    sc = sphere_cells(1, 0.08)
    sc.add_field("surface__color", np.tile([1.0, 0.0, 0.0], (sc.n_cells, 1)), at="cell")
    files = surface_obj(sc, stem="v", vertex_colors=True, textured=False)
    assert set(files) == {"v.obj"}     # no material: readers then keep the vertex colours
    rows = [l.split() for l in files["v.obj"].decode().splitlines() if l.startswith("v ")]
    assert all(len(r) == 7 and r[4:] == ["1.0000", "0.0000", "0.0000"] for r in rows)
    back = trimesh.load(io.BytesIO(files["v.obj"]), file_type="obj", force="mesh", process=False)
    assert np.all(np.asarray(back.visual.vertex_colors)[:, :3] == [255, 0, 0])
    (g,) = trimesh.load(io.BytesIO(surface_glb(sc, textured=False)), file_type="glb").geometry.values()
    assert g.visual.material.name == "vertex_colours"     # a material that shows them (Blender)
    assert np.all(np.asarray(g.visual.vertex_attributes["color"])[:, :3] == [255, 0, 0])


def test_saved_state_loads_after_plugin_discovery_alone(host, tmp_path):
    """The SurfaceCells kind is registered when the plugin loads, not when a rule is used."""
    import subprocess
    import sys
    run_small(host, tmp_path, "c")
    code = ("from procgen import get_plugin_manager, State; get_plugin_manager(); "
            f"s = State.load({str(tmp_path / 'c' / 'state.npz')!r}); "
            "from procgen_layers.stack import load_table; "
            "print(s.domains['cells'].kind, load_table(s.domains['cells']).names)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["SurfaceCells", "('copper',", "'patina')"]
