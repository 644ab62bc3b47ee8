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


_PAD = 0  # byte dropped from the formatted table (padding of the fixed-width digit columns)


def _digits(a: np.ndarray, width: int, keep: int) -> np.ndarray:
    """(n, width) ASCII digits of non-negative ints, leading zeros as _PAD except the last ``keep``."""
    p = 10 ** np.arange(width - 1, -1, -1, dtype=np.int64)
    d = (a[:, None] // p) % 10
    out = (d + 48).astype(np.uint8)
    lead = np.cumsum(d, axis=1) == 0
    lead[:, width - keep:] = False
    out[lead] = _PAD
    return out


def _number_bytes(col: np.ndarray, decimals: int) -> np.ndarray:
    """(n, w) ASCII of one column: ints, or floats fixed to ``decimals`` places (printf's %.Nf)."""
    if decimals == 0:
        v = np.asarray(col, np.int64)
    else:
        v = np.round(np.asarray(col, np.float64) * 10.0 ** decimals).astype(np.int64)
    neg = v < 0
    a = np.abs(v)
    scale = 10 ** decimals
    ip, fp = a // scale, a % scale
    width = max(len(str(int(ip.max()))) if len(ip) else 1, 1)
    parts = [np.where(neg, ord("-"), _PAD).astype(np.uint8)[:, None], _digits(ip, width, 1)]
    if decimals:
        parts += [np.full((len(v), 1), ord("."), np.uint8), _digits(fp, decimals, decimals)]
    return np.concatenate(parts, axis=1)


def _rows(prefix: str, columns: np.ndarray, decimals: int | tuple[int, ...], seps: str = " ") -> str:
    """Text lines ``prefix c0<sep>c1...`` for a (n, k) table, formatted by numpy arithmetic
    (no Python per row: np.savetxt took most of the export of big meshes). ``seps``: the
    separator after each column but the last, cycled (e.g. "/ " for ``f v/vt v/vt``)."""
    cols = np.asarray(columns)
    n, k = cols.shape
    if n == 0:
        return ""
    dec = (decimals,) * k if isinstance(decimals, int) else decimals
    blocks = [np.frombuffer((prefix + " ").encode(), np.uint8)[None, :].repeat(n, 0)]
    for j in range(k):
        blocks.append(_number_bytes(cols[:, j], dec[j]))
        sep = seps[j % len(seps)] if j < k - 1 else "\n"
        blocks.append(np.full((n, 1), ord(sep), np.uint8))
    table = np.concatenate(blocks, axis=1)
    return table[table != _PAD].tobytes().decode("ascii")


def unique_rows(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(unique rows in lexicographic order, inverse) of a 2-D array, via lexsort (np.unique with
    axis=0 sorts a structured view and was the slowest step of exporting big meshes)."""
    a = np.ascontiguousarray(a)
    if len(a) == 0:
        return a, np.zeros(0, np.int64)
    order = np.lexsort(a.T[::-1])
    s = a[order]
    new = np.ones(len(a), bool)
    new[1:] = np.any(s[1:] != s[:-1], axis=1)
    group = np.cumsum(new) - 1
    inv = np.empty(len(a), np.int64)
    inv[order] = group
    return s[new], inv


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
               material: tuple[float, float, float] = (0.8, 0.8, 0.8),
               orm_field: str | None = None, normal_field: str | None = None,
               height_field: str | None = None) -> dict[str, bytes]:
    """OBJ text (+ ``stem.mtl``, + ``stem_texture.png`` when textured) for a TriMesh (2-D meshes
    get z=0).  With a texture, ``orm_field`` (occlusion/roughness/metallic image in [0, 1]),
    ``normal_field`` (tangent-space normal map, encoded in [0, 1]) and ``height_field`` (a
    height image) add ``stem_orm.png`` (plus its roughness and metallic channels as grey PNGs),
    ``stem_normal.png`` and a 16-bit ``stem_height.png``, named in the MTL with the PBR
    extension (``Pr``/``Pm``/``map_Pr``/``map_Pm``) and ``map_Bump`` (a normal map to Blender)."""
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
        out.append(_rows("v", np.column_stack([v, vertex_colors(domain, color_field)]), (6, 6, 6, 4, 4, 4)))
    else:
        out.append(_rows("v", v, 6))
    if normals:
        out.append(_rows("vn", domain.vertex_normals, 5))
    files: dict[str, bytes] = {}
    f1 = domain.faces + 1
    mtl = ["# procgen material\n", "newmtl procgen\n", "Ka 0.2 0.2 0.2\n",
           "Kd %.4f %.4f %.4f\n" % tuple(material), "Ks 0.0 0.0 0.0\n", "d 1.0\n", "illum 1\n"]
    if uv_field:
        uv, t_idx = unique_rows(corner_uvs(domain, uv_field).reshape(-1, 2))
        out.append(_rows("vt", uv, 6))
        t1 = t_idx.reshape(-1, 3) + 1
        out.append("usemtl procgen\n")
        if normals:
            out.append(_rows("f", np.stack([f1, t1, f1], axis=2).reshape(-1, 9), 0, "// "))
        else:
            out.append(_rows("f", np.stack([f1, t1], axis=2).reshape(-1, 6), 0, "/ "))
        # texture rows are stored top-first, as image files are; UV v=1 is the top row
        tex = texture_image(domain, texture_field)
        files[f"{name}_texture.png"] = png_bytes(tex, provenance)
        mtl[3] = "Kd 1.0 1.0 1.0\n"
        mtl.append(f"map_Kd {name}_texture.png\n")
        if tex.shape[2] == 4:             # alpha cuts holes (corroded-through cells)
            mtl.append(f"map_d {name}_texture.png\n")
        files.update(_pbr_maps(domain, name, provenance, mtl, orm_field, normal_field, height_field))
    else:
        if use_mtl:
            out.append("usemtl procgen\n")
        if normals:
            out.append(_rows("f", np.stack([f1, f1], axis=2).reshape(-1, 6), 0, "/ "))
        else:
            out.append(_rows("f", f1, 0))
    files[f"{name}.obj"] = "".join(out).encode()
    if use_mtl:
        files[f"{name}.mtl"] = "".join(mtl).encode()
    return files


def _pbr_maps(domain: TriMesh, name: str, provenance: dict[str, Any] | None, mtl: list[str],
              orm_field: str | None, normal_field: str | None, height_field: str | None) -> dict[str, bytes]:
    """The PBR maps beside the OBJ as PNGs, and their MTL lines (appended to ``mtl``)."""
    files: dict[str, bytes] = {}
    if orm_field:
        orm = texture_image(domain, orm_field)
        files[f"{name}_orm.png"] = png_bytes(orm, provenance)
        files[f"{name}_roughness.png"] = png_bytes(np.ascontiguousarray(orm[..., 1]), provenance)
        files[f"{name}_metallic.png"] = png_bytes(np.ascontiguousarray(orm[..., 2]), provenance)
        mtl += ["Pr 1.0\n", "Pm 1.0\n", f"map_Pr {name}_roughness.png\n", f"map_Pm {name}_metallic.png\n"]
    if normal_field:
        files[f"{name}_normal.png"] = png_bytes(texture_image(domain, normal_field), provenance)
        mtl.append(f"map_Bump -bm 1.0 {name}_normal.png\n")
    if height_field:
        h = np.asarray(domain[height_field], np.float64)
        lo, hi = float(h.min()), float(h.max())
        q = np.round((h - lo) / (hi - lo if hi > lo else 1.0) * 65535.0).astype(np.uint16)
        files[f"{name}_height.png"] = png_bytes(q, provenance, {"height_min": lo, "height_max": hi})
    return files
