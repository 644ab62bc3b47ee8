"""GLB files stand upright where they are opened: glTF is +Y up, procgen's generated meshes are
z-up and scanned ones (Spot, the bunny) y-up, so every GLB writer turns the model's ``up`` axis to
+Y by a rotation (never a mirror: faces keep facing out). Checked on the bytes (trimesh reads
glTF's own frame) and in Blender, which turns +Y into its own +Z."""
from __future__ import annotations

import io

import numpy as np
import pytest
import trimesh

from _blender import run_blender_probe
from procgen.domains import TriMesh
from procgen.errors import InputError
from procgen.exchange.glb import glb_export

EXTENTS = (1.0, 2.0, 3.0)        # x, y, z of a box, the tall side along the model's z


def _box() -> TriMesh:
    box = trimesh.creation.box(extents=EXTENTS)
    return TriMesh(np.asarray(box.vertices, float), np.asarray(box.faces))


def _read(blob: bytes) -> trimesh.Trimesh:
    return trimesh.load(io.BytesIO(blob), file_type="glb", force="mesh", process=False)


@pytest.mark.parametrize("up, gltf_extents", [("z", (1.0, 3.0, 2.0)), ("y", EXTENTS), ("x", (2.0, 1.0, 3.0))])
def test_the_model_up_axis_becomes_gltf_y_by_a_rotation(up, gltf_extents):
    mesh = _read(glb_export(_box(), up=up))
    assert np.allclose(mesh.extents, gltf_extents)
    assert mesh.volume > 0 and np.isclose(mesh.volume, np.prod(EXTENTS))   # outward faces: no mirror


def test_a_bad_up_axis_is_one_line():
    with pytest.raises(InputError, match="up must be x, y or z"):
        glb_export(_box(), up="w")


@pytest.mark.parametrize("recipe, output", [("meshes/plate-4-2", 1), ("demo/basics", 6), ("meshes/plate-5-8", 0)])
def test_a_bad_up_axis_is_refused_at_check(host, recipe, output):
    from procgen.errors import RecipeError
    from procgen.recipes import load_recipe

    with pytest.raises(RecipeError, match=r"option 'up': 'w' is not one of \['x', 'y', 'z'\]"):
        load_recipe(recipe, host, [f"outputs.{output}.options.up=w"])


def test_surface_glb_turns_a_z_up_model_and_leaves_a_y_up_one(host):
    from procgen.recipes import load_recipe
    from procgen.runner import render_output, run
    import dataclasses

    recipe = load_recipe("meshes/plate-4-2", host, ["steps.cells.params.target_cells=3000"])
    corrode = next(i for i, s in enumerate(recipe.steps) if s.rule.name == "layers.corrode")
    recipe = dataclasses.replace(recipe, steps=recipe.steps[:corrode], outputs=[])
    state = run(recipe, host, seed=1, progress=False).state
    spec = next(o for o in load_recipe("meshes/plate-4-2", host).outputs if o.format == "surface_glb")
    blobs = {}
    for up in ("z", "y"):
        spec_up = dataclasses.replace(spec, options={**spec.options, "up": up, "texels": 1})
        blobs[up] = _read(next(iter(render_output(state, spec_up, host, None).values())))
    z, y = blobs["z"].vertices, blobs["y"].vertices
    assert np.allclose(z, np.column_stack([y[:, 0], y[:, 2], -y[:, 1]]))


BLENDER_SCRIPT = """
import sys
import numpy
numpy.bool = bool                     # Debian's Blender 3.4 glTF add-on needs it
import bpy
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=sys.argv[-1])
ob = next(o for o in bpy.data.objects if o.type == "MESH")
print("DIMS", *[round(v, 4) for v in ob.dimensions])
"""


def test_blender_stands_a_z_up_model_upright(tmp_path):
    glb = tmp_path / "box.glb"
    glb.write_bytes(glb_export(_box(), up="z"))
    dims = next(line.split()[1:] for line in run_blender_probe(BLENDER_SCRIPT, glb, tmp_path) if line.startswith("DIMS"))
    assert np.allclose([float(d) for d in dims], EXTENTS, atol=1e-3)


def test_vertex_colours_are_written_linear_as_gltf_reads_them():
    """sRGB mid grey 128 is linear 0.216 (55 of 255); black and white stay; alpha untouched."""
    mesh = _box()
    srgb = np.array([[128, 128, 128], [0, 0, 0], [255, 255, 255], [200, 100, 50]] * 2, float) / 255
    mesh.add_field("surface__color", srgb, at="vertex")
    scene = trimesh.load(io.BytesIO(glb_export(mesh, color_field="surface__color")), file_type="glb", process=False)
    (read,) = scene.geometry.values()
    col = np.asarray(read.visual.vertex_attributes["color"])
    assert col.shape == (8, 4) and np.all(col[:, 3] == 255)
    assert col[:4, :3].tolist() == [[55, 55, 55], [0, 0, 0], [255, 255, 255], [147, 32, 8]]
