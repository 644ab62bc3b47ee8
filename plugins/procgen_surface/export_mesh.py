"""Export geometry: the surface displaced by cumulative layer thickness, cells baked in an atlas.

Every input triangle is subdivided N x N (the same N everywhere, so shared edges stay conforming
and the output is watertight when the input is).  Each lattice vertex is displaced along the
interpolated vertex normal (the thesis's "rounded facets") by the stacked thickness of the cell
under it; vertices on shared edges average both triangles' values (thesis 4.2.3.a).  Triangles
over holes are removed.  Texture coordinates map each triangle's own cell grid, packed as a
rectangle in one atlas image (one texel block per cell).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from procgen import geometry as geo
from procgen.domains import TriMesh

from .domain import SurfaceCells


@dataclass(frozen=True)
class Atlas:
    """Placement of every triangle's cell grid in one image."""

    image: np.ndarray      # (H, W, 4) float RGBA in [0, 1], row 0 = top
    origin: np.ndarray     # (m, 2) texel (x, y) of each face's cell (0, 0) corner
    texels: int            # texels per cell side

    def uv(self, face: np.ndarray, xy: np.ndarray, size: float) -> np.ndarray:
        """Texture coordinates (u right, v up) of 2-D frame points of ``face``."""
        h, w = self.image.shape[:2]
        px = self.origin[face] + xy / size * self.texels
        return np.column_stack([px[:, 0] / w, 1.0 - px[:, 1] / h])


def pack_atlas(cells: SurfaceCells, rgb: np.ndarray, alive: np.ndarray, *,
               texels: int = 2, pad: int = 1) -> Atlas:
    """Shelf-pack the face grids and paint each cell's colour (alpha 0 on holes).

    ``rgb``: (n, 3) one colour per cell, or (n, texels, texels, 3) one per texel [cell, x, y]
    (x along the facet frame's ex, y along ey), e.g. anti-aliased crack micro-cells.
    """
    nx, ny = cells.nx, cells.ny
    w_f, h_f = nx * texels + 2 * pad, ny * texels + 2 * pad
    use = nx > 0
    area = int(np.sum((w_f * h_f)[use]))
    width = max(int(np.ceil(np.sqrt(area) * 1.05)), int(w_f.max()))
    order = np.argsort(-h_f, kind="stable")
    origin = np.zeros((len(nx), 2), np.int64)
    x = y = shelf = 0
    for f in order[use[order]]:            # packing loop over triangles (setup, not per step)
        if x + w_f[f] > width:
            x, y, shelf = 0, y + shelf, 0
        origin[f] = (x + pad, y + pad)
        x += w_f[f]
        shelf = max(shelf, h_f[f])
    height = y + shelf
    img = np.zeros((height, width, 4))
    filled = np.zeros((height, width), bool)
    k = texels
    base = origin[cells.face] + cells.ij * k                   # (n, 2) texel (x, y)
    for dy in range(k):                                        # k*k texel offsets, vectorised
        for dx in range(k):
            yy, xx = base[:, 1] + dy, base[:, 0] + dx
            img[yy, xx, :3] = rgb if rgb.ndim == 2 else rgb[:, dx, dy]
            img[yy, xx, 3] = alive.astype(float)
            filled[yy, xx] = True
    # bleed colours into unused texels so bilinear filtering never picks up black
    from scipy.ndimage import distance_transform_edt
    if (~filled).any() and filled.any():
        idx = distance_transform_edt(~filled, return_distances=False, return_indices=True)
        img[~filled] = img[idx[0][~filled], idx[1][~filled]]      # colour and alpha
    return Atlas(image=img, origin=origin, texels=k)


@dataclass(frozen=True)
class DisplacedMesh:
    vertices: np.ndarray     # (V, 3)
    faces: np.ndarray        # (T, 3)
    corner_uv: np.ndarray    # (T, 3, 2)
    vertex_rgb: np.ndarray   # (V, 3) colour of the cell under each vertex
    face_cell: np.ndarray    # (T,) cell under each triangle's centroid
    face_src: np.ndarray     # (T,) input triangle each output triangle lies on
    corner_xy: np.ndarray    # (T, 3, 2) corners in that triangle's 2-D cell frame


def _lattice(n: int) -> tuple[np.ndarray, np.ndarray]:
    """Barycentric lattice points (P, 3) with weights (N-a-b, a, b)/N and its triangles."""
    pts, index = [], {}
    for a in range(n + 1):
        for b in range(n + 1 - a):
            index[(a, b)] = len(pts)
            pts.append((n - a - b, a, b))
    tris = []
    for a in range(n):
        for b in range(n - a):
            tris.append((index[(a, b)], index[(a + 1, b)], index[(a, b + 1)]))
            if a + b + 2 <= n:
                tris.append((index[(a + 1, b)], index[(a + 1, b + 1)], index[(a, b + 1)]))
    return np.asarray(pts, np.int64), np.asarray(tris, np.int64)


def subdivision_level(cells: SurfaceCells, cells_per_segment: float, max_triangles: int) -> int:
    f = cells.faces[cells.valid]
    v = cells.vertices
    longest = np.max(np.linalg.norm(v[f[:, [1, 2, 0]]] - v[f], axis=2))
    n = int(np.ceil(longest / (cells.size * cells_per_segment)))
    n_cap = int(np.sqrt(max_triangles / max(len(f), 1)))
    return int(np.clip(n, 1, max(n_cap, 1)))


def cell_under(cells: SurfaceCells, face: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Active cell of ``face`` containing 2-D points (nudged into the triangle); -1 if none."""
    c2 = cells.corners2d[face]
    q = xy + 1e-6 * (c2.mean(axis=1) - xy)
    ij = np.floor(q / cells.size).astype(np.int64)
    i = np.clip(ij[:, 0], 0, np.maximum(cells.nx[face] - 1, 0))
    j = np.clip(ij[:, 1], 0, np.maximum(cells.ny[face] - 1, 0))
    return cells.layout.cell_at(face, i, j)


def displaced_mesh(cells: SurfaceCells, height: np.ndarray, rgb: np.ndarray, alive: np.ndarray,
                   atlas: Atlas | None, *, level: int, exaggerate: float = 1.0) -> DisplacedMesh:
    """Subdivide, displace by ``height`` (per cell) along interpolated normals, drop holes."""
    pts, tris = _lattice(level)
    faces_src = np.nonzero(cells.valid)[0]
    mf = len(faces_src)
    P = len(pts)
    f_rep = np.repeat(faces_src, P)                            # (mf*P,)
    bc = np.tile(pts / level, (mf, 1))
    verts_src = cells.faces[f_rep]                              # (mf*P, 3)
    xyz = np.einsum("nk,nkd->nd", bc, cells.vertices[verts_src])
    xy = np.einsum("nk,nkd->nd", bc, cells.corners2d[f_rep])
    cell = cell_under(cells, f_rep, xy)
    # canonical key: the (vertex id, weight) pairs with non-zero weight, sorted by vertex id
    w = np.tile(pts, (mf, 1))
    vid = np.where(w > 0, verts_src, np.iinfo(np.int64).max)
    order = np.argsort(vid, axis=1)
    key = np.concatenate([np.take_along_axis(vid, order, 1), np.take_along_axis(w, order, 1)], 1)
    interior = np.all(w > 0, axis=1)
    key[interior, 0] = -1 - f_rep[interior]                     # interior points: per face
    _, inv = np.unique(key, axis=0, return_inverse=True)
    inv = inv.ravel()
    nv = int(inv.max()) + 1
    cnt = np.bincount(inv, minlength=nv).astype(float)
    pos = np.zeros((nv, 3))
    np.add.at(pos, inv, xyz)
    pos /= cnt[:, None]
    # normals: face-sign-corrected vertex normals interpolated, averaged over duplicates
    fn = geo.face_normals(cells.vertices, cells.faces)[f_rep]
    vn = geo.vertex_normals(cells.vertices, cells.faces)[verts_src]
    vn = np.where((np.sum(vn * fn[:, None], 2) < 0)[..., None], -vn, vn)
    nrm_s = np.einsum("nk,nkd->nd", bc, vn)
    nrm = np.zeros((nv, 3))
    np.add.at(nrm, inv, nrm_s)
    ln = np.linalg.norm(nrm, axis=1, keepdims=True)
    nrm = np.divide(nrm, ln, out=np.zeros_like(nrm), where=ln > 1e-12)
    ok = cell >= 0
    h = np.zeros(nv)
    hc = np.zeros(nv)
    np.add.at(h, inv[ok], height[cell[ok]])
    np.add.at(hc, inv[ok], 1.0)
    h = np.divide(h, hc, out=np.zeros(nv), where=hc > 0)
    col = np.zeros((nv, 3))
    np.add.at(col, inv[ok], rgb[cell[ok]])
    col = np.divide(col, hc[:, None], out=np.zeros((nv, 3)), where=hc[:, None] > 0)
    pos = pos + (exaggerate * h)[:, None] * nrm
    # triangles
    t_local = tris[None, :, :] + (np.arange(mf) * P)[:, None, None]   # (mf, T, 3)
    t_flat = t_local.reshape(-1, 3)
    t_face = np.repeat(faces_src, len(tris))
    cen_xy = xy[t_flat].mean(axis=1)
    t_cell = cell_under(cells, t_face, cen_xy)
    keep = (t_cell >= 0) & alive[np.maximum(t_cell, 0)]
    t_flat, t_face, t_cell = t_flat[keep], t_face[keep], t_cell[keep]
    if atlas is not None:
        uv = atlas.uv(np.repeat(t_face, 3), xy[t_flat.ravel()], cells.size).reshape(-1, 3, 2)
    else:
        uv = np.zeros((len(t_flat), 3, 2))
    faces_out = inv[t_flat]
    # drop unused vertices
    used = np.unique(faces_out)
    remap = np.full(nv, -1, np.int64)
    remap[used] = np.arange(len(used))
    return DisplacedMesh(pos[used], remap[faces_out], uv, col[used], t_cell, t_face, xy[t_flat])


# -- file writers: the core's OBJ/GLB exporters, fed a TriMesh with UV and texture fields ----

def as_trimesh(mesh: DisplacedMesh, atlas: Atlas | None) -> TriMesh:
    """The displaced mesh as a core TriMesh: corner UVs, atlas texture and vertex colours as fields.

    Writing OBJ/GLB is then the core exchange's job (procgen.exchange.obj / glb), one writer for
    every plugin.
    """
    tm = TriMesh(mesh.vertices, mesh.faces)
    tm.add_field("surface__color", mesh.vertex_rgb, at="vertex", doc="colour of the cell under each vertex")
    if atlas is not None:
        tm.add_field("surface__uv", mesh.corner_uv, at="face", doc="atlas UV of each face corner")
        tm.add_field("surface__texture", atlas.image, at="domain", doc="RGBA atlas; alpha 0 = hole")
    return tm


def obj_files(mesh: DisplacedMesh, atlas: Atlas | None, *, name: str, provenance: dict | None = None,
              vertex_colors: bool = False) -> dict[str, bytes]:
    """OBJ (+ MTL + PNG atlas) bytes through the core exporter; ``v x y z r g b`` when asked."""
    from procgen.exchange import obj_export

    tm = as_trimesh(mesh, atlas)
    textured = {"uv_field": "surface__uv", "texture_field": "surface__texture"} if atlas is not None else {}
    color = {"color_field": "surface__color"} if (vertex_colors or atlas is None) else {}
    return obj_export(tm, stem=name, provenance=provenance, **textured, **color)


def glb_bytes(mesh: DisplacedMesh, atlas: Atlas | None, provenance: dict | None = None) -> bytes:
    """Binary glTF through the core exporter (textured, or vertex colours without an atlas)."""
    from procgen.exchange import glb_export

    tm = as_trimesh(mesh, atlas)
    if atlas is not None:
        return glb_export(tm, provenance=provenance, uv_field="surface__uv", texture_field="surface__texture")
    return glb_export(tm, provenance=provenance, color_field="surface__color")
