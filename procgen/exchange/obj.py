"""Wavefront OBJ (+ MTL + texture PNG) from a TriMesh; read back by trimesh and Blender.

Vertex colours use the widely read ``v x y z r g b`` extension; a texture atlas uses face-corner
UVs (``vt``) with ``f v/vt`` indices and an MTL whose ``map_Kd`` names the PNG.
"""
from __future__ import annotations

import io
from typing import Any

import numpy as np

from ..domains import Domain, TriMesh
from ..errors import InputError
from .image import png_bytes, to_rgb8
from .provenance import comment_lines


def _rows(fmt: str, arr: np.ndarray) -> str:
    buf = io.StringIO()
    np.savetxt(buf, arr, fmt=fmt)
    return buf.getvalue()


def vertex_colors(domain: TriMesh, color_field: str, cmap: str = "terrain") -> np.ndarray:
    """(n, 3) floats in 0..1 from a vertex field: colours (0..1 floats or uint8), or scalars
    (heights, say) through the matplotlib colour map ``cmap``, as image_png colours a grid."""
    col = np.asarray(domain[color_field])
    if col.shape == (domain.n_vertices,):
        return to_rgb8(col[None, :].astype(np.float64), cmap)[0] / 255.0
    if col.shape[:1] != (domain.n_vertices,) or col.ndim != 2 or col.shape[1] not in (3, 4):
        raise InputError(f"obj: color field {color_field!r} must be (n_vertices, 3|4), got {col.shape}")
    col = col[:, :3]
    return col / 255.0 if col.dtype == np.uint8 else np.clip(col.astype(float), 0, 1)


def corner_uvs(domain: TriMesh, uv_field: str) -> np.ndarray:
    """(m, 3, 2) texture coordinates per face corner from a face (m,3,2) or vertex (n,2) field."""
    uv = np.asarray(domain[uv_field], dtype=np.float64)
    if uv.shape == (domain.n_faces, 3, 2):
        return uv
    if uv.shape == (domain.n_vertices, 2):
        return uv[domain.faces]
    raise InputError(f"obj: uv field {uv_field!r} must be (n_faces, 3, 2) or (n_vertices, 2), got {uv.shape}")


def texture_image(domain: TriMesh, texture_field: str) -> np.ndarray:
    tex = np.asarray(domain[texture_field])
    if tex.ndim != 3 or tex.shape[2] not in (3, 4):
        raise InputError(f"obj: texture field {texture_field!r} must be an (h, w, 3|4) image, got {tex.shape}")
    return to_rgb8(tex)


def obj_export(domain: Domain, *, stem: str, provenance: dict[str, Any] | None = None,
               color_field: str | None = None, uv_field: str | None = None,
               texture_field: str | None = None, normals: bool = False,
               material: tuple[float, float, float] = (0.8, 0.8, 0.8)) -> dict[str, bytes]:
    """OBJ text (+ ``stem.mtl``, + ``stem.png`` when textured) for a TriMesh (2-D meshes get z=0)."""
    if not isinstance(domain, TriMesh):
        raise InputError(f"obj: expected a TriMesh, got {domain.kind}")
    if (uv_field is None) != (texture_field is None):
        raise InputError("obj: give both uv_field and texture_field for a textured mesh")
    v = domain.vertices if domain.dim == 3 else np.column_stack([domain.vertices, np.zeros(domain.n_vertices)])
    name = stem.rsplit("/", 1)[-1]
    # vertex-coloured meshes carry no material: readers (trimesh) then keep the colours
    use_mtl = uv_field is not None or color_field is None
    out = [comment_lines(provenance)] + ([f"mtllib {name}.mtl\n"] if use_mtl else []) + ["o procgen\n"]
    if color_field:
        out.append(_rows("v %.6f %.6f %.6f %.4f %.4f %.4f", np.column_stack([v, vertex_colors(domain, color_field)])))
    else:
        out.append(_rows("v %.6f %.6f %.6f", v))
    if normals:
        out.append(_rows("vn %.5f %.5f %.5f", domain.vertex_normals))
    files: dict[str, bytes] = {}
    f1 = domain.faces + 1
    mtl = ["# procgen material\n", "newmtl procgen\n", "Ka 0.2 0.2 0.2\n",
           "Kd %.4f %.4f %.4f\n" % tuple(material), "Ks 0.0 0.0 0.0\n", "d 1.0\n", "illum 1\n"]
    if uv_field:
        uv, t_idx = np.unique(corner_uvs(domain, uv_field).reshape(-1, 2), axis=0, return_inverse=True)
        out.append(_rows("vt %.6f %.6f", uv))
        t1 = t_idx.reshape(-1, 3) + 1
        out.append("usemtl procgen\n")
        if normals:
            out.append(_rows("f %d/%d/%d %d/%d/%d %d/%d/%d", np.stack([f1, t1, f1], axis=2).reshape(-1, 9)))
        else:
            out.append(_rows("f %d/%d %d/%d %d/%d", np.stack([f1, t1], axis=2).reshape(-1, 6)))
        # texture rows are stored top-first, as image files are; UV v=1 is the top row
        tex = texture_image(domain, texture_field)
        files[f"{name}_texture.png"] = png_bytes(tex, provenance)
        mtl[3] = "Kd 1.0 1.0 1.0\n"
        mtl.append(f"map_Kd {name}_texture.png\n")
        if tex.shape[2] == 4:             # alpha cuts holes (corroded-through cells)
            mtl.append(f"map_d {name}_texture.png\n")
    else:
        if use_mtl:
            out.append("usemtl procgen\n")
        if normals:
            out.append(_rows("f %d//%d %d//%d %d//%d", np.stack([f1, f1], axis=2).reshape(-1, 6)))
        else:
            out.append(_rows("f %d %d %d", f1))
    files[f"{name}.obj"] = "".join(out).encode()
    if use_mtl:
        files[f"{name}.mtl"] = "".join(mtl).encode()
    return files
