"""The GLB writer encodes each texture once, with provenance (issue 35, item 5; issue 34, size).

Why it matters: trimesh re-encoded every texture once per material slot (the ORM image fills
two) at zlib's default level; at a 16-Mpx crack atlas that was most of the export.  What must
hold: every embedded image carries procgen's provenance (PNG text chunk or JPEG comment),
decodes to the texture the mesh carries (exactly as PNG, within JPEG's error as JPEG), and the
ORM image is stored once for both slots that read it.
"""
from __future__ import annotations

import io
import json
import struct

import numpy as np
from PIL import Image

from procgen.domains import TriMesh
from procgen.exchange import glb_export

PROV = {"recipe": "glb-encode-test", "seed": 3}


def textured_square() -> TriMesh:
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], float)
    tm = TriMesh(v, np.array([[0, 1, 2], [0, 2, 3]]))
    rng = np.random.default_rng(0)
    tm.add_field("test__uv", v[:, :2].copy(), at="vertex")
    tm.add_field("test__tex", rng.random((24, 32, 3)), at="domain")
    tm.add_field("test__orm", rng.random((24, 32, 3)), at="domain")
    tm.add_field("test__nrm", np.broadcast_to([0.5, 0.5, 1.0], (24, 32, 3)).copy(), at="domain")
    return tm


def split_glb(data: bytes) -> tuple[dict, bytes]:
    magic, _, _ = struct.unpack_from("<III", data, 0)
    assert magic == 0x46546C67
    jlen, _ = struct.unpack_from("<II", data, 12)
    tree = json.loads(data[20:20 + jlen])
    blen, _ = struct.unpack_from("<II", data, 20 + jlen)
    return tree, data[28 + jlen:28 + jlen + blen]


def test_glb_textures_are_encoded_once_with_provenance_and_read_back_exactly():
    tm = textured_square()
    data = glb_export(tm, provenance=PROV, uv_field="test__uv", texture_field="test__tex", orm_field="test__orm",
                      normal_field="test__nrm")
    tree, blob = split_glb(data)
    mat = tree["materials"][0]
    pbr = mat["pbrMetallicRoughness"]
    image_of = lambda tex: tree["images"][tree["textures"][tex["index"]]["source"]]   # noqa: E731
    view_of = lambda img: img["bufferView"]                                            # noqa: E731
    # the ORM image fills two slots from one stored copy
    assert view_of(image_of(pbr["metallicRoughnessTexture"])) == view_of(image_of(mat["occlusionTexture"]))
    views = {view_of(img) for img in tree["images"]}
    assert len(views) == 3                                     # colour, ORM, normal: each stored once
    want = {"baseColorTexture": "test__tex", "metallicRoughnessTexture": "test__orm"}
    for slot, field in want.items():
        bv = tree["bufferViews"][view_of(image_of(pbr[slot]))]
        png = blob[bv.get("byteOffset", 0):bv.get("byteOffset", 0) + bv["byteLength"]]
        img = Image.open(io.BytesIO(png))
        expect = np.rint(np.clip(np.asarray(tm[field]), 0, 1) * 255).astype(np.uint8)
        got = np.asarray(img.convert("RGB"))
        # the image is the texture (row order as texture_image writes it: either way round)
        if img.format == "PNG":
            assert json.loads(img.text["procgen"])["recipe"] == PROV["recipe"]
            assert np.array_equal(got, expect) or np.array_equal(got, expect[::-1])
        else:
            assert img.format == "JPEG" and json.loads(img.info["comment"])["recipe"] == PROV["recipe"]
            err = min(np.abs(got.astype(int) - e).mean() for e in (expect, expect[::-1]))
            assert err < 12.0, err       # white noise, JPEG's worst case (~9 at quality 85); flipped rows: ~85
