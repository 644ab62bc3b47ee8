"""Mesh outputs show their colours in Blender with no hand-work (Debian's blender, headless).

A GLB whose colours are per vertex must carry a material whose Base Color reads them: without
one, Blender's default material hides the colours and the mesh imports plain grey.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import trimesh

from _blender import run_blender_probe
from procgen.cli import main

BLENDER_SCRIPT = """
import numpy; numpy.bool = bool            # Blender 3.4's glTF add-on on Debian's numpy
import bpy, sys
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=sys.argv[-1])
for ob in bpy.data.objects:
    if ob.type == "MESH":
        for slot in ob.material_slots:
            bsdf = next(n for n in slot.material.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
            links = bsdf.inputs["Base Color"].links
            print("BASECOLOR", slot.material.name, links[0].from_node.type if links else "unlinked")
"""


def _blender_base_colours(glb, tmp_path) -> list[str]:
    lines = run_blender_probe(BLENDER_SCRIPT, glb, tmp_path)
    return [line.split(maxsplit=1)[1] for line in lines if line.startswith("BASECOLOR")]


def test_vertex_coloured_terrain_glb_shows_its_colours_in_blender(tmp_path):
    out = tmp_path / "basics"
    assert main(["run", "demo/basics", "--out", str(out), "--progress", "off"]) == 0
    glb = out / "terrain.glb"
    (mesh,) = trimesh.load(glb).geometry.values()
    assert mesh.visual.material is not None
    colours = np.asarray(mesh.visual.vertex_attributes["color"])
    assert colours.shape[0] == len(mesh.vertices) and colours[:, :3].std() > 20   # heights as colours
    assert _blender_base_colours(glb, tmp_path) == ["vertex_colours VERTEX_COLOR"]


def test_an_uncoloured_glb_still_imports_with_a_material(tmp_path):
    from procgen.domains import TriMesh
    from procgen.exchange import glb_export

    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], float)
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    glb = tmp_path / "tet.glb"
    glb.write_bytes(glb_export(TriMesh(v, f)))
    assert _blender_base_colours(glb, tmp_path) == ["plain unlinked"]
