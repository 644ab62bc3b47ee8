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


class SheetLayout:
    """Planar patches of a mesh placed side by side on a sheet: points and directions to 2-D."""

    def __init__(self, vertices: np.ndarray, faces: np.ndarray, use_faces: np.ndarray,
                 gap: float = 0.08) -> None:
        from procgen import TriMesh

        v, f = vertices, faces
        self.vertices, self.faces = v, f
        self.patch = planar_patches(v, f, np.asarray(TriMesh(v, f).face_adjacency))
        n_patch = int(self.patch.max()) + 1
        self.used = np.unique(self.patch[use_faces])
        self.first = np.full(n_patch, len(f))
        np.minimum.at(self.first, self.patch, np.arange(len(f)))
        self.frames = _PatchFrames(v, f, self.first)
        in_used = np.isin(self.patch, self.used)
        corners = self._plane(np.repeat(np.nonzero(in_used)[0], 3), v[f[in_used]].reshape(-1, 3))
        cpatch = np.repeat(self.patch[in_used], 3)
        lo = np.full((n_patch, 2), np.inf)
        hi = np.full((n_patch, 2), -np.inf)
        np.minimum.at(lo, cpatch, corners)
        np.maximum.at(hi, cpatch, corners)
        size = hi[self.used] - lo[self.used]
        self.shift = np.zeros((n_patch, 2))
        self.shift[self.used] = _shelf(size, gap * float(size.max())) - lo[self.used]

    def _plane(self, face: np.ndarray, xyz: np.ndarray) -> np.ndarray:
        return self.frames.to_2d(self.first[self.patch[face]], xyz)

    def to_sheet(self, face: np.ndarray, xyz: np.ndarray) -> np.ndarray:
        """Sheet positions (n, 2) of 3-D points lying on facets ``face``."""
        return self._plane(face, xyz) + self.shift[self.patch[face]]

    def direction(self, face: np.ndarray, vec: np.ndarray) -> np.ndarray:
        """Sheet directions (n, 2) of 3-D vectors in the planes of facets ``face``."""
        q = self.first[self.patch[face]]
        return np.column_stack([np.sum(vec * self.frames.ex[q], 1), np.sum(vec * self.frames.ey[q], 1)])

    def outlines(self) -> np.ndarray:
        """(E, 2, 2) sheet segments of the placed patches' border edges (edges not shared inside)."""
        f, v = self.faces, self.vertices
        e = np.sort(np.stack([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]], 1), axis=2).reshape(-1, 2)
        ep = np.repeat(self.patch, 3)
        keep = np.isin(ep, self.used)
        uniq, cnt = np.unique(np.column_stack([e, ep])[keep], axis=0, return_counts=True)
        border = uniq[cnt == 1]
        face = np.repeat(self.first[border[:, 2]], 2)
        return self.to_sheet(face, v[border[:, :2].ravel()]).reshape(-1, 2, 2)


def crack_sheet(cells, paths: Polylines, *, gap: float = 0.08) -> Polylines:
    """The paths on one flat sheet: crack pieces (point ``crack__width``, line ``crack__layer`` and
    ``crack__type``) followed by the patch outline edges (``crack__layer`` = -1)."""
    pts3 = np.asarray(paths.points, float)
    offsets = np.asarray(paths.offsets)
    face = np.asarray(paths["crack__face"], np.int64)
    line_of = np.repeat(np.arange(paths.n_lines), np.diff(offsets))
    starts = np.ones(len(pts3), bool)
    starts[offsets[1:] - 1] = False
    seg = np.nonzero(starts)[0]                                   # segment i -> i+1
    sheet = SheetLayout(cells.vertices, cells.faces, face[seg], gap)
    sp = sheet.patch[face[seg]]
    new_run = np.ones(len(seg), bool)
    new_run[1:] = (line_of[seg[1:]] != line_of[seg[:-1]]) | (sp[1:] != sp[:-1]) | (seg[1:] != seg[:-1] + 1)
    run = np.cumsum(new_run) - 1
    run_end = np.append(new_run[1:], True)
    # each run: its segments' start points, then its last segment's end point (same facet)
    idx = np.insert(seg, np.nonzero(run_end)[0] + 1, seg[run_end] + 1)
    pt_face = np.insert(face[seg], np.nonzero(run_end)[0] + 1, face[seg][run_end])
    counts = np.bincount(run) + 1
    xy = sheet.to_sheet(pt_face, pts3[idx])
    border = sheet.outlines()
    w = np.asarray(paths["crack__width"], float)[idx]
    n_runs, n_edges = len(counts), len(border)
    lines = line_of[seg[new_run]]
    layer = np.asarray(paths["crack__layer"], np.int64)[lines] if "crack__layer" in paths \
        else np.zeros(n_runs, np.int64)
    ctype = np.asarray(paths["crack__type"], np.int64)[lines] if "crack__type" in paths \
        else np.zeros(n_runs, np.int64)
    offs = np.concatenate([[0], np.cumsum(np.concatenate([counts, np.full(n_edges, 2)]))])
    out = Polylines(np.vstack([xy, border.reshape(-1, 2)]), offs)
    out.add_field("crack__width", np.concatenate([w, np.zeros(2 * n_edges)]), at="point", units="length")
    out.add_field("crack__layer", np.concatenate([layer, np.full(n_edges, -1)]), at="line", units="")
    out.add_field("crack__type", np.concatenate([ctype, np.full(n_edges, -1)]), at="line", units="")
    return out


def stress_flowers(cells, spectrum: np.ndarray, *, every: int = 4, size: float = 0.45,
                   gap: float = 0.08) -> Polylines:
    """"Stress flowers" (plate D-19): one 8-petal star per sampled cell on a flat sheet.

    ``spectrum`` (n, 4): intensities along 0, pi/4, pi/2, 3pi/4 of each cell's facet frame; a
    petal points each way along every axis (tension is centrally symmetric, thesis 5.2.3.a),
    its length log-compressed with one scale for the object (Appendix C step 4):
    size * every cells * log(1 + I) / log(1 + I_max), I in units of the mean intensity.
    Cells on a lattice of ``every`` cells of their facet's grid are drawn as closed lines, then
    the patch outlines as open two-point lines.
    """
    pick = np.nonzero(np.all(cells.ij % every == 0, axis=1) & cells.comp_in)[0]
    sheet = SheetLayout(cells.vertices, cells.faces, np.unique(cells.face[pick]), gap)
    s = np.asarray(spectrum, float)[pick]
    mean = max(float(np.mean(s)), 1e-300)
    radius = size * every * cells.size * np.log1p(s / mean) / np.log1p(max(float(s.max()), 1e-300) / mean)
    face = cells.face[pick]
    ang = np.arange(8) * np.pi / 4                              # petal tips, then the gaps between
    r_tip = np.concatenate([radius, radius], axis=1)             # axis k and its opposite k + 4
    r_in = 0.22 * radius.max(axis=1, keepdims=True) * np.ones((1, 8))
    ang_all = np.stack([ang, ang + np.pi / 8], axis=1).ravel()   # (16,)
    r_all = np.stack([r_tip, r_in], axis=2).reshape(len(pick), 16)
    fr = cells.layout.frames
    vec3 = (np.cos(ang_all)[None, :, None] * fr.ex[face][:, None, :]
            + np.sin(ang_all)[None, :, None] * fr.ey[face][:, None, :]) * r_all[..., None]
    centre = sheet.to_sheet(face, cells.center3d[pick])
    d2 = sheet.direction(np.repeat(face, 16), vec3.reshape(-1, 3)).reshape(len(pick), 16, 2)
    pts = (centre[:, None, :] + d2).reshape(-1, 2)
    border = sheet.outlines()
    n = len(pick)
    offs = np.concatenate([np.arange(n + 1) * 16, 16 * n + 2 * np.arange(1, len(border) + 1)])
    closed = np.concatenate([np.ones(n, bool), np.zeros(len(border), bool)])
    return Polylines(np.vstack([pts, border.reshape(-1, 2)]), offs, closed=closed)


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
