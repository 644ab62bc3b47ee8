"""The exact cell-polygon mesh of SurfaceCells: holes exactly where cells are gone, rounded facets.

Why a second mesh builder: the displaced-lattice export (:mod:`.export_mesh`) subdivides every
triangle into a few cells wide lattice triangles and drops those whose centroid lies on a hole,
so a hole of a few cells becomes a staircase of lattice triangles (or vanishes).  The thesis
draws each cell (Appendix B §4: the square cell clipped by the oriented triangle) and cuts holes
by deleting the strips' triangles of the missing cells (Appendix B §6, plate B.2).  Here every
living cell's clipped polygon becomes a triangle fan around its centre, so:

* a removed cell removes exactly its polygon: the mesh's boundary runs exactly along the borders
  between removed and living cells, and the missing area is the removed cells' area;
* neighbouring triangles cut their grids at different points along a shared edge; each
  polygon side on a mesh edge is split at every grid crossing of *both* triangles, so the mesh
  has no T-junction and a closed input with no hole gives a closed (watertight) output.

Layer surfaces (Appendix B §7, Figure B.16, plate B.3): every vertex moves by the cells' layer
thickness along a normal.  ``rounded`` uses the vertex normals interpolated across the facet
(the thesis's ``rounded_facet``): both facets of an edge agree there, so the layer surface is
continuous and bends over the facet instead of folding at the edge.  Flat facets move along
their own face normal and keep their own vertices: at a convex edge the two layer surfaces part
(the red region of Figure B.16(a)).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from procgen import geometry as geo

from .domain import SurfaceCells
from .geometry import MAX_POLY


@dataclass(frozen=True)
class CellMesh:
    """Triangles of the living cells' polygons, with what the exporters and tests need."""

    vertices: np.ndarray      # (V, 3) displaced positions
    base: np.ndarray          # (V, 3) positions on the input surface (before displacement)
    normals: np.ndarray       # (V, 3) unit normals the vertices moved along
    faces: np.ndarray         # (T, 3) oriented as the input triangle under them
    face_cell: np.ndarray     # (T,) the cell each triangle belongs to
    face_src: np.ndarray      # (T,) the input triangle each triangle lies on
    corner_xy: np.ndarray     # (T, 3, 2) corners in that input triangle's 2-D cell frame


def _clusters(points: np.ndarray, tol: float) -> np.ndarray:
    """Vertex id per point: points closer than ``tol`` (transitively) share one id."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    pairs = cKDTree(points).query_pairs(tol, output_type="ndarray")
    n = len(points)
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    return connected_components(g, directed=False)[1]


def cell_mesh(sc: SurfaceCells, height: np.ndarray | None = None, alive: np.ndarray | None = None,
              *, rounded: bool = True, shape: float = 0.0, tol: float = 1e-7) -> CellMesh:
    """Mesh of the living cells' clipped polygons, moved by ``height`` (n,) along the normals.

    ``shape`` (rounded only, 0..1): also curve the facets themselves by Phong tessellation
    (Boubekeur and Alexa 2008; not in the thesis): each point moves towards the mean of its
    projections onto the tangent planes of the facet's corners, by this factor (3/4 is theirs).

    ``tol`` (a fraction of the cell size) merges polygon corners that are the same point computed
    twice (a grid corner shared by four cells, a triangle corner shared by its neighbours).
    """
    n = sc.n_cells
    h = np.zeros(n) if height is None else np.asarray(height, float)
    live = np.ones(n, bool) if alive is None else np.asarray(alive, bool)
    # every cell's polygon, living or not: both sides of a rim then split the input edges at
    # the same points, so the holed mesh and the removed cells' mesh share their rims exactly
    cells = np.arange(n)
    poly, cnt = sc.layout.cell_polygons(cells)                    # (K, MAX_POLY, 2)
    k_poly = len(cells)
    slot = np.arange(MAX_POLY)
    used = slot[None, :] < cnt[:, None]
    pi, sl = np.nonzero(used)                                     # polygon corner -> (poly, slot)
    face = sc.face[cells][pi]
    xy = poly[pi, sl]
    # barycentric weights, snapped so points on an edge lie exactly on the 3-D edge segment and
    # triangle corners are exactly the input vertex (the same point from every triangle)
    c2 = sc.corners2d[face]
    bc = geo.barycentric(c2, xy)
    bc = np.where(np.abs(bc) < 1e-9, 0.0, bc)
    bc = np.clip(bc, 0.0, None)
    bc /= bc.sum(axis=1, keepdims=True)
    fv = sc.faces[face]                                           # (N, 3) input vertex ids
    base = np.einsum("nk,nkd->nd", bc, sc.vertices[fv])
    vid = _clusters(base, tol * sc.size)
    if not rounded:                                               # flat facets keep own vertices
        _, vid = np.unique(np.column_stack([vid, face]), axis=0, return_inverse=True)
        vid = vid.ravel()
    n_vid = int(vid.max()) + 1 if len(vid) else 0
    corner_id = np.full((k_poly, MAX_POLY), -1, np.int64)
    corner_id[pi, sl] = vid

    # points on input edges: (edge key, vertex, t along the edge from its lower vertex id)
    on_edge = bc[:, [2, 0, 1]] == 0.0                            # edge e: corner e -> e+1
    rows, e = np.nonzero(on_edge)
    va, vb = fv[rows, e], fv[rows, (e + 1) % 3]
    lo_first = va < vb
    t = np.where(lo_first, bc[rows, (e + 1) % 3], bc[rows, e])
    if rounded:
        ekey = np.column_stack([np.minimum(va, vb), np.maximum(va, vb)])
    else:
        ekey = np.column_stack([face[rows], e])
    _, eid = np.unique(ekey, axis=0, return_inverse=True)
    eid = eid.ravel()
    pkey = eid * max(n_vid, 1) + vid[rows]
    upk, first = np.unique(pkey, return_index=True)
    pe, pv, pt = eid[first], vid[rows][first], t[first]
    order = np.lexsort((pt, pe))                                  # along each edge, by t
    rank = np.empty(len(order), np.int64)
    rank[order] = np.arange(len(order))
    sorted_v = pv[order]
    corner_eid = np.full((k_poly, MAX_POLY, 3), -1, np.int64)
    corner_eid[pi[rows], sl[rows], e] = eid

    # polygon sides: on one input edge (split at every point of that edge) or inside
    nxt = np.where(slot[None, :] + 1 < cnt[:, None], slot[None, :] + 1, 0)
    a_id = corner_id
    b_id = np.take_along_axis(corner_id, nxt, axis=1)
    edge_of = np.full((k_poly, MAX_POLY, 3), False)
    edge_of[pi, sl] = on_edge
    both = edge_of & np.take_along_axis(edge_of, nxt[..., None], axis=1)
    side_edge = np.where(both.any(axis=2), np.argmax(both, axis=2), -1)   # (K, MAX_POLY)
    live_side = used & (a_id != b_id) & live[:, None]
    inner = live_side & (side_edge < 0)
    tri_p, tri_a, tri_b = [], [], []
    ip, isl = np.nonzero(inner)
    tri_p.append(ip)
    tri_a.append(a_id[ip, isl])
    tri_b.append(b_id[ip, isl])
    ep, esl = np.nonzero(live_side & (side_edge >= 0))
    if len(ep):
        side_eid = corner_eid[ep, esl, side_edge[ep, esl]]
        ra = rank[np.searchsorted(upk, side_eid * max(n_vid, 1) + a_id[ep, esl])]
        rb = rank[np.searchsorted(upk, side_eid * max(n_vid, 1) + b_id[ep, esl])]
        step = np.where(rb > ra, 1, -1)
        nseg = np.abs(rb - ra)
        seg = np.repeat(np.arange(len(ep)), nseg)
        k = np.arange(len(seg)) - np.repeat(np.cumsum(nseg) - nseg, nseg)
        r0 = ra[seg] + step[seg] * k
        tri_p.append(ep[seg])
        tri_a.append(sorted_v[r0])
        tri_b.append(sorted_v[r0 + step[seg]])
    tp = np.concatenate(tri_p)
    ta = np.concatenate(tri_a)
    tb = np.concatenate(tri_b)

    # one centre vertex per polygon (inside: the polygon is convex)
    ctr_xy = np.sum(np.where(used[..., None], poly, 0.0), axis=1) / cnt[:, None]
    pf = sc.face[cells]
    cbc = geo.barycentric(sc.corners2d[pf], ctr_xy)
    ctr_base = np.einsum("nk,nkd->nd", cbc, sc.vertices[sc.faces[pf]])
    v_base = np.zeros((n_vid, 3))
    v_base[vid] = base
    all_base = np.concatenate([v_base, ctr_base])
    faces = np.column_stack([n_vid + tp, ta, tb])
    tri_face = pf[tp]

    # normals: interpolated vertex normals (rounded) or the face normal (flat)
    fn = geo.face_normals(sc.vertices, sc.faces)
    if rounded:
        vn = geo.vertex_normals(sc.vertices, sc.faces)
        def interp(f: np.ndarray, w: np.ndarray) -> np.ndarray:
            vv = vn[sc.faces[f]]
            vv = np.where((np.sum(vv * fn[f][:, None], 2) < 0)[..., None], -vv, vv)
            return np.einsum("nk,nkd->nd", w, vv)
        nrm = np.zeros((n_vid, 3))
        np.add.at(nrm, vid, interp(face, bc))
        nrm = np.concatenate([nrm, interp(pf, cbc)])
        if shape > 0.0:
            def phong(f: np.ndarray, w: np.ndarray, p: np.ndarray) -> np.ndarray:
                vv = vn[sc.faces[f]]
                vv = np.where((np.sum(vv * fn[f][:, None], 2) < 0)[..., None], -vv, vv)
                d = np.einsum("nkd,nkd->nk", p[:, None, :] - sc.vertices[sc.faces[f]], vv)
                star = p - np.einsum("nk,nk,nkd->nd", w, d, vv)       # sum_k w_k pi_k(p)
                return (1.0 - shape) * p + shape * star
            curved = np.zeros((n_vid, 3))
            np.add.at(curved, vid, phong(face, bc, base))
            curved /= np.maximum(np.bincount(vid, minlength=n_vid), 1)[:, None]
            surface = np.concatenate([curved, phong(pf, cbc, ctr_base)])
        else:
            surface = all_base
    else:
        nrm = np.zeros((n_vid, 3))
        nrm[vid] = fn[face]
        nrm = np.concatenate([nrm, fn[pf]])
        surface = all_base
    ln = np.linalg.norm(nrm, axis=1, keepdims=True)
    nrm = np.divide(nrm, ln, out=np.zeros_like(nrm), where=ln > 1e-12)
    # heights: a shared vertex takes the mean of the living cells around it (thesis 4.2.3.a)
    # (a rim point that only removed cells have takes their mean: it lies on a living side)
    hv = np.bincount(vid, h[pi] * live[pi], minlength=n_vid)
    hc = np.bincount(vid, live[pi].astype(float), minlength=n_vid)
    hv_all = np.bincount(vid, h[pi], minlength=n_vid) / np.maximum(np.bincount(vid, minlength=n_vid), 1)
    hv = np.where(hc > 0, hv / np.maximum(hc, 1.0), hv_all)
    hall = np.concatenate([hv, h])
    verts = surface + hall[:, None] * nrm

    # orientation of the input triangle under each output triangle
    cr = geo.triangle_cross(all_base, faces)
    flip = np.sum(cr * fn[tri_face], axis=1) < 0
    faces[flip] = faces[flip][:, [0, 2, 1]]
    # drop vertices no triangle uses (points of edges whose polygons were all removed)
    keep = np.flatnonzero(np.bincount(faces.ravel(), minlength=len(all_base)))
    remap = np.full(len(all_base), -1, np.int64)
    remap[keep] = np.arange(len(keep))
    faces = remap[faces]
    corner_xy = sc.layout.frames.to_2d(np.repeat(tri_face, 3),
                                       all_base[keep][faces.ravel()]).reshape(-1, 3, 2)
    return CellMesh(vertices=verts[keep], base=all_base[keep], normals=nrm[keep], faces=faces,
                    face_cell=cells[tp], face_src=tri_face, corner_xy=corner_xy)


def boundary_edges(faces: np.ndarray) -> np.ndarray:
    """(b, 2) directed edges used by exactly one triangle (the holes' rims and open borders)."""
    e = np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]])
    s = np.sort(e, axis=1)
    _, inv, count = np.unique(s, axis=0, return_inverse=True, return_counts=True)
    return e[count[inv.ravel()] == 1]


def boundary_loops(faces: np.ndarray) -> int:
    """Number of closed boundary loops (components of the boundary-edge graph)."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    b = boundary_edges(faces)
    if len(b) == 0:
        return 0
    ids, inv = np.unique(b.ravel(), return_inverse=True)
    inv = inv.reshape(-1, 2)
    g = coo_matrix((np.ones(len(inv)), (inv[:, 0], inv[:, 1])), shape=(len(ids), len(ids)))
    return int(connected_components(g, directed=False)[0])
