"""Triangle and polygon formulas every domain and plugin shares, written once.

``TriMesh`` caches their per-mesh results (``face_normals``, ``vertex_normals``, ``face_areas``);
code holding raw (vertices, faces) arrays, such as the surface plugin's cells or the preview
renderer, calls the functions here. All are vectorised over triangles.
"""
from __future__ import annotations

import numpy as np


def triangle_cross(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """(m, 3) cross products (b - a) x (c - a): twice the area along the normal; 2-D gets z = 0."""
    v = np.asarray(vertices, dtype=np.float64)
    if v.shape[1] == 2:
        v = np.column_stack([v, np.zeros(len(v))])
    a, b, c = v[faces[:, 0]], v[faces[:, 1]], v[faces[:, 2]]
    return np.cross(b - a, c - a)


def _unit(n: np.ndarray) -> np.ndarray:
    ln = np.linalg.norm(n, axis=1, keepdims=True)
    return np.divide(n, ln, out=np.zeros_like(n), where=ln > 0)


def face_normals(vertices: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Unit normals (m, 3) by the right-hand rule; zero for degenerate faces."""
    return _unit(triangle_cross(vertices, faces))


def vertex_normals(vertices: np.ndarray, faces: np.ndarray, *, weld: bool = False) -> np.ndarray:
    """Area-weighted unit vertex normals (n, 3); zero for unused vertices.

    ``weld`` sums over coincident vertices (positions equal to 1e-9), so a mesh split along UV
    seams still shades smoothly across them.
    """
    f = np.asarray(faces)
    cross = triangle_cross(vertices, f)
    n = len(vertices)
    ids = np.arange(n)
    if weld:
        _, ids = np.unique(np.round(np.asarray(vertices, dtype=np.float64), 9), axis=0, return_inverse=True)
        ids = ids.ravel()
    corner = ids[f.T.ravel()]                                  # corner 0 of every face, then 1, 2
    w = np.tile(cross, (3, 1))
    acc = np.column_stack([np.bincount(corner, w[:, k], minlength=n) for k in range(3)])
    return _unit(acc)[ids]


def orient2d(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """Twice the signed area of 2-D triangles (a, b, c), each (m, 2): > 0 counter-clockwise."""
    return (b[..., 0] - a[..., 0]) * (c[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (c[..., 0] - a[..., 0])


def ccw_faces(points: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """``faces`` with every clockwise triangle of the 2-D ``points`` reversed (a new array)."""
    f = np.array(faces, dtype=np.int64)
    cw = orient2d(points[f[:, 0]], points[f[:, 1]], points[f[:, 2]]) < 0
    f[cw] = f[cw][:, [0, 2, 1]]
    return f


def signed_area(ring: np.ndarray) -> float:
    """Shoelace area of a closed 2-D ring (k, 2) (last point joins the first): > 0 counter-clockwise."""
    x, y = ring[:, 0], ring[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(np.roll(x, -1), y))


def ccw_ring(ring: np.ndarray) -> np.ndarray:
    """The ring counter-clockwise (reversed when its signed area is negative)."""
    return ring[::-1] if signed_area(ring) < 0 else ring


def barycentric(corners: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Barycentric coordinates (n, 3) of points (n, d) in triangles (n, 3, d), d = 2 or 3.

    Exact for points in the triangle's plane (3-D points off it are projected onto it);
    a degenerate triangle gives finite, meaningless weights rather than NaN.
    """
    a = corners[:, 0]
    v0, v1, v2 = corners[:, 1] - a, corners[:, 2] - a, points - a
    if corners.shape[2] == 2:
        d = v0[:, 0] * v1[:, 1] - v1[:, 0] * v0[:, 1]
        d = np.where(np.abs(d) > 0, d, 1.0)
        l1 = (v2[:, 0] * v1[:, 1] - v1[:, 0] * v2[:, 1]) / d
        l2 = (v0[:, 0] * v2[:, 1] - v2[:, 0] * v0[:, 1]) / d
    else:
        d00, d01, d11 = (v0 * v0).sum(1), (v0 * v1).sum(1), (v1 * v1).sum(1)
        d20, d21 = (v2 * v0).sum(1), (v2 * v1).sum(1)
        den = d00 * d11 - d01 * d01
        den = np.where(np.abs(den) > 0, den, 1.0)
        l1, l2 = (d11 * d20 - d01 * d21) / den, (d00 * d21 - d01 * d20) / den
    return np.column_stack([1 - l1 - l2, l1, l2])
