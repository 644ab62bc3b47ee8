"""Compact GLB geometry (procgen/exchange/gltf_compact.py) reads back as the mesh it came from.

Why: 8-bit normals and 16-bit indices shrink the gallery's GLB geometry, but a stride off by a
byte, a view left at its old offset or a normal written unnormalised would give a file that
loads and looks wrong.  What must hold, read back by trimesh (its scene geometry, untransformed)
and by an independent decode of the accessors: positions and faces identical, normals within the
8-bit angle, the extension declared, and a file with nothing left to gain kept byte for byte.
"""
from __future__ import annotations

import io

import numpy as np
import trimesh

from procgen.domains import TriMesh
from procgen.exchange.gltf_compact import INT8, UINT16, quantize_glb, read_glb


def _mesh(subdivisions: int) -> TriMesh:
    sphere = trimesh.creation.icosphere(subdivisions)
    v = sphere.vertices * [3.0, 1.0, 0.5] + [10.0, -4.0, 2.0]        # off-centre, unequal extents
    return TriMesh(np.asarray(v, float), np.asarray(sphere.faces))


def _plain(tm: TriMesh) -> bytes:
    """The GLB trimesh writes (z-up turned to +Y as glb_export does), before quantising."""
    from procgen.exchange.glb import TO_GLTF_UP
    mesh = trimesh.Trimesh(tm.vertices.copy(), tm.faces.copy(), process=False)
    mesh.apply_transform(TO_GLTF_UP["z"])
    assert mesh.vertex_normals.shape == mesh.vertices.shape     # computed, so trimesh writes NORMAL
    return trimesh.Scene(mesh).export(file_type="glb")


def _load(blob: bytes) -> trimesh.Trimesh:
    scene = trimesh.load(io.BytesIO(blob), file_type="glb", process=False)
    return next(iter(scene.geometry.values()))        # as stored, no node transform applied


def test_positions_faces_and_normals_survive_quantisation():
    tm = _mesh(4)
    plain = _plain(tm)
    small = quantize_glb(plain)
    assert len(small) < 0.75 * len(plain)
    a, b = _load(plain), _load(small)
    assert np.array_equal(a.vertices, b.vertices) and np.array_equal(a.faces, b.faces)
    # trimesh reads the int8 normals as integers (it ignores ``normalized``): 127 long, same direction
    nb = b.vertex_normals / np.linalg.norm(b.vertex_normals, axis=1, keepdims=True)
    assert np.degrees(np.arccos(np.clip((nb * a.vertex_normals).sum(1), -1, 1))).max() < 0.7
    tree, blob = read_glb(small)
    prim = tree["meshes"][0]["primitives"][0]
    acc = tree["accessors"]
    assert acc[prim["indices"]]["componentType"] == UINT16                 # 2,562 vertices fit
    assert "KHR_mesh_quantization" in tree["extensionsRequired"]
    # the normals decoded by hand from their int8 view (stride 4) against the float ones
    n_acc = acc[prim["attributes"]["NORMAL"]]
    assert n_acc["componentType"] == INT8 and n_acc["normalized"]
    view = tree["bufferViews"][n_acc["bufferView"]]
    assert view["byteStride"] == 4 and view["byteOffset"] % 4 == 0
    raw = np.frombuffer(blob[view["byteOffset"]:view["byteOffset"] + view["byteLength"]], np.int8)
    got = raw.reshape(-1, 4)[:, :3] / 127.0
    tree0, blob0 = read_glb(plain)
    a0 = tree0["accessors"][tree0["meshes"][0]["primitives"][0]["attributes"]["NORMAL"]]
    v0 = tree0["bufferViews"][a0["bufferView"]]
    want = np.frombuffer(blob0[v0.get("byteOffset", 0):v0.get("byteOffset", 0) + v0["byteLength"]], "<f4")
    want = want.reshape(-1, 3)
    cos = (got * want).sum(1) / np.linalg.norm(got, axis=1)
    assert np.degrees(np.arccos(np.clip(cos, -1, 1))).max() < 0.7


def test_big_meshes_keep_32_bit_indices():
    tm = _mesh(7)                                                          # 163,842 vertices
    tree, _ = read_glb(quantize_glb(_plain(tm)))
    prim = tree["meshes"][0]["primitives"][0]
    assert tree["accessors"][prim["indices"]]["componentType"] == 5125
    assert tree["accessors"][prim["attributes"]["NORMAL"]]["componentType"] == INT8


def test_a_compacted_file_is_left_byte_for_byte():
    small = quantize_glb(_plain(_mesh(2)))
    assert quantize_glb(small) == small
