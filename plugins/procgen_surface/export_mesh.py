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
from procgen.exchange.obj import unique_rows
from procgen.domains import TriMesh

from .domain import SurfaceCells


@dataclass(frozen=True)
class Atlas:
    """Placement of every triangle's cell grid in one image, and the maps painted into it."""

    image: np.ndarray      # (H, W, 4) RGBA in [0, 1] (uint8 or float), row 0 = top
    origin: np.ndarray     # (m, 2) texel (x, y) of each face's cell (0, 0) corner
    texels: int            # texels per cell side
    orm: np.ndarray | None = None      # (H, W, 3) occlusion, roughness, metallic in [0, 1]
    height: np.ndarray | None = None   # (H, W) relief height (length)
    texel_size: float = 1.0            # model length of one texel side
    normal: np.ndarray | None = None   # (H, W, 3) uint8 encoded OpenGL normal map, if packed already

    def uv(self, face: np.ndarray, xy: np.ndarray, size: float) -> np.ndarray:
        """Texture coordinates (u right, v up) of 2-D frame points of ``face``."""
        h, w = self.image.shape[:2]
        px = self.origin[face] + xy / size * self.texels
        return np.column_stack([px[:, 0] / w, 1.0 - px[:, 1] / h])

    def normal_map(self, strength: float = 1.0, directx: bool = False) -> np.ndarray | None:
        """(H, W, 3) tangent-space unit normals in [-1, 1] of the height map (None without one).

        The atlas x axis is the facet frame's ex (u), rows run along ey, and v = 1 - row / H, so
        a height h gives n = (-dh/du, -dh/dv, 1) normalised, the OpenGL (+Y = +v) convention of
        glTF; ``directx`` flips the green channel (the -Y convention of DirectX tools).
        """
        if self.height is None:
            return None
        if self.normal is not None and strength == 1.0:
            n = self.normal.astype(np.float32) / np.float32(127.5) - np.float32(1.0)
        else:
            h = np.asarray(self.height, np.float32) * np.float32(strength / self.texel_size)
            gy, gx = np.gradient(h)
            n = np.stack([-gx, gy, np.ones_like(gx)], axis=-1)     # dh/dv = -dh/drow
            n /= np.sqrt(np.einsum("...i,...i->...", n, n))[..., None]
        if directx:
            n[..., 1] *= -1.0
        return n


def atlas_layout(cells: SurfaceCells, texels: int, pad: int = 1) -> tuple[np.ndarray, int, int]:
    """Shelf-pack the face grids: (origin (m, 2) texel of each face's cell (0, 0), width, height)."""
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
    return origin, width, y + shelf


def paint_atlas(cells: SurfaceCells, origin: np.ndarray, size: tuple[int, int], texels: int,
                channels: np.ndarray) -> np.ndarray:
    """(H, W, C) float32 image of per-cell (n, C) or per-texel (n, k, k, C) [cell, x, y] values,
    bled into the unused texels (nearest painted texel) so that filtering never picks up black."""
    from scipy.ndimage import distance_transform_edt

    width, height = size
    k = texels
    ch = np.asarray(channels, np.float32)
    img = np.zeros((height, width, ch.shape[-1]), np.float32)
    filled = np.zeros((height, width), bool)
    base = origin[cells.face] + cells.ij * k                   # (n, 2) texel (x, y)
    step = np.arange(k)
    xx = base[:, 0, None, None] + step[None, :, None]          # (n, k, k) [cell, x, y]
    yy = base[:, 1, None, None] + step[None, None, :]
    img[yy, xx] = ch[:, None, None, :] if ch.ndim == 2 else ch  # one scatter of every texel
    filled[yy, xx] = True
    if (~filled).any() and filled.any():
        idx = distance_transform_edt(~filled, return_distances=False, return_indices=True)
        img[~filled] = img[idx[0][~filled], idx[1][~filled]]
    return img


def pack_atlas(cells: SurfaceCells, rgb: np.ndarray, alive: np.ndarray, *,
               texels: int = 2, pad: int = 1, metallic: np.ndarray | None = None,
               roughness: np.ndarray | None = None, relief: np.ndarray | None = None) -> Atlas:
    """Shelf-pack the face grids and paint each cell's colour (alpha 0 on holes) and, when given,
    its metallic / roughness / relief (per cell (n,) or per texel (n, k, k)) into ORM and height
    maps; occlusion is the relief's cavities (:func:`cavity_occlusion`).

    ``rgb``: (n, 3) one colour per cell, or (n, texels, texels, 3) one per texel [cell, x, y]
    (x along the facet frame's ex, y along ey), e.g. anti-aliased crack micro-cells.
    """
    origin, width, height = atlas_layout(cells, texels, pad)
    per_texel = np.asarray(rgb).ndim == 4
    shape = (cells.n_cells, texels, texels) if per_texel else (cells.n_cells,)

    def chan(v: np.ndarray | None, default: float) -> np.ndarray:
        a = np.full(shape, default, np.float32) if v is None else np.asarray(v, np.float32)
        if per_texel and a.ndim == 1:
            a = np.broadcast_to(a[:, None, None], shape)
        return a[..., None]

    stack = [np.asarray(rgb, np.float32), chan(alive.astype(np.float32), 1.0)]
    pbr = metallic is not None or roughness is not None or relief is not None
    if pbr:
        stack += [chan(roughness, 0.8), chan(metallic, 0.0), chan(relief, 0.0)]
    img = paint_atlas(cells, origin, (width, height), texels, np.concatenate(stack, axis=-1))
    tsize = float(cells.size) / texels
    if not pbr:
        return Atlas(image=img, origin=origin, texels=texels, texel_size=tsize)
    h = img[..., 6]
    if relief is not None and np.ndim(relief) == 1 and texels > 1:
        # one height per cell is a staircase of texel blocks: a box of one cell turns it into
        # the piecewise-linear surface through the cell centres, whose slope the normals show
        from scipy.ndimage import uniform_filter
        h = uniform_filter(h, size=texels, mode="nearest")
    ao = cavity_occlusion(h, tsize) if relief is not None else np.ones_like(h)
    orm = np.stack([ao, img[..., 4], img[..., 5]], axis=-1)
    return Atlas(image=img[..., :4], origin=origin, texels=texels, orm=orm,
                 height=h if relief is not None else None, texel_size=tsize)


def cavity_occlusion(height: np.ndarray, texel_size: float, radius: int = 3) -> np.ndarray:
    """Ambient occlusion of a height map's cavities: 1 on flats and ridges, darker where a texel
    lies below the mean of its surroundings (a crack groove), by that depth over the radius."""
    from scipy.ndimage import uniform_filter

    h = np.asarray(height, np.float32)
    depth = uniform_filter(h, size=2 * radius + 1, mode="nearest") - h
    return np.clip(1.0 - depth / (radius * texel_size), 0.25, 1.0).astype(np.float32)


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
    _, inv = unique_rows(key)
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
    used = np.flatnonzero(np.bincount(faces_out.ravel(), minlength=nv))
    remap = np.full(nv, -1, np.int64)
    remap[used] = np.arange(len(used))
    return DisplacedMesh(pos[used], remap[faces_out], uv, col[used], t_cell, t_face, xy[t_flat])


# -- file writers: the core's OBJ/GLB exporters, fed a TriMesh with UV and texture fields ----

def as_trimesh(mesh: DisplacedMesh, atlas: Atlas | None, *, normal_strength: float = 1.0,
               directx: bool = False) -> TriMesh:
    """The displaced mesh as a core TriMesh: corner UVs, the atlas maps and vertex colours as fields.

    Writing OBJ/GLB is then the core exchange's job (procgen.exchange.obj / glb), one writer for
    every plugin.
    """
    tm = TriMesh(mesh.vertices, mesh.faces)
    tm.add_field("surface__color", mesh.vertex_rgb, at="vertex", doc="colour of the cell under each vertex")
    if atlas is not None:
        tm.add_field("surface__uv", mesh.corner_uv, at="face", doc="atlas UV of each face corner")
        tm.add_field("surface__texture", atlas.image, at="domain", doc="RGBA atlas; alpha 0 = hole")
        if atlas.orm is not None:
            tm.add_field("surface__orm", atlas.orm, at="domain", doc="occlusion, roughness, metallic")
        nrm = None
        if atlas.normal is not None and normal_strength == 1.0 and not directx:
            nrm = atlas.normal                                  # packed once by surface.bake
        elif atlas.height is not None:
            nrm = 0.5 * (atlas.normal_map(normal_strength, directx) + 1.0)
        if nrm is not None:
            tm.add_field("surface__normal", nrm, at="domain", doc="tangent-space normal map")
            tm.add_field("surface__height", atlas.height, at="domain", units="length", doc="relief height map")
    return tm


def _maps(tm: TriMesh) -> dict[str, str]:
    return {k: f"surface__{k[:-6]}" for k in ("orm_field", "normal_field", "height_field")
            if f"surface__{k[:-6]}" in tm}


def obj_files(mesh: DisplacedMesh, atlas: Atlas | None, *, name: str, provenance: dict | None = None,
              vertex_colors: bool = False, normal_strength: float = 1.0,
              directx: bool = False) -> dict[str, bytes]:
    """OBJ (+ MTL + PNG maps) bytes through the core exporter; ``v x y z r g b`` when asked."""
    from procgen.exchange import obj_export

    tm = as_trimesh(mesh, atlas, normal_strength=normal_strength, directx=directx)
    textured = {"uv_field": "surface__uv", "texture_field": "surface__texture", **_maps(tm)} \
        if atlas is not None else {}
    color = {"color_field": "surface__color"} if (vertex_colors or atlas is None) else {}
    return obj_export(tm, stem=name, provenance=provenance, **textured, **color)


def glb_bytes(mesh: DisplacedMesh, atlas: Atlas | None, provenance: dict | None = None, *,
              normal_strength: float = 1.0, up: str = "z") -> bytes:
    """Binary glTF through the core exporter (textured PBR maps, or vertex colours without an atlas);
    ``up``: the model's up axis, turned to glTF's +Y."""
    from procgen.exchange import glb_export

    tm = as_trimesh(mesh, atlas, normal_strength=normal_strength)
    if atlas is not None:
        maps = {k: v for k, v in _maps(tm).items() if k != "height_field"}
        return glb_export(tm, provenance=provenance, uv_field="surface__uv",
                          texture_field="surface__texture", up=up, **maps)
    return glb_export(tm, provenance=provenance, color_field="surface__color", up=up)
