"""Neighbour graph of 3DSCA cells: 8 in-grid Moore slots plus cross-edge links (thesis 3.3).

Two cross-edge schemes:

* ``unfold`` (default, seed-003 digest 7/12): every empty Moore slot of a cell takes the slot's
  virtual centre, finds the triangle edge it lies beyond, unfolds it into the neighbouring
  triangle's frame (same distance along the edge, same distance past it) and takes the cell
  there.  On a closed mesh every cell then has all 8 slots filled.
* ``pairs`` (the thesis literally): each cell crossed by a shared edge is paired with the cell of
  the other triangle whose centre projects nearest on the edge (projections clamped to the
  segment); pairs are taken in both directions, and the partner becomes one extra neighbour.

The result is the core's :class:`procgen.ca.graph.CellGraph`: one flat CSR graph with a Moore
direction code 0..7 and a cross-edge flag per entry.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from procgen.domains.trimesh_domain import edge_table
from procgen.errors import InputError

from procgen.geometry import orient2d

from .geometry import CellLayout, edge_half_planes

from procgen.ca.graph import MOORE, CellGraph  # the shared Moore convention and graph

SIDE_SLOTS = np.array([1, 3, 4, 6])
DIAGONAL_SLOTS = np.array([0, 2, 5, 7])


@dataclass(frozen=True)
class EdgeTopology:
    """Undirected edges of a triangle mesh and the (up to two) faces on each side."""

    edges: np.ndarray       # (E, 2) sorted vertex ids
    face_edges: np.ndarray  # (m, 3) edge id of corner k -> k+1
    edge_faces: np.ndarray  # (E, 2) faces, -1 on a boundary (non-manifold extras dropped)
    valence: np.ndarray     # (E,) faces per edge


def edge_topology(faces: np.ndarray, valid: np.ndarray | None = None) -> EdgeTopology:
    """Edge table (the core's); faces with ``valid == False`` (degenerate) do not link anything."""
    return EdgeTopology(*edge_table(faces, valid))


def _other_face(topo: EdgeTopology, face: np.ndarray, k: np.ndarray) -> np.ndarray:
    e = topo.face_edges[face, k]
    a, b = topo.edge_faces[e, 0], topo.edge_faces[e, 1]
    return np.where(a == face, b, np.where(b == face, a, -1))


def _closest_in_triangle(q: np.ndarray, tri: np.ndarray) -> np.ndarray:
    """Closest point of each 2-D triangle tri (n, 3, 2) to q (n, 2)."""
    best = q.copy()
    nrm, off = edge_half_planes(tri)
    inside = np.all(np.einsum("nkd,nd->nk", nrm, q) - off >= 0, axis=1)
    bestd = np.where(inside, 0.0, np.inf)
    for k in range(3):
        p0, p1 = tri[:, k], tri[:, (k + 1) % 3]
        e = p1 - p0
        t = np.clip(np.sum((q - p0) * e, 1) / np.maximum(np.sum(e * e, 1), 1e-300), 0, 1)
        c = p0 + t[:, None] * e
        d = np.sum((q - c) ** 2, 1)
        better = d < bestd
        best[better], bestd[better] = c[better], d[better]
    return best


@dataclass(frozen=True)
class EdgeFrames:
    """For each (face f, edge k): tangent/outward normal in f's frame and the matching
    tangent/inward normal in the other face g's frame (the rigid unfolding map f -> g)."""

    u_f: np.ndarray
    t_f: np.ndarray
    n_out: np.ndarray
    u_g: np.ndarray
    t_g: np.ndarray
    n_in: np.ndarray


def edge_frames(layout: CellLayout, faces: np.ndarray, f: np.ndarray, g: np.ndarray,
                k: np.ndarray) -> EdgeFrames:
    """Unfolding frames of edge k of faces f towards faces g (g must be valid indices)."""
    c2 = layout.frames.corners2d
    u_v, w_v = faces[f, k], faces[f, (k + 1) % 3]
    iu = np.argmax(faces[g] == u_v[:, None], axis=1)
    iw = np.argmax(faces[g] == w_v[:, None], axis=1)
    u_f, w_f, u_g, w_g = c2[f, k], c2[f, (k + 1) % 3], c2[g, iu], c2[g, iw]
    t_f = (w_f - u_f) / np.maximum(np.linalg.norm(w_f - u_f, axis=1, keepdims=True), 1e-300)
    t_g = (w_g - u_g) / np.maximum(np.linalg.norm(w_g - u_g, axis=1, keepdims=True), 1e-300)
    nrm_f, _ = edge_half_planes(c2[f])
    n_out = -nrm_f[np.arange(len(f)), k]
    third = c2[g, 3 - iu - iw]
    n_in = np.stack([-t_g[:, 1], t_g[:, 0]], 1)
    n_in *= np.where(np.sum((third - u_g) * n_in, 1) < 0, -1.0, 1.0)[:, None]
    return EdgeFrames(u_f, t_f, n_out, u_g, t_g, n_in)


def _unfold(layout: CellLayout, topo: EdgeTopology, faces: np.ndarray, face: np.ndarray,
            p: np.ndarray, k: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Unfold 2-D points p of faces ``face`` across their edge k; (other face, point in its frame)."""
    g = _other_face(topo, face, k)
    fr = edge_frames(layout, faces, face, np.where(g >= 0, g, face), k)
    along = np.sum((p - fr.u_f) * fr.t_f, 1)
    past = np.sum((p - fr.u_f) * fr.n_out, 1)
    q = fr.u_g + along[:, None] * fr.t_g + past[:, None] * fr.n_in
    return g, q


def _cell_containing(layout: CellLayout, g: np.ndarray, q: np.ndarray) -> np.ndarray:
    """Active cell of face g nearest to q: q is clamped into the triangle, nudged inwards."""
    tri = layout.frames.corners2d[g]
    q = _closest_in_triangle(q, tri)
    q = q + 1e-7 * (tri.mean(axis=1) - q)
    ij = np.floor(q / layout.size).astype(np.int64)
    i = np.clip(ij[:, 0], 0, layout.nx[g] - 1)
    j = np.clip(ij[:, 1], 0, layout.ny[g] - 1)
    return layout.cell_at(g, i, j)


def moore_slots(layout: CellLayout, faces: np.ndarray, topo: EdgeTopology,
                cross: str = "unfold") -> tuple[np.ndarray, np.ndarray]:
    """(n, 8) slot table (-1 = empty) and (n, 8) bool 'filled across an edge'."""
    n = layout.n_cells
    f = layout.face
    slots = np.full((n, 8), -1, np.int64)
    for s, (di, dj) in enumerate(MOORE):          # 8 iterations, each vectorised over cells
        slots[:, s] = layout.cell_at(f, layout.ij[:, 0] + di, layout.ij[:, 1] + dj)
    crossed = np.zeros((n, 8), bool)
    if cross != "unfold":
        return slots, crossed
    cell, slot = np.nonzero(slots < 0)
    if len(cell) == 0:
        return slots, crossed
    fc = f[cell]
    p = layout.center2d[cell] + MOORE[slot] * layout.size
    nrm, off = edge_half_planes(layout.frames.corners2d[fc])
    dist_out = off - np.einsum("nkd,nd->nk", nrm, p)              # > 0 outside edge k
    k = np.argmax(dist_out, axis=1)
    beyond = dist_out[np.arange(len(cell)), k] > 0
    g, q = _unfold(layout, topo, faces, fc, p, k)
    ok = beyond & (g >= 0)
    ok[ok] &= layout.nx[g[ok]] > 0
    target = np.full(len(cell), -1, np.int64)
    target[ok] = _cell_containing(layout, g[ok], q[ok])
    slots[cell, slot] = target
    crossed[cell, slot] = target >= 0
    return slots, crossed


def _segment_hits_square(p0: np.ndarray, p1: np.ndarray, lo: np.ndarray, size: float) -> np.ndarray:
    """Liang-Barsky: does segment p0-p1 meet the closed square [lo, lo + size]?"""
    d = p1 - p0
    t0 = np.zeros(len(p0))
    t1 = np.ones(len(p0))
    ok = np.ones(len(p0), bool)
    for ax in range(2):
        a, b = lo[:, ax] - p0[:, ax], lo[:, ax] + size - p0[:, ax]
        dd = d[:, ax]
        par = np.abs(dd) < 1e-300
        ok &= ~par | ((a <= 0) & (b >= 0))
        with np.errstate(divide="ignore", invalid="ignore"):
            ta, tb = a / dd, b / dd
        lo_t = np.where(par, -np.inf, np.minimum(ta, tb))
        hi_t = np.where(par, np.inf, np.maximum(ta, tb))
        t0, t1 = np.maximum(t0, lo_t), np.minimum(t1, hi_t)
    return ok & (t0 <= t1)


def thesis_pairs(layout: CellLayout, faces: np.ndarray, vertices: np.ndarray,
                 topo: EdgeTopology) -> np.ndarray:
    """(P, 2) cell pairs across shared edges by nearest projection on the edge (thesis 3.3.2)."""
    s = layout.size
    # clipped cells, plus column 0: edge AB lies exactly on the grid line x = 0
    border = np.nonzero((layout.area < s * s * (1 - 1e-9)) | (layout.ij[:, 0] == 0))[0]
    f = layout.face[border]
    rec_e, rec_side, rec_cell, rec_t = [], [], [], []
    c2 = layout.frames.corners2d
    for k in range(3):                              # the three edges of each face, vectorised
        e = topo.face_edges[f, k]
        g = _other_face(topo, f, k)
        p0, p1 = c2[f, k], c2[f, (k + 1) % 3]
        hit = _segment_hits_square(p0, p1, layout.ij[border] * s, s) & (g >= 0)
        # projection parameter measured from the edge's lower vertex id, in length units
        lo_is_u = faces[f, k] == topo.edges[e, 0]
        a = np.where(lo_is_u[:, None], p0, p1)
        b = np.where(lo_is_u[:, None], p1, p0)
        ln = np.linalg.norm(b - a, axis=1)
        t = np.clip(np.sum((layout.center2d[border] - a) * (b - a), 1) / ln, 0, ln)
        side = (topo.edge_faces[e, 0] != f).astype(np.int64)
        rec_e.append(e[hit]); rec_side.append(side[hit]); rec_cell.append(border[hit])
        rec_t.append(t[hit])
    e, side, cell, t = (np.concatenate(x) for x in (rec_e, rec_side, rec_cell, rec_t))
    if len(e) == 0:
        return np.zeros((0, 2), np.int64)
    span = float(np.max(t)) * 1.001 + 1.0
    pairs = []
    for a_side in (0, 1):
        qa, tb = side == a_side, side != a_side
        key_b = e[tb] * span + t[tb]
        order = np.argsort(key_b, kind="stable")
        kb, cb, eb = key_b[order], cell[tb][order], e[tb][order]
        if len(kb) == 0:
            continue
        key_a = e[qa] * span + t[qa]
        pos = np.searchsorted(kb, key_a)
        lo, hi = np.clip(pos - 1, 0, len(kb) - 1), np.clip(pos, 0, len(kb) - 1)
        dlo = np.where(eb[lo] == e[qa], np.abs(kb[lo] - key_a), np.inf)
        dhi = np.where(eb[hi] == e[qa], np.abs(kb[hi] - key_a), np.inf)
        pick = np.where(dhi < dlo, hi, lo)
        okp = np.minimum(dlo, dhi) < np.inf
        pairs.append(np.column_stack([cell[qa][okp], cb[pick[okp]]]))
    p = np.concatenate(pairs)
    p = np.concatenate([p, p[:, ::-1]])
    return np.unique(p, axis=0)


def _direction_code(vec: np.ndarray) -> np.ndarray:
    """Moore slot whose offset is closest in angle to 2-D vectors ``vec``."""
    unit = MOORE / np.linalg.norm(MOORE, axis=1, keepdims=True)
    return np.argmax(vec @ unit.T, axis=1)


def build_neighbours(layout: CellLayout, vertices: np.ndarray, faces: np.ndarray,
                     cross: str = "unfold") -> tuple[CellGraph, EdgeTopology]:
    """The CSR neighbour graph for ``cross`` in {'unfold', 'pairs', 'none'}."""
    if cross not in ("unfold", "pairs", "none"):
        raise InputError(f"neighbours must be 'unfold', 'pairs' or 'none', got {cross!r}")
    topo = edge_topology(faces, layout.frames.valid)
    slots, crossed = moore_slots(layout, faces, topo, "unfold" if cross == "unfold" else "none")
    n = layout.n_cells
    rows, code = np.nonzero(slots >= 0)
    cols = slots[rows, code]
    xflag = crossed[rows, code]
    if cross == "pairs":
        pr = thesis_pairs(layout, faces, vertices, topo)
        if len(pr):
            a, b = pr[:, 0], pr[:, 1]
            # direction: the partner's centre seen from a, expressed in a's frame
            fa = layout.face[a]
            vec = layout.frames.to_2d(fa, layout.center3d[b]) - layout.center2d[a]
            rows = np.concatenate([rows, a])
            cols = np.concatenate([cols, b])
            code = np.concatenate([code, _direction_code(vec)])
            xflag = np.concatenate([xflag, np.ones(len(a), bool)])
    order = np.lexsort((code, rows))
    rows, cols, code, xflag = rows[order], cols[order], code[order], xflag[order]
    indptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=n))]).astype(np.int64)
    return CellGraph(indptr, cols.astype(np.int64), code.astype(np.int8), xflag), topo


def orientation_errors(layout: CellLayout, faces: np.ndarray, topo: EdgeTopology) -> np.ndarray:
    """Per shared edge, 1 - cos(alpha) with alpha the grid misalignment folded into [0, pi/4].

    Thesis 3.3.3: the mismatch of the two grids after unfolding one onto the other; its mean
    over uniformly random angles is 1 - 2*sqrt(2)/pi.
    """
    ef = topo.edge_faces
    shared = np.nonzero((ef[:, 0] >= 0) & (ef[:, 1] >= 0))[0]
    if len(shared) == 0:
        return np.zeros(0)
    f, g = ef[shared, 0], ef[shared, 1]
    k = np.argmax(topo.face_edges[f] == shared[:, None], axis=1)
    fr = edge_frames(layout, faces, f, g, k)
    # g's x axis (1, 0) written in (t_g, n_in) coordinates, then rebuilt in f's frame
    ex_g = fr.t_g[:, :1] * fr.t_f + fr.n_in[:, :1] * fr.n_out
    alpha = np.abs(np.arctan2(ex_g[:, 1], ex_g[:, 0])) % (np.pi / 2)
    alpha = np.minimum(alpha, np.pi / 2 - alpha)
    return 1.0 - np.cos(alpha)


def analytic_mean_edge_error() -> float:
    """(4/pi) * integral_0^{pi/4} (1 - cos a) da = 1 - 2*sqrt(2)/pi (thesis: about 9.9 %)."""
    return 1.0 - 2.0 * np.sqrt(2.0) / np.pi


def unfolded_distances(layout: CellLayout, faces: np.ndarray, topo: EdgeTopology,
                       cell: int) -> np.ndarray:
    """(n,) surface distance from cell ``cell``'s centre to every cell centre, by unfolding.

    Exact on the development of the seed's triangle and its edge neighbours: a neighbour
    triangle is unfolded about the shared edge into the seed triangle's plane (the same rigid
    map as the ``unfold`` cross-edge links), so the shortest path is the straight segment when it
    crosses the shared edge (or stays on the seed's side of it: PART-IN centres) and goes around
    the nearer edge end otherwise.  Cells on triangles
    further away get NaN: the ideal circle of plate 3.2 (thesis 3.3.3) lies on two triangles.
    """
    f0 = int(layout.face[cell])
    p = layout.center2d[cell]
    out = np.full(layout.n_cells, np.nan)
    on0 = layout.face == f0
    out[on0] = np.linalg.norm(layout.center2d[on0] - p, axis=1)
    for k in range(3):                            # the seed triangle's three edges
        g = _other_face(topo, np.array([f0]), np.array([k]))[0]
        if g < 0:
            continue
        cells = np.nonzero(layout.face == g)[0]
        kg = int(np.argmax([_other_face(topo, np.array([g]), np.array([j]))[0] == f0 for j in range(3)]))
        _, q = _unfold(layout, topo, faces, np.full(len(cells), g), layout.center2d[cells],
                       np.full(len(cells), kg))
        a, b = layout.frames.corners2d[f0, k], layout.frames.corners2d[f0, (k + 1) % 3]
        pa, pb = np.broadcast_to(p, q.shape), np.broadcast_to(a, q.shape)
        bb = np.broadcast_to(b, q.shape)
        # straight unless the segment crosses the edge's line outside the edge (then it would
        # leave the two triangles); a PART-IN centre on the seed's side needs no crossing at all
        same_side = orient2d(pb, bb, pa) * orient2d(pb, bb, q) > 0
        crosses = same_side | (orient2d(pa, q, pb) * orient2d(pa, q, bb) <= 0)
        straight = np.linalg.norm(q - p, axis=1)
        around = np.minimum(np.linalg.norm(a - p) + np.linalg.norm(q - a, axis=1),
                            np.linalg.norm(b - p) + np.linalg.norm(q - b, axis=1))
        out[cells] = np.where(crosses, straight, around)
    return out
