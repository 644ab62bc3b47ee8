"""The cell-network GLB shows its cells' colours in Blender (issue 35: every mesh output is a
material a 3-D pipeline takes as it is).  The splats carry per-vertex colours; the GLB's material
(white times COLOR_0) must be wired by Blender's importer to the Principled BSDF's Base Color,
and the colours must be the cells' own."""
from __future__ import annotations

import io

import numpy as np
import trimesh

from _blender import run_blender_probe
from procgen.exchange.glb import SRGB8_TO_LINEAR8
from procgen.testing import run_example

PROBE = """
import numpy; numpy.bool = bool            # Blender 3.4's glTF add-on on Debian's numpy
import bpy, sys
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=sys.argv[-1])
for ob in bpy.data.objects:
    if ob.type == "MESH":
        attrs = [a.name for a in ob.data.color_attributes]
        for slot in ob.material_slots:
            bsdf = next(n for n in slot.material.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
            links = bsdf.inputs["Base Color"].links
            print("BASECOLOR", links[0].from_node.type if links else "unlinked", len(attrs))
"""


def test_cellnet_glb_colours_reach_blenders_base_color(host, tmp_path):
    from procgen_cellnet.exporters import cell_rgb, cellnet_glb

    state = run_example(host.rule("cellnet.seed_colors"), host)
    net = state.get("cells")
    glb = cellnet_glb(net, provenance={"recipe": "pbr-cellnet"})
    (mesh,) = trimesh.load(io.BytesIO(glb), file_type="glb", process=False).geometry.values()
    col = np.asarray(mesh.visual.vertex_attributes["color"])[:, :3]
    # glTF's COLOR_0 is linear: the cells' display (sRGB) colours, linearised
    want = SRGB8_TO_LINEAR8[np.round(cell_rgb(net, "surface__color") * 255).astype(int)]
    # every splat vertex carries its cell's colour (6 vertices a splat, cells in order)
    assert set(map(tuple, col.astype(int))) <= set(map(tuple, want.astype(int)))
    assert len(np.unique(col, axis=0)) > 3                          # several seed colours
    path = tmp_path / "cells.glb"
    path.write_bytes(glb)
    lines = [ln.split()[1:] for ln in run_blender_probe(PROBE, path, tmp_path) if ln.startswith("BASECOLOR")]
    assert lines and all(node == "VERTEX_COLOR" and int(n) >= 1 for node, n in lines), lines
