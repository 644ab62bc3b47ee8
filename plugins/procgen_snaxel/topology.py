"""The tessellation as the snake sees it: CCW neighbour rings, edge lengths, blocked vertices.

Snaxels live on Delaunay edges (thesis section 3.1). Every topological question the snake asks
("which edges leave this vertex, in angular order?", "which triangle lies left of this edge?")
is answered from one CSR ring per vertex sorted counter-clockwise by angle, built once.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from procgen.errors import InputError
from procgen.geometry import ccw_faces, orient2d


@dataclass(frozen=True)
class Topology:
    """Immutable tessellation topology for snaxel growth (all arrays flat, CSR rings)."""

    points: np.ndarray        # (n, 2) vertex positions
    faces: np.ndarray         # (m, 3) CCW triangles
    ring_ptr: np.ndarray      # (n+1,) CSR pointer into ring
    ring: np.ndarray          # neighbours of each vertex, CCW by angle
    hull: np.ndarray          # (n,) bool: vertex on the convex hull / mesh boundary
    mean_edge: float          # mean undirected edge length
    min_edge: float           # shortest edge length

    @property
    def n_vertices(self) -> int:
        return len(self.points)

    def neighbours(self, w: int) -> np.ndarray:
        return self.ring[self.ring_ptr[w]:self.ring_ptr[w + 1]]

    def left_vertex(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Third vertex of the triangle left of each directed edge u->v (-1 if none).

        (u, v, y) is CCW exactly when y follows v in u's CCW ring (and the wedge is a triangle).
        """
        u = np.asarray(u, np.int64)
        v = np.asarray(v, np.int64)
        out = np.full(u.shape, -1, np.int64)
        for i in range(u.size):     # test/diagnostic helper only, never on the per-step path
            nb = self.neighbours(int(u.flat[i]))
            k = int(np.flatnonzero(nb == v.flat[i])[0])
            y = int(nb[(k + 1) % len(nb)])
            a, b, c = self.points[u.flat[i]], self.points[v.flat[i]], self.points[y]
            cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
            out.flat[i] = y if cross > 0 else -1
        return out


def build_topology(points: np.ndarray, faces: np.ndarray) -> Topology:
    """Rings sorted by angle from a triangle list; raises InputError on a broken mesh."""
    pts = np.asarray(points, np.float64)
    tri = np.asarray(faces, np.int64)
    if pts.ndim != 2 or pts.shape[1] < 2 or len(pts) < 3:
        raise InputError(f"snaxel tessellation: need (n>=3, 2) vertices, got {pts.shape}")
    pts = pts[:, :2]
    if tri.ndim != 2 or tri.shape[1] != 3 or len(tri) == 0:
        raise InputError(f"snaxel tessellation: need (m, 3) triangles, got {tri.shape}")
    if tri.min() < 0 or tri.max() >= len(pts):
        raise InputError("snaxel tessellation: a face index is outside the vertex array")
    if np.any(orient2d(pts[tri[:, 0]], pts[tri[:, 1]], pts[tri[:, 2]]) == 0):
        raise InputError("snaxel tessellation: degenerate (zero-area) triangle")
    tri = ccw_faces(pts, tri)
    # directed half-edges of CCW triangles; each interior edge appears once per direction
    src = tri.ravel()
    dst = tri[:, [1, 2, 0]].ravel()
    n = len(pts)
    key = np.sort(src * n + dst)
    if np.any(key[1:] == key[:-1]):
        raise InputError("snaxel tessellation: a directed edge is shared by two triangles (non-manifold)")
    rev = dst * n + src
    at = np.minimum(np.searchsorted(key, rev), len(key) - 1)
    boundary_half = key[at] != rev
    hull = np.zeros(n, bool)
    hull[src[boundary_half]] = True
    hull[dst[boundary_half]] = True
    # directed neighbour lists: every half-edge plus the reverse of each boundary half-edge
    s = np.concatenate([src, dst[boundary_half]])
    d = np.concatenate([dst, src[boundary_half]])
    ang = np.arctan2(pts[d, 1] - pts[s, 1], pts[d, 0] - pts[s, 0]) + np.pi     # in [0, 2 pi]
    order = np.argsort(s * 8.0 + ang)        # by vertex, then CCW angle (angles < 8)
    s, d = s[order], d[order]
    ptr = np.zeros(n + 1, np.int64)
    ptr[1:] = np.cumsum(np.bincount(s, minlength=n))
    und = s < d
    elen = np.hypot(*(pts[d[und]] - pts[s[und]]).T)
    return Topology(points=pts, faces=tri, ring_ptr=ptr, ring=d.astype(np.int64), hull=hull,
                    mean_edge=float(elen.mean()), min_edge=float(elen.min()))
