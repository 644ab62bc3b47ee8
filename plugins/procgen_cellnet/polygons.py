"""Polygon input: planar 3-D polygons (convex, concave, holed; several objects) to triangles.

The paper feeds "any type of polygon" to the cell seeding (section 3.3, Figure 8: a pyramid
made of triangles, of convex or of concave polygons).  Only the union of a polygon's triangles
matters to the seeding, so each polygon is triangulated in its own plane by shapely's
constrained Delaunay triangulation (holes respected, no new vertices) and the triangles keep
the polygon, object and material ids as face fields; the triangles of every object face one
side, outward where it encloses something (orientation.py).  Bad polygons are refused in one line:
fewer than 3 vertices, not planar, zero area, self-intersecting, holes outside the outline.
"""
from __future__ import annotations

import numpy as np

from procgen import InputError, TriMesh

from .orientation import loop_normal, orient_polygons, wound

#: a polygon's vertices must lie within this fraction of its size of its best-fit plane
PLANAR_TOL = 1e-6


def _loop(points: list[list[float]], where: str) -> np.ndarray:
    p = np.asarray(points, float)
    if p.ndim != 2 or p.shape[1] != 3:
        raise InputError(f"{where}: every vertex needs 3 coordinates")
    if len(p) < 3:
        raise InputError(f"{where}: a polygon needs at least 3 vertices, got {len(p)}")
    return p


def triangulate_polygon(loops: list[list[list[float]]], where: str) -> np.ndarray:
    """(t, 3, 3) triangles of one planar polygon given as [outer, hole, hole, ...] loops."""
    import shapely

    if not loops:
        raise InputError(f"{where}: empty polygon (no outline)")
    rings = [_loop(lp, f"{where} loop {k}") for k, lp in enumerate(loops)]
    allp = np.concatenate(rings)
    centre = allp.mean(axis=0)
    _, sv, vt = np.linalg.svd(allp - centre)
    size = float(np.ptp(allp, axis=0).max())
    if sv[1] <= 1e-12 * max(size, 1e-300) * np.sqrt(len(allp)):
        raise InputError(f"{where}: polygon has zero area (collinear vertices)")
    n = vt[2]
    off = np.abs((allp - centre) @ n).max()
    if off > PLANAR_TOL * size:
        raise InputError(f"{where}: polygon is not planar (a vertex is {off:.3g} off its plane)")
    u, w = vt[0], vt[1]
    flat = [shapely.LinearRing(np.column_stack([(r - centre) @ u, (r - centre) @ w])) for r in rings]
    poly = shapely.Polygon(flat[0], flat[1:])
    if not poly.is_valid:
        reason = shapely.is_valid_reason(poly)
        raise InputError(f"{where}: invalid polygon ({reason}): self-intersecting outline or a "
                         "hole crossing it")
    tris = shapely.get_parts(shapely.constrained_delaunay_triangles(poly))
    xy = np.array([np.asarray(t.exterior.coords)[:3] for t in tris], float)
    return centre + xy[..., :1] * u + xy[..., 1:] * w


def polygons_mesh(polygons: list[list[list[list[float]]]], objects: list[int] | None,
                  materials: list[int] | None, where: str = "cellnet.polygons") -> TriMesh:
    """One TriMesh of every polygon's triangles, with ``face__polygon/object/material``."""
    if not polygons:
        raise InputError(f"{where}: no polygons")
    for name, ids in (("objects", objects), ("materials", materials)):
        if ids is not None and len(ids) != len(polygons):
            raise InputError(f"{where}: {name} has {len(ids)} entries for {len(polygons)} polygons")
    tris = [triangulate_polygon(loops, f"{where}: polygon {k}") for k, loops in enumerate(polygons)]
    # one side per object (orientation.py): every triangle faces its polygon's oriented normal
    wound_polys = []
    for loops in polygons:
        rings = [np.asarray(lp, float) for lp in loops]
        wound_polys.append(wound(rings, loop_normal(rings[0])))
    flips = orient_polygons(wound_polys)
    pid = []
    for k, t in enumerate(tris):
        n = loop_normal(wound_polys[k][0]) * (-1 if flips[k] else 1)
        back = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0]) @ n < 0
        t[back] = t[back][:, ::-1]
        pid.append(np.full(len(t), k))
    t = np.concatenate(tris)
    poly = np.concatenate(pid)
    verts = t.reshape(-1, 3)
    scale = max(float(np.ptp(verts, axis=0).max()), 1e-300)
    key = np.round(verts / (scale * 1e-12)).astype(np.int64)
    _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    mesh = TriMesh(verts[first], inv.ravel().reshape(-1, 3))
    mesh.add_field("face__polygon", poly.astype(np.int32), at="face", doc="source polygon")
    obj = np.zeros(len(polygons), np.int32) if objects is None else np.asarray(objects, np.int32)
    mat = np.zeros(len(polygons), np.int32) if materials is None else np.asarray(materials, np.int32)
    mesh.add_field("face__object", obj[poly], at="face", doc="source object")
    mesh.add_field("face__material", mat[poly], at="face", doc="material id")
    return mesh
