"""Crack paths unfolded onto a flat sheet for vector output (3DSCA thesis 5.2.5; the issue's SVG).

The thesis stores crack paths per facet as linked segments with widths.  For a plotter or an
illustrator they are laid flat: facets are grouped into planar patches (connected facets whose
normals agree, e.g. a cube side of several triangles, or the whole of a flat mesh = one 2-D
grid), each patch is drawn in its own plane's 2-D frame, and the patches are placed side by side
on one sheet.  A crack crossing from one patch to another is cut there (each piece keeps its
widths).  Only patches with cracks are placed; their outlines come along as hairlines.
"""
from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from procgen import Polylines
from procgen import geometry as geo


def planar_patches(vertices: np.ndarray, faces: np.ndarray, adjacency: np.ndarray,
                   tolerance: float = 1e-6) -> np.ndarray:
    """(m,) patch label per facet: components of adjacent facets with normals within tolerance."""
    n = geo.face_normals(vertices, faces)
    a, b = adjacency[:, 0], adjacency[:, 1]
    same = np.sum(n[a] * n[b], axis=1) > 1.0 - tolerance
    m = len(faces)
    graph = coo_matrix((np.ones(int(same.sum())), (a[same], b[same])), shape=(m, m))
    return connected_components(graph, directed=False)[1]


def crack_sheet(cells, paths: Polylines, *, gap: float = 0.08) -> Polylines:
    """The paths on one flat sheet: crack pieces (point ``crack__width``, line ``crack__layer`` and
    ``crack__type``) followed by the patch outline edges (``crack__layer`` = -1)."""
    from procgen import TriMesh

    v, f = cells.vertices, cells.faces
    adj = TriMesh(v, f).face_adjacency
    patch = planar_patches(v, f, np.asarray(adj))
    pts3 = np.asarray(paths.points, float)
    offsets = np.asarray(paths.offsets)
    face = np.asarray(paths["crack__face"], np.int64)
    line_of = np.repeat(np.arange(paths.n_lines), np.diff(offsets))
    starts = np.ones(len(pts3), bool)
    starts[offsets[1:] - 1] = False
    seg = np.nonzero(starts)[0]                                   # segment i -> i+1
    sp = patch[face[seg]]
    new_run = np.ones(len(seg), bool)
    new_run[1:] = (line_of[seg[1:]] != line_of[seg[:-1]]) | (sp[1:] != sp[:-1]) | (seg[1:] != seg[:-1] + 1)
    run = np.cumsum(new_run) - 1
    run_end = np.append(new_run[1:], True)
    # each run: its segments' start points, then its last segment's end point
    idx = np.insert(seg, np.nonzero(run_end)[0] + 1, seg[run_end] + 1)
    pt_patch = np.insert(sp, np.nonzero(run_end)[0] + 1, sp[run_end])
    counts = np.bincount(run, minlength=int(run.max()) + 1 if len(run) else 0) + 1
    used = np.unique(sp)
    # per patch: a frame in its plane, outline edges, placement on the sheet
    first = np.full(patch.max() + 1, len(f))
    np.minimum.at(first, patch, np.arange(len(f)))
    fr = _PatchFrames(v, f, first)
    in_used = np.isin(patch, used)
    corners = fr.to_2d(np.repeat(first[patch[in_used]], 3), v[f[in_used]].reshape(-1, 3))
    cpatch = np.repeat(patch[in_used], 3)
    lo = np.full((patch.max() + 1, 2), np.inf)
    hi = np.full((patch.max() + 1, 2), -np.inf)
    np.minimum.at(lo, cpatch, corners)
    np.maximum.at(hi, cpatch, corners)
    size = hi[used] - lo[used]
    shift = np.zeros((patch.max() + 1, 2))
    shift[used] = _shelf(size, gap * float(size.max())) - lo[used]
    xy = fr.to_2d(first[pt_patch], pts3[idx]) + shift[pt_patch]
    # outline: facet edges of a used patch that are not shared within the patch
    e = np.sort(np.stack([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]], 1), axis=2).reshape(-1, 2)
    ep = np.repeat(patch, 3)
    keep = np.isin(ep, used)
    key = np.column_stack([e, ep])[keep]
    uniq, cnt = np.unique(key, axis=0, return_counts=True)
    border = uniq[cnt == 1]
    bf = np.repeat(first[border[:, 2]], 2)
    bxy = fr.to_2d(bf, v[border[:, :2].ravel()]) + shift[np.repeat(border[:, 2], 2)]
    w = np.asarray(paths["crack__width"], float)[idx]
    n_runs, n_edges = len(counts), len(border)
    layer = np.asarray(paths["crack__layer"], np.int64)[line_of[seg[new_run]]] if "crack__layer" in paths \
        else np.zeros(n_runs, np.int64)
    ctype = np.asarray(paths["crack__type"], np.int64)[line_of[seg[new_run]]] if "crack__type" in paths \
        else np.zeros(n_runs, np.int64)
    all_pts = np.vstack([xy, bxy])
    offs = np.concatenate([[0], np.cumsum(np.concatenate([counts, np.full(n_edges, 2)]))])
    out = Polylines(all_pts, offs)
    out.add_field("crack__width", np.concatenate([w, np.zeros(2 * n_edges)]), at="point", units="length")
    out.add_field("crack__layer", np.concatenate([layer, np.full(n_edges, -1)]), at="line", units="")
    out.add_field("crack__type", np.concatenate([ctype, np.full(n_edges, -1)]), at="line", units="")
    return out


class _PatchFrames:
    """2-D frames of planar patches, indexed by the patch's first facet: the world x axis (y for
    patches facing x) projected into the plane, so a mesh in the xy plane keeps its x and y."""

    def __init__(self, v: np.ndarray, f: np.ndarray, first: np.ndarray) -> None:
        n = geo.face_normals(v, f)
        self.origin = v[f[:, 0]]
        axis = np.where((np.abs(n[:, 0]) > 0.9)[:, None], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0])
        ex = axis - np.sum(axis * n, axis=1)[:, None] * n
        self.ex = ex / np.linalg.norm(ex, axis=1, keepdims=True)
        self.ey = np.cross(n, self.ex)

    def to_2d(self, face: np.ndarray, xyz: np.ndarray) -> np.ndarray:
        d = xyz - self.origin[face]
        return np.column_stack([np.sum(d * self.ex[face], 1), np.sum(d * self.ey[face], 1)])


def _shelf(size: np.ndarray, gap: float) -> np.ndarray:
    """Lower-left corners placing rectangles ``size`` (p, 2) in rows about as wide as tall."""
    width = max(float(np.sqrt(np.sum((size[:, 0] + gap) * (size[:, 1] + gap))) * 1.2), float(size[:, 0].max()))
    pos = np.zeros_like(size)
    x = y = row = 0.0
    for i, (w, h) in enumerate(size):               # one placement per planar patch (few)
        if x > 0 and x + w > width:
            x, y, row = 0.0, y - row - gap, 0.0
        pos[i] = (x, y - h)
        x += w + gap
        row = max(row, h)
    return pos
