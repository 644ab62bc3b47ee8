"""Smaller GLB geometry: 8-bit normals and 16-bit indices where they fit.

Why: the gallery's meshes are mostly geometry (154 of 212 MB of GLB), stored by trimesh as
32-bit floats and 32-bit indices.  glTF's KHR_mesh_quantization extension (what gltfpack does by
default) lets a normal be an 8-bit normalised integer; Blender's importer, three.js /
model-viewer and Babylon read it.  Only what every reader, trimesh included, still reads right
is changed here:

- normals as normalised int8, unit length to 1/127 (under half a degree). trimesh ignores the
  ``normalized`` flag and reads the integers: the direction is right, the length 127 (its
  ``force="mesh"`` load re-normalises them; a scene's raw geometry does not).
- triangle indices as uint16 when the primitive has at most 65,535 vertices (core glTF).

Positions stay 32-bit floats: quantised positions need the node's matrix to scale them back,
and trimesh hands a scene's geometry out untransformed, so a user reading
``scene.geometry`` would get integers.  Texture coordinates stay floats for the same reason
(quantised UVs need ``normalized``).  The binary chunk is rebuilt with 4-byte alignment.
"""
from __future__ import annotations

import json
import struct
from typing import Any

import numpy as np

FLOAT, INT8, UINT16, UINT32 = 5126, 5120, 5123, 5125
_GLB_MAGIC, _JSON, _BIN = 0x46546C67, 0x4E4F534A, 0x004E4942
_EXT = "KHR_mesh_quantization"


def _pad(b: bytes, fill: bytes = b"\x00") -> bytes:
    return b + fill * (-len(b) % 4)


def read_glb(data: bytes) -> tuple[dict[str, Any], bytes]:
    """The JSON and binary chunks of a GLB."""
    magic, _version, _length = struct.unpack_from("<III", data, 0)
    if magic != _GLB_MAGIC:
        raise ValueError("not a GLB")
    n, kind = struct.unpack_from("<II", data, 12)
    tree = json.loads(data[20:20 + n])
    binary = b""
    if 20 + n < len(data):
        m, kind = struct.unpack_from("<II", data, 20 + n)
        binary = data[28 + n:28 + n + m]
    return tree, binary


def write_glb(tree: dict[str, Any], binary: bytes) -> bytes:
    """A GLB from a JSON tree and its binary chunk (padded as the format requires)."""
    js = _pad(json.dumps(tree, separators=(",", ":"), sort_keys=True).encode(), b" ")
    binary = _pad(binary)
    body = struct.pack("<II", len(js), _JSON) + js
    if binary:
        body += struct.pack("<II", len(binary), _BIN) + binary
    return struct.pack("<III", _GLB_MAGIC, 2, 12 + len(body)) + body


def _view_bytes(tree: dict[str, Any], binary: bytes, index: int) -> bytes:
    v = tree["bufferViews"][index]
    start = v.get("byteOffset", 0)
    return binary[start:start + v["byteLength"]]


def _accessor_array(tree: dict[str, Any], binary: bytes, index: int) -> np.ndarray:
    a = tree["accessors"][index]
    width = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4}[a["type"]]
    dtype = {FLOAT: "<f4", UINT32: "<u4", UINT16: "<u2"}[a["componentType"]]
    raw = _view_bytes(tree, binary, a["bufferView"])
    stride = tree["bufferViews"][a["bufferView"]].get("byteStride")
    itemsize = np.dtype(dtype).itemsize * width
    if stride and stride != itemsize:
        rows = np.frombuffer(raw, np.uint8)[:a["count"] * stride].reshape(a["count"], stride)[:, :itemsize]
        return np.ascontiguousarray(rows).view(dtype).reshape(a["count"], width)
    start = a.get("byteOffset", 0)
    return np.frombuffer(raw, dtype, a["count"] * width, start).reshape(a["count"], width)


def _padded_rows(arr: np.ndarray, stride: int) -> bytes:
    """Rows of ``arr`` (raw bytes) each padded to ``stride`` bytes (vertex attributes are 4-aligned)."""
    raw = np.ascontiguousarray(arr).view(np.uint8).reshape(len(arr), -1)
    out = np.zeros((len(arr), stride), np.uint8)
    out[:, :raw.shape[1]] = raw
    return out.tobytes()


def quantize_glb(data: bytes) -> bytes:
    """``data`` (a GLB as trimesh writes it) with quantised geometry; other views kept byte for byte.

    A buffer view that another accessor also reads is left as it is."""
    tree, binary = read_glb(data)
    acc = tree.get("accessors", [])
    readers: dict[int, int] = {}
    for a in acc:
        if "bufferView" in a:
            readers[a["bufferView"]] = readers.get(a["bufferView"], 0) + 1
    new_views: dict[int, tuple[bytes, int | None]] = {}     # view index -> (bytes, byteStride)
    normals = False
    for prim in (p for mesh in tree.get("meshes", []) for p in mesh.get("primitives", [])):
        attrs, n_vertices = prim["attributes"], acc[prim["attributes"]["POSITION"]]["count"]
        ni, ii = attrs.get("NORMAL"), prim.get("indices")
        if ni is not None and acc[ni]["componentType"] == FLOAT and readers.get(acc[ni]["bufferView"]) == 1:
            n = _accessor_array(tree, binary, ni).astype(np.float64)
            length = np.linalg.norm(n, axis=1, keepdims=True)
            n = np.divide(n, length, out=np.zeros_like(n), where=length > 0)
            qn = np.clip(np.round(n * 127), -127, 127).astype(np.int8)
            acc[ni].update(componentType=INT8, normalized=True, min=[int(v) for v in qn.min(axis=0)],
                           max=[int(v) for v in qn.max(axis=0)])
            acc[ni].pop("byteOffset", None)
            new_views[acc[ni]["bufferView"]] = (_padded_rows(qn, 4), 4)
            normals = True
        if (ii is not None and acc[ii]["componentType"] == UINT32 and n_vertices <= 65535
                and readers.get(acc[ii]["bufferView"]) == 1):
            idx = _accessor_array(tree, binary, ii).astype("<u2")
            acc[ii].update(componentType=UINT16)
            acc[ii].pop("byteOffset", None)
            new_views[acc[ii]["bufferView"]] = (idx.tobytes(), None)
    if not new_views:
        return data
    chunks, offset = [], 0
    for i, view in enumerate(tree["bufferViews"]):
        raw, stride = new_views.get(i, (_view_bytes(tree, binary, i), view.get("byteStride")))
        view.update(byteOffset=offset, byteLength=len(raw))
        view.pop("byteStride", None)
        if stride:
            view["byteStride"] = stride
        chunks.append(_pad(raw))
        offset += len(chunks[-1])
    tree["buffers"] = [{"byteLength": offset}]
    if normals:
        for key in ("extensionsUsed", "extensionsRequired"):
            tree[key] = sorted(set(tree.get(key, [])) | {_EXT})
    return write_glb(tree, b"".join(chunks))
