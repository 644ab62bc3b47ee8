"""PBR material sets of the mesh exporters (issue 35): what the maps hold, read back the way a
3-D pipeline reads them (trimesh, PIL, Blender 3.4 headless).

Small meshes only: a flat square of cells, an icosphere; the Blender part imports two GLBs.
"""
from __future__ import annotations

import io
import json
from pathlib import Path

import numpy as np
import pytest
import trimesh
from PIL import Image

from _blender import run_blender_probe
from procgen import State
from procgen_layers.bake import bake_stack
from procgen_layers.materials import PRESETS, parse_materials
from procgen_layers.rules import cell_stack_colors
from procgen_layers.stack import put_thickness, store_table
from procgen_surface.domain import SurfaceCells
from procgen_surface.exporters import coverage_png, surface_glb, surface_obj, surface_png
from procgen_surface.shading import lobe_colors

PROV = {"recipe": "pbr-test", "seed": 7}


def square(size: float = 0.05) -> SurfaceCells:
    v = np.array([[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0]], float)
    return SurfaceCells.from_mesh(v, np.array([[0, 1, 2], [0, 2, 3]]), cell_size=size)


def copper_patina(sc: SurfaceCells) -> np.ndarray:
    """Copper under patina; the patina only where x > 0 (so x < 0 is bare copper)."""
    table = parse_materials(["copper", "patina"])
    store_table(sc, table)
    patina = sc.center3d[:, 0] > 0
    put_thickness(sc, np.column_stack([np.full(sc.n_cells, 0.3), np.where(patina, 1.5, 0.0)]), table)
    bake_stack(sc, table)                     # as every layers rule does after changing the stack
    return patina


def load_glb(data: bytes) -> trimesh.Trimesh:
    return trimesh.load(io.BytesIO(data), file_type="glb", process=False, force="mesh")


def texel_at(img: np.ndarray, uv: np.ndarray) -> np.ndarray:
    h, w = img.shape[:2]
    x = np.clip((uv[:, 0] * w).astype(int), 0, w - 1)
    y = np.clip(((1.0 - uv[:, 1]) * h).astype(int), 0, h - 1)
    return img[y, x]


def test_stack_bake_reproduces_the_layered_phong_exactly():
    """The baked lobes (procgen_layers.bake) lit for a camera equal the layers' own shading."""
    sc = SurfaceCells.from_mesh(*(lambda m: (m.vertices, m.faces))(trimesh.creation.icosphere(2)),
                                cell_size=0.08)
    copper_patina(sc)
    light, eye = np.array([0.3, -0.5, 0.8]), np.array([0.6, 0.2, 0.77])
    light, eye = light / np.linalg.norm(light), eye / np.linalg.norm(eye)
    want = cell_stack_colors(sc, lit=True, light=light, eye=eye)
    np.testing.assert_allclose(lobe_colors(sc, light=light, eye=eye), want, atol=1e-12)
    assert np.ptp(want, axis=0).max() > 0.2                # copper and patina look different


def test_glb_is_a_metallic_roughness_material_copper_metal_patina_not():
    sc = square()
    patina = copper_patina(sc)
    mesh = load_glb(surface_glb(sc, provenance=PROV, exaggerate=0.0))
    mat = mesh.visual.material
    assert isinstance(mat, trimesh.visual.material.PBRMaterial)
    for tex in (mat.baseColorTexture, mat.metallicRoughnessTexture, mat.occlusionTexture):
        assert tex is not None
    orm = np.asarray(mat.metallicRoughnessTexture.convert("RGB"), float) / 255.0
    face_uv = np.asarray(mesh.visual.uv)[mesh.faces].mean(axis=1)
    cen = mesh.triangles_center
    x_cell = cen[:, 0]
    metal = texel_at(orm, face_uv)[:, 2]
    rough = texel_at(orm, face_uv)[:, 1]
    cu = x_cell < -0.05
    pa = x_cell > 0.05
    assert cu.sum() > 20 and pa.sum() > 20 and patina.any()
    assert metal[cu].min() > 0.95 and metal[pa].max() < 0.05          # copper bare, patina dielectric
    np.testing.assert_allclose(rough[cu], PRESETS["copper"].pbr_roughness, atol=0.01)
    assert rough[pa].min() > 0.7                                       # patina 0.8 under a thin mix


def uv_tangent_frames(mesh: trimesh.Trimesh) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per face (T, B, N): dP/du and dP/dv from corner positions and UVs (as MikkTSpace does)."""
    p = mesh.vertices[mesh.faces]
    uv = np.asarray(mesh.visual.uv)[mesh.faces]
    e1, e2 = p[:, 1] - p[:, 0], p[:, 2] - p[:, 0]
    d1, d2 = uv[:, 1] - uv[:, 0], uv[:, 2] - uv[:, 0]
    det = d1[:, 0] * d2[:, 1] - d2[:, 0] * d1[:, 1]
    t = (e1 * d2[:, 1:2] - e2 * d1[:, 1:2]) / det[:, None]
    b = (e2 * d1[:, 0:1] - e1 * d2[:, 0:1]) / det[:, None]
    n = np.cross(e1, e2)
    n *= np.sign(n[:, 2:3])
    unit = lambda a: a / np.linalg.norm(a, axis=1, keepdims=True)          # noqa: E731
    return unit(t), unit(b), unit(n)


@pytest.mark.parametrize("convention", ["opengl", "directx"])
def test_decoded_normal_map_matches_the_relief_gradient(convention, tmp_path):
    """A ramp relief h = a x: every texel's decoded normal, in the UV tangent frame of its face,
    is the ramp's normal (-a, 0, 1)/|.| in world space; the DirectX map flips green."""
    sc = square(0.04)
    a = 0.3
    sc.add_field("bake__relief", a * sc.center3d[:, 0], at="cell", units="length")
    files = surface_obj(sc, stem="ramp", provenance=PROV, exaggerate=0.0, texels=4,
                        normal_convention=convention)
    assert {"ramp.obj", "ramp.mtl", "ramp_texture.png", "ramp_orm.png", "ramp_normal.png",
            "ramp_height.png", "ramp_roughness.png", "ramp_metallic.png"} <= set(files)
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    mesh = trimesh.load(tmp_path / "ramp.obj", process=False, force="mesh")
    nmap = np.asarray(Image.open(io.BytesIO(files["ramp_normal.png"])).convert("RGB"), float) / 127.5 - 1.0
    t, b, n = uv_tangent_frames(mesh)
    face_uv = np.asarray(mesh.visual.uv)[mesh.faces].mean(axis=1)
    c = texel_at(nmap, face_uv)
    if convention == "directx":
        c[:, 1] *= -1
    world = c[:, :1] * t + c[:, 1:2] * b + c[:, 2:3] * n
    world /= np.linalg.norm(world, axis=1, keepdims=True)
    want = np.array([-a, 0.0, 1.0]) / np.hypot(a, 1.0)
    inner = np.all(np.abs(mesh.triangles_center[:, :2]) < 0.4, axis=1)     # away from the rim
    assert inner.sum() > 50
    err = np.degrees(np.arccos(np.clip(world[inner] @ want, -1, 1)))
    assert np.median(err) < 2.0 and np.percentile(err, 95) < 6.0
    flat = np.degrees(np.arccos(np.clip(n[inner] @ want, -1, 1)))
    assert flat.min() > 10                                 # the mesh itself is flat: the map tilts
    h = Image.open(io.BytesIO(files["ramp_height.png"]))
    assert np.asarray(h).dtype == np.uint16 or h.mode.startswith("I;16")
    scale = json.loads(h.text["height_max"]) - json.loads(h.text["height_min"])
    assert scale == pytest.approx(a * np.ptp(sc.center3d[:, 0]), rel=0.05)
    mtl = files["ramp.mtl"].decode()
    assert "map_Pr ramp_roughness.png" in mtl and "map_Pm ramp_metallic.png" in mtl
    assert "map_Bump -bm 1.0 ramp_normal.png" in mtl


def test_every_png_exporter_of_the_family_carries_provenance():
    from procgen import Polylines
    from procgen.domains import TriMesh
    from procgen.exchange import preview_png

    sc = square(0.1)
    copper_patina(sc)
    log = Polylines.from_list([[[0, 0.0], [1, 50.0], [2, 100.0]]])
    m = trimesh.creation.icosphere(1)
    pngs = {"surface_png": surface_png(sc, provenance=PROV, width=80, height=60),
            "coverage_png": coverage_png(log, provenance=PROV),
            "preview_png": preview_png(TriMesh(np.asarray(m.vertices), np.asarray(m.faces)),
                                       provenance=PROV, width=80, height=60, edges=True)}
    for name, data in pngs.items():
        assert json.loads(Image.open(io.BytesIO(data)).text["procgen"]) == PROV, name


def test_fast_obj_rows_read_back_as_the_numbers_written():
    from procgen.exchange.obj import _rows, unique_rows

    rng = np.random.default_rng(5)
    x = np.concatenate([rng.normal(0, 3, (500, 3)), [[-1e-9, 0.0, 1234.5678905]]])
    back = np.loadtxt(io.StringIO(_rows("v", x, 6).replace("v ", "")))
    np.testing.assert_allclose(back, x, atol=5.1e-7)
    assert _rows("f", np.array([[1, 20], [300, 4]]), 0, "/ ") == "f 1/20\nf 300/4\n"
    a = rng.integers(0, 4, (300, 3))
    u, inv = unique_rows(a)
    want_u, want_inv = np.unique(a, axis=0, return_inverse=True)
    np.testing.assert_array_equal(u, want_u)
    np.testing.assert_array_equal(inv, want_inv.ravel())


BLENDER_SCRIPT = """
import numpy; numpy.bool = bool            # Blender 3.4's glTF add-on on Debian's numpy
import bpy, sys
bpy.ops.wm.read_factory_settings(use_empty=True)
bpy.ops.import_scene.gltf(filepath=sys.argv[-1])
def source(socket):
    if not socket.links:
        return "unlinked"
    node = socket.links[0].from_node
    while node.type not in ("TEX_IMAGE", "VERTEX_COLOR"):
        ins = [i for i in node.inputs if i.links]
        if not ins:
            return node.type
        node = ins[-1].links[0].from_node
    return node.type
for ob in bpy.data.objects:
    if ob.type == "MESH":
        for slot in ob.material_slots:
            bsdf = next(n for n in slot.material.node_tree.nodes if n.type == "BSDF_PRINCIPLED")
            for name in ("Base Color", "Metallic", "Roughness", "Normal"):
                print("PBR", name, source(bsdf.inputs[name]))
"""


def blender_sockets(glb: Path, tmp_path: Path) -> dict[str, str]:
    lines = run_blender_probe(BLENDER_SCRIPT, glb, tmp_path, "probe_pbr.py")
    rows = [line.split()[1:] for line in lines if line.startswith("PBR ")]
    return {" ".join(row[:-1]): row[-1] for row in rows}


def cracked_state() -> State:
    from procgen_cracks.bake import CrackBake
    from procgen_cracks.render_rules import DrawCracks, RenderCracks
    from procgen_surface.bake import BakeAtlas

    state = State(seed=3)
    sc = square(0.05)
    table = parse_materials(["copper", {"preset": "glaze", "opacity": 0.9}])
    store_table(sc, table)
    put_thickness(sc, np.tile([0.3, 1.0], (sc.n_cells, 1)), table)
    state.add_domain("cells", sc)
    DrawCracks(lines=[[-0.45, -0.3, 0.06, 0.45, 0.35, 0.06]]).step(state)
    RenderCracks(k=4, profile="v_linear").step(state)
    CrackBake().step(state)
    BakeAtlas().step(state)
    return state


def test_cracked_mesh_bakes_once_and_the_crack_shows_the_metal():
    from procgen_cracks.exporters import crack_glb, crack_obj

    sc = cracked_state().get("cells")
    assert sc["atlas__color"].dtype == np.uint8 and "atlas__normal" in sc
    glb = crack_glb(sc, provenance=PROV, exaggerate=0.0)
    mat = load_glb(glb).visual.material
    orm = np.asarray(mat.metallicRoughnessTexture.convert("RGB"))
    assert orm[..., 2].max() > 240 and orm[..., 2].min() < 15       # copper in the crack, glaze over it
    files = crack_obj(sc, stem="c", provenance=PROV, exaggerate=0.0)
    obj_atlas = np.asarray(Image.open(io.BytesIO(files["c_texture.png"])).convert("RGB"), int)
    glb_atlas = np.asarray(load_glb(glb).visual.material.baseColorTexture.convert("RGB"), int)
    assert glb_atlas.shape == obj_atlas.shape                       # one atlas, every format:
    assert np.abs(glb_atlas - obj_atlas).mean() < 1.5               # equal up to the GLB's JPEG error


def test_blender_finds_base_color_metallic_roughness_and_normal_as_textures(tmp_path):
    sc = SurfaceCells.from_mesh(*(lambda m: (m.vertices, m.faces))(trimesh.creation.icosphere(2)),
                                cell_size=0.08)
    copper_patina(sc)
    sc.add_field("bake__relief", 0.02 * np.sin(8 * sc.center3d[:, 0]), at="cell", units="length")
    cup = tmp_path / "sphere.glb"
    cup.write_bytes(surface_glb(sc, provenance=PROV))
    from procgen_cracks.exporters import crack_glb

    cracked = tmp_path / "cracked.glb"
    cracked.write_bytes(crack_glb(cracked_state().get("cells"), provenance=PROV, exaggerate=0.0))
    want = {"Base Color": "TEX_IMAGE", "Metallic": "TEX_IMAGE", "Roughness": "TEX_IMAGE",
            "Normal": "TEX_IMAGE"}
    assert blender_sockets(cup, tmp_path) == want
    assert blender_sockets(cracked, tmp_path) == want


def ramp_terrain() -> "Grid":
    """A 40 x 30 grid: a two-layer stack (rock under soil) on a tilted plane h = 0.2 x + 0.1 y."""
    from procgen.domains import Grid
    from procgen_layers.rules import Shade

    g = Grid((30, 40), spacing=0.5)
    xx, yy = np.meshgrid(g.x, g.y)
    g.add_field("surface__height", 0.2 * xx + 0.1 * yy, at="cell", units="length")
    table = parse_materials(["rock", "soil"])
    store_table(g, table)
    put_thickness(g, np.column_stack([np.ones(g.n_cells), (xx.ravel() > 10).astype(float)]), table)
    state = State(seed=1)
    state.add_domain("terrain", g)
    Shade(cells="terrain").step(state)
    return g


@pytest.mark.parametrize("convention", ["opengl", "directx"])
def test_terrain_normal_map_decodes_to_the_height_gradient(convention):
    from procgen_layers.terrain_export import terrain_maps

    files = terrain_maps(ramp_terrain(), stem="t", provenance=PROV, normal_convention=convention)
    assert {"t_normal.png", "t_splat.png"} <= set(files)
    n = np.asarray(Image.open(io.BytesIO(files["t_normal.png"])).convert("RGB"), float) / 127.5 - 1.0
    n = np.flipud(n)                                            # north-up image -> rows of y
    if convention == "directx":
        n[..., 1] *= -1
    want = np.array([-0.2, -0.1, 1.0]) / np.linalg.norm([-0.2, -0.1, 1.0])
    assert np.abs(n - want).max() < 0.01
    splat = Image.open(io.BytesIO(files["t_splat.png"]))
    assert splat.text["procgen_channels"] == "rock,soil"
    s = np.flipud(np.asarray(splat.convert("RGBA"), float) / 255.0)
    assert s[:, :15, 0].min() > 0.99 and s[:, 25:, 1].min() > 0.9    # rock bare west, soil east


def test_terrain_glb_in_blender_has_colour_orm_and_normal_textures(tmp_path):
    from procgen_layers.terrain_export import terrain_glb

    glb = tmp_path / "terrain.glb"
    glb.write_bytes(terrain_glb(ramp_terrain(), provenance=PROV, mesh_step=5))
    mat = load_glb(glb.read_bytes()).visual.material
    assert mat.normalTexture is not None and mat.metallicRoughnessTexture is not None
    want = {"Base Color": "TEX_IMAGE", "Metallic": "TEX_IMAGE", "Roughness": "TEX_IMAGE",
            "Normal": "TEX_IMAGE"}
    assert blender_sockets(glb, tmp_path) == want
