"""Closest points on a triangle mesh: harmonized cells go back onto the source polygons.

Harmonization (section 4.4) moves cells in their tangent planes; on a curved or creased object
that lifts them off the surface a little every step.  The paper leaves this open; here a cell
can be put back at the closest point of the source polygons after each step.  Candidates are
found with a KD-tree of triangle centres: a triangle of centre c and circumradius R can only
beat the distance U to the nearest centre's triangle if |p - c| <= U + R, so the search is exact
(not a k-nearest guess); the closest point on each candidate is Ericson's region test
("Real-Time Collision Detection", 5.1.5), vectorised.
"""
from __future__ import annotations

import numpy as np


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("ij,ij->i", a, b)


def closest_on_triangles(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Closest point of triangle (a[i], b[i], c[i]) to p[i], for every row (Voronoi regions)."""
    ab, ac, ap = b - a, c - a, p - a
    d1, d2 = _dot(ab, ap), _dot(ac, ap)
    bp = p - b
    d3, d4 = _dot(ab, bp), _dot(ac, bp)
    cp = p - c
    d5, d6 = _dot(ab, cp), _dot(ac, cp)
    va, vb, vc = d3 * d6 - d5 * d4, d5 * d2 - d1 * d6, d1 * d4 - d3 * d2
    with np.errstate(divide="ignore", invalid="ignore"):
        den = va + vb + vc
        v_in, w_in = vb / den, vc / den
        out = a + v_in[:, None] * ab + w_in[:, None] * ac                # inside the face
        t_bc = (d4 - d3) / ((d4 - d3) + (d5 - d6))
        t_ac = d2 / (d2 - d6)
        t_ab = d1 / (d1 - d3)
    # Ericson's tests in order: vertex a, vertex b, edge ab, vertex c, edge ac, edge bc, face;
    # the first that holds wins, so they are written here last-first
    regions = [
        ((va <= 0) & (d4 - d3 >= 0) & (d5 - d6 >= 0), b + t_bc[:, None] * (c - b)),
        ((vb <= 0) & (d2 >= 0) & (d6 <= 0), a + t_ac[:, None] * ac),
        ((d6 >= 0) & (d5 <= d6), c),
        ((vc <= 0) & (d1 >= 0) & (d3 <= 0), a + t_ab[:, None] * ab),
        ((d3 >= 0) & (d4 <= d3), b),
        ((d1 <= 0) & (d2 <= 0), a),
    ]
    for mask, point in regions:
        out = np.where(mask[:, None], point, out)
    return out


def closest_on_mesh(points: np.ndarray, vertices: np.ndarray,
                    faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(closest point, face, distance) on the mesh for every point (exact, ties: lowest face)."""
    from scipy.spatial import cKDTree

    p = np.asarray(points, float)
    tri = np.asarray(vertices, float)[np.asarray(faces, np.int64)]           # (m, 3, 3)
    centre = tri.mean(axis=1)
    radius = np.linalg.norm(tri - centre[:, None], axis=2).max(axis=1)
    tree = cKDTree(centre)
    _, near = tree.query(p)
    first = closest_on_triangles(p, *(tri[near, k] for k in range(3)))
    bound = np.linalg.norm(first - p, axis=1)
    cand = tree.query_ball_point(p, bound + radius.max() * (1 + 1e-9) + 1e-12)
    count = np.array([len(c) for c in cand])
    pid = np.repeat(np.arange(len(p)), count)
    fid = np.concatenate([np.asarray(c, np.int64) for c in cand]) if len(p) else np.zeros(0, np.int64)
    ok = np.linalg.norm(p[pid] - centre[fid], axis=1) <= bound[pid] + radius[fid] * (1 + 1e-9) + 1e-12
    pid, fid = pid[ok], fid[ok]
    q = closest_on_triangles(p[pid], *(tri[fid, k] for k in range(3)))
    d = np.linalg.norm(q - p[pid], axis=1)
    order = np.lexsort((fid, d, pid))
    best = order[np.concatenate([[True], pid[order][1:] != pid[order][:-1]])]
    return q[best], fid[best], d[best]
