"""2-D outlines and profiles to 3-D meshes: extrusion (slabs, holes kept) and lathing (a vase, cup or ring).

They let a snaxel cloud outline or a smoothed contour become a surface that mesh automata
grow on. Caps are triangulated from the outline plus interior Poisson-disk points, so the
mesh has well-shaped triangles inside (surface cells need them), not long fan slivers.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from ..domains import Polylines, TriMesh
from ..errors import InputError
from ..geometry import ccw_faces, ccw_ring, orient2d, signed_area
from ..params import param
from ..rules import RuleBase
from ..state import State


FILL_RULES = ("evenodd", "nonzero")


def subdivide_ring(ring: np.ndarray, spacing: float) -> np.ndarray:
    """The ring's own corners plus points splitting every side longer than ``spacing`` evenly.

    Corners are kept, so a straight-sided outline keeps its exact area (an arc-length resampling
    would cut its corners); a densely sampled curve is first thinned by Douglas-Peucker within
    2 % of ``spacing`` (see :func:`outline_polygons`).
    """
    r = np.asarray(ring, dtype=np.float64)[:, :2]
    if np.allclose(r[0], r[-1]):
        r = r[:-1]
    b = np.roll(r, -1, axis=0)
    n = np.maximum(1, np.ceil(np.linalg.norm(b - r, axis=1) / spacing).astype(np.int64))
    t = np.arange(n.sum()) - np.repeat(np.cumsum(n) - n, n)
    t = t / np.repeat(n, n)
    a = np.repeat(r, n, axis=0)
    return a + t[:, None] * (np.repeat(b, n, axis=0) - a)


def winding_numbers(ring: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Signed number of times a closed ring (k, 2) winds around each point (n, 2)."""
    a, b = ring[None, :, :], np.roll(ring, -1, axis=0)[None, :, :]
    p = points[:, None, :]
    cross = (b[..., 0] - a[..., 0]) * (p[..., 1] - a[..., 1]) - (b[..., 1] - a[..., 1]) * (p[..., 0] - a[..., 0])
    up = (a[..., 1] <= p[..., 1]) & (b[..., 1] > p[..., 1]) & (cross > 0)
    down = (a[..., 1] > p[..., 1]) & (b[..., 1] <= p[..., 1]) & (cross < 0)
    return up.sum(axis=1) - down.sum(axis=1)


def outline_polygons(pl: Polylines, name: str, fill: str, spacing: float) -> list:
    """The region the closed rings of ``pl`` enclose, as shapely Polygons with holes, one per part.

    The rings' union of boundaries cuts the plane into faces (shapely's polygonize); a face is
    inside by the SVG fill rule: ``evenodd`` (an odd number of rings around it: a ring inside
    another is a hole whatever its direction) or ``nonzero`` (the signed windings do not cancel:
    overlapping same-direction rings merge, a reversed inner ring is a hole).
    """
    import shapely

    rings = [np.asarray(pl.line(i), np.float64)[:, :2] for i in range(pl.n_lines)
             if pl.closed[i] and len(pl.line(i)) >= 3]
    rings = [r[:-1] if np.allclose(r[0], r[-1]) else r for r in rings]
    rings = [r for r in rings if abs(signed_area(r)) > 0]
    if not rings:
        raise InputError(f"Polylines {name!r} hold no closed ring with area to use as an outline")
    edges = shapely.union_all([shapely.LineString(np.vstack([r, r[:1]])) for r in rings])
    faces = list(shapely.get_parts(shapely.polygonize(shapely.get_parts(edges))))
    faces = [f for f in faces if f.area > 0]
    inside = np.array([pt.coords[0] for pt in (f.point_on_surface() for f in faces)]).reshape(-1, 2)
    total = sum(winding_numbers(r, inside) for r in rings)
    keep = total % 2 == 1 if fill == "evenodd" else total != 0
    region = shapely.union_all([f for f, k in zip(faces, keep) if k])
    region = shapely.simplify(region, 0.02 * spacing, preserve_topology=True)
    parts = [g for g in shapely.get_parts(region) if g.geom_type == "Polygon" and g.area > 0]
    if not parts:
        raise InputError(f"the closed rings of {name!r} enclose no area under the {fill!r} fill rule")
    return sorted(parts, key=lambda g: -g.area)


def delaunay(pts: np.ndarray) -> np.ndarray:
    """Delaunay triangles (scipy/Qhull) with no zero-area triangle.

    Collinear boundary samples make Qhull merge cocircular facets and triangulate them with flat
    triangles (a, m, b), m on the segment ab. Each is removed by flipping ab in the quadrilateral
    it forms with its neighbour (a, b, c) across ab into (a, m, c) and (m, b, c), the
    triangulation of that facet without the flat one; a flat triangle on the hull is dropped.
    This runs once per conversion, over the few flat triangles only.
    """
    from scipy.spatial import Delaunay

    faces = Delaunay(pts).simplices.copy()
    tol = 1e-12 * float(np.ptp(pts, axis=0).max()) ** 2

    def is_flat(f: np.ndarray) -> bool:
        q = pts[f][:, None, :]
        return abs(float(orient2d(q[0], q[1], q[2])[0])) <= tol

    for _ in range(len(faces)):
        p = pts[faces]
        flats = np.nonzero(np.abs(orient2d(p[:, 0], p[:, 1], p[:, 2])) <= tol)[0]
        if len(flats) == 0:
            return faces
        for i in flats:                     # a fan of flats along a line: start from its far end
            f = faces[i]
            k = int(np.argmax(np.linalg.norm(pts[f] - pts[np.roll(f, -1)], axis=1)))
            a, b, m = f[k], f[(k + 1) % 3], f[(k + 2) % 3]       # m lies on the long side ab
            other = np.nonzero((faces == a).any(1) & (faces == b).any(1))[0]
            other = other[other != i]
            if len(other) == 0:
                faces = np.delete(faces, i, axis=0)
                break
            g = faces[other[0]]
            if is_flat(g):
                continue
            c = g[(g != a) & (g != b)][0]
            faces[i], faces[other[0]] = (a, m, c), (m, b, c)
            break
        else:
            break
    raise InputError("could not remove the flat triangles of the caps")


def _edge_codes(a: np.ndarray, b: np.ndarray, n: int) -> np.ndarray:
    return np.minimum(a, b).astype(np.int64) * n + np.maximum(a, b)


def triangulate_polygon(poly, spacing: float, rng: np.random.Generator,
                        max_rounds: int = 40) -> tuple[np.ndarray, np.ndarray, list[int]]:
    """(points, ccw faces, boundary ring sizes) covering a shapely Polygon with holes.

    Boundary points come first, ring after ring (the exterior counter-clockwise, each hole
    clockwise, so a wall built along them faces out of the material), then interior Poisson-disk
    samples. Delaunay of them all must contain every boundary side: a side it misses (a sharp
    tip, a narrow neck, an interior sample too close) is split at its midpoint and the samples
    inside its diametral circle dropped, until none is missing (a conforming Delaunay
    triangulation); then the triangles inside the polygon are exactly those whose centroid is.
    """
    import shapely
    from scipy.spatial import cKDTree

    from .poisson import poisson_disk

    rings = [ccw_ring(subdivide_ring(np.asarray(poly.exterior.coords), spacing))]
    rings += [ccw_ring(subdivide_ring(np.asarray(h.coords), spacing))[::-1] for h in poly.interiors]
    x0, y0, x1, y1 = poly.bounds
    inner = poisson_disk(rng, (x1 - x0, y1 - y0), spacing, origin=(x0, y0))
    inner = inner[shapely.contains_xy(poly.buffer(-0.5 * spacing), inner[:, 0], inner[:, 1])]
    for _ in range(max_rounds):
        pts = np.vstack(rings + [inner])
        faces = delaunay(pts)
        have = np.unique(np.concatenate([_edge_codes(faces[:, k], faces[:, (k + 1) % 3], len(pts))
                                         for k in range(3)]))
        start, missing_mid, missing_rad, new_rings = 0, [], [], []
        for r in rings:
            idx = np.arange(start, start + len(r))
            start += len(r)
            miss = ~np.isin(_edge_codes(idx, np.roll(idx, -1), len(pts)), have)
            mid = 0.5 * (r[miss] + np.roll(r, -1, axis=0)[miss])
            missing_mid.append(mid)
            missing_rad.append(0.5 * np.linalg.norm(np.roll(r, -1, axis=0)[miss] - r[miss], axis=1))
            new_rings.append(np.insert(r, np.nonzero(miss)[0] + 1, mid, axis=0))
        mids, rads = np.vstack(missing_mid), np.concatenate(missing_rad)
        if len(mids) == 0:
            cen = pts[faces].mean(axis=1)
            faces = faces[shapely.contains_xy(poly, cen[:, 0], cen[:, 1])]
            return pts, ccw_faces(pts, faces), [len(r) for r in rings]
        if len(inner):
            tree = cKDTree(inner)
            near = tree.query_ball_point(mids, rads * (1 + 1e-9))
            drop = np.unique(np.concatenate([np.asarray(n, np.int64) for n in near]))
            inner = np.delete(inner, drop, axis=0)
        rings = new_rings
    raise InputError(f"the outline's boundary could not be kept in the caps after "
                     f"{max_rounds} refinements (self-touching outline?)")


def slab(pts: np.ndarray, faces: np.ndarray, ring_sizes: list[int], depth: float,
         layers: int) -> tuple[np.ndarray, np.ndarray]:
    """A closed slab from a triangulated 2-D region: top cap at z = depth, bottom cap at 0, and a
    wall of ``layers`` rows along every boundary ring (boundary points first in ``pts``)."""
    n, nb = len(pts), sum(ring_sizes)
    z = np.linspace(0.0, depth, layers + 1)
    verts = [np.column_stack([pts, np.full(n, depth)]), np.column_stack([pts, np.zeros(n)])]
    verts += [np.column_stack([pts[:nb], np.full(nb, z[k])]) for k in range(1, layers)]
    level = [np.arange(nb) + n] + [2 * n + (k - 1) * nb + np.arange(nb) for k in range(1, layers)] + [np.arange(nb)]
    out = [faces, faces[:, ::-1] + n]
    start = 0
    for size in ring_sizes:
        idx = np.arange(start, start + size)
        start += size
        for lo_level, hi_level in zip(level[:-1], level[1:]):
            lo, hi = lo_level[idx], hi_level[idx]
            lo2, hi2 = np.roll(lo, -1), np.roll(hi, -1)
            out += [np.stack([lo, lo2, hi2], 1), np.stack([lo, hi2, hi], 1)]
    return np.vstack(verts), np.vstack(out)


@dataclass(kw_only=True)
class Extrude(RuleBase):
    """Converter: the region the closed rings of a Polylines enclose, extruded into closed slabs.

    Every shape becomes its own watertight part, holes included (a letter O, a logo with a
    cut-out): the rings are combined by the SVG fill rule (``evenodd`` by default: a ring inside
    another is a hole), caps are triangulated with the holes, and walls run round the outside
    and round every hole. A cloud, contour or drawing becomes solids for mesh automata.
    """

    name: ClassVar[str] = "mesh.extrude"
    uses: ClassVar[dict[str, str]] = {"{lines}": "Polylines"}
    creates: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "points.poisson_disk", "params": {"radius": 0.1}}, {"rule": "mesh.delaunay"},
        {"rule": "mesh.boundary"}, {"rule": "mesh.extrude", "params": {"lines": "outline", "spacing": 0.1}})

    lines: str = param("outline", doc="Polylines whose closed rings are extruded (open lines are ignored)")
    mesh: str = param("solid", doc="name of the TriMesh to create")
    depth: float = param(0.1, gt=0.0, units="length", doc="extrusion depth along z")
    spacing: float = param(0.02, gt=0.0, units="length", doc="target edge length of the mesh")
    fill: str = param("evenodd", choices=FILL_RULES,
                      doc="SVG fill rule: evenodd (nested rings alternate solid/hole) or nonzero (by direction)")

    def check_chain(self, earlier: list[RuleBase]) -> None:
        """An SVG read by an earlier lines.load must have a closed path to extrude."""
        from .lines import LoadLines

        source = [r for r in earlier if self.lines in r.domains_created()]
        if source and isinstance(source[-1], LoadLines):
            try:
                pl = source[-1].read(source[-1].recipe_dir)
            except InputError:
                return                      # lines.load reports its own file problems
            if not pl.closed.any():
                raise ValueError(f"{Path(source[-1].file).name}: no closed path (an outline ending in Z, "
                                 "or a rect/circle/polygon) to extrude")

    def step(self, state: State) -> bool:
        parts = outline_polygons(state.get(self.lines, Polylines), self.lines, self.fill, self.spacing)
        rng = state.rng()
        layers = max(1, int(np.ceil(self.depth / self.spacing)))
        verts, faces, offset = [], [], 0
        for poly in parts:
            pts, tris, ring_sizes = triangulate_polygon(poly, self.spacing, rng)
            v, f = slab(pts, tris, ring_sizes, self.depth, layers)
            verts.append(v)
            faces.append(f + offset)
            offset += len(v)
        mesh = TriMesh(np.vstack(verts), np.vstack(faces))
        state.add_domain(self.mesh, mesh)
        state.report(f"{self.mesh}.parts", len(parts))
        state.report(f"{self.mesh}.holes", sum(len(p.interiors) for p in parts))
        state.report(f"{self.mesh}.area", float(sum(p.area for p in parts)))
        return True


def outward(verts: np.ndarray, faces: np.ndarray) -> np.ndarray:
    """Faces wound so a closed surface has positive signed volume (normals point out)."""
    f = faces
    vol = np.sum(np.einsum("ij,ij->i", verts[f[:, 0]], np.cross(verts[f[:, 1]], verts[f[:, 2]])))
    return f[:, ::-1].copy() if vol < 0 else f


def revolve(profile: np.ndarray, sections: int) -> tuple[np.ndarray, np.ndarray]:
    """Closed surface of revolution about z of a (k, 2) profile (r, z) that starts and ends on
    the axis (r = 0).  Returns (vertices, faces) with outward-facing triangles."""
    p = np.asarray(profile, dtype=float)
    if len(p) < 3 or p[0, 0] != 0 or p[-1, 0] != 0 or np.any(p[1:-1, 0] <= 0):
        raise InputError("revolve: profile must start and end on the axis (r = 0) and stay off it between")
    if sections < 3:
        raise InputError(f"revolve: need at least 3 sections, got {sections}")
    ring = p[1:-1]
    k = len(ring)
    a = 2 * np.pi * np.arange(sections) / sections
    verts = np.column_stack([
        (ring[:, 0][:, None] * np.cos(a)[None, :]).ravel(),
        (ring[:, 0][:, None] * np.sin(a)[None, :]).ravel(),
        np.repeat(ring[:, 1], sections)])
    bottom, top = len(verts), len(verts) + 1
    verts = np.vstack([verts, [0, 0, p[0, 1]], [0, 0, p[-1, 1]]])
    s = np.arange(sections)
    s1 = (s + 1) % sections
    faces = [np.column_stack([np.full(sections, bottom), s1, s])]
    for r in range(k - 1):
        a0, b0 = r * sections + s, r * sections + s1
        a1, b1 = (r + 1) * sections + s, (r + 1) * sections + s1
        faces += [np.column_stack([a0, b0, b1]), np.column_stack([a0, b1, a1])]
    last = (k - 1) * sections
    faces.append(np.column_stack([np.full(sections, top), last + s, last + s1]))
    f = np.vstack(faces).astype(np.int64)
    f = outward(verts, f)
    return verts, f


def revolve_loop(profile: np.ndarray, sections: int) -> tuple[np.ndarray, np.ndarray]:
    """Closed ring surface (genus 1) revolving a closed (k, 2) profile loop with r > 0."""
    p = np.asarray(profile, dtype=float)
    if len(p) < 3 or np.any(p[:, 0] <= 0):
        raise InputError("revolve: a loop profile needs at least 3 points, all with r > 0")
    if sections < 3:
        raise InputError(f"revolve: need at least 3 sections, got {sections}")
    k = len(p)
    a = 2 * np.pi * np.arange(sections) / sections
    verts = np.column_stack([(p[:, 0][:, None] * np.cos(a)).ravel(),
                             (p[:, 0][:, None] * np.sin(a)).ravel(), np.repeat(p[:, 1], sections)])
    r = np.arange(k)[:, None]
    s = np.arange(sections)[None, :]
    a0 = (r * sections + s).ravel()
    b0 = (r * sections + (s + 1) % sections).ravel()
    a1 = (((r + 1) % k) * sections + s).ravel()
    b1 = (((r + 1) % k) * sections + (s + 1) % sections).ravel()
    f = np.vstack([np.column_stack([a0, b0, b1]), np.column_stack([a0, b1, a1])]).astype(np.int64)
    f = outward(verts, f)
    return verts, f



def lathe(profile: np.ndarray, sections: int, closed: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, faces) of a (k, 2) profile (r, z) revolved about z.

    A closed profile (r > 0) gives a ring, a profile from the axis back to the axis a closed
    solid (both outward-wound), any other an open surface (a tube, a vase wall).
    """
    prof = np.array(profile, dtype=np.float64)
    if prof.ndim != 2 or prof.shape[1] != 2 or len(prof) < 2:
        raise InputError(f"lathe: the profile needs at least two (r, z) points, got shape {prof.shape}")
    if (prof[:, 0] < -1e-12).any():
        raise InputError("lathe: profile r (radius) must be >= 0")
    if closed:
        return revolve_loop(prof, sections)
    on_axis = np.abs(prof[:, 0]) < 1e-12
    if on_axis[0] and on_axis[-1] and not on_axis[1:-1].any():
        prof[on_axis, 0] = 0.0
        return revolve(prof, sections)
    k, s = len(prof), sections
    ang = 2 * np.pi * np.arange(s) / s
    verts = np.stack([prof[:, 0:1] * np.cos(ang), prof[:, 0:1] * np.sin(ang),
                      np.repeat(prof[:, 1:2], s, axis=1)], axis=2).reshape(-1, 3)
    idx = np.arange(k * s).reshape(k, s)
    a, b = idx[:-1], np.roll(idx[:-1], -1, axis=1)
    c, d = idx[1:], np.roll(idx[1:], -1, axis=1)
    faces = np.concatenate([np.stack([a, b, d], -1).reshape(-1, 3), np.stack([a, d, c], -1).reshape(-1, 3)])
    from .meshes import clean_mesh

    m = clean_mesh(TriMesh(verts, faces))          # welds the seam and the axis points
    return m.vertices, m.faces


@dataclass(kw_only=True)
class Lathe(RuleBase):
    """Generator or converter: a profile (r = radius, z = height) revolved about the z axis.

    Cups, vases, bowls and rings: the thesis's cup objects and plate 2-9's 32-facet ring are
    lathed profiles. The profile is ``profile`` (``loop`` closes it) or, with ``lines``, the first
    line of a Polylines (x = r, y = z; closed if that line is). From the axis back to the axis it
    gives a closed solid, a closed loop off the axis a ring, any other profile an open surface.
    """

    name: ClassVar[str] = "mesh.lathe"
    uses: ClassVar[dict[str, str]] = {"{lines}": "Polylines"}
    creates: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "points.poisson_disk", "params": {"radius": 0.1}}, {"rule": "mesh.delaunay"},
        {"rule": "mesh.boundary"}, {"rule": "mesh.lathe", "params": {"lines": "outline", "sections": 12}})

    profile: list[list[float]] = param([], doc="(r, z) points of the profile (or give lines)")
    loop: bool = param(False, doc="profile is a closed loop off the axis (a ring)")
    lines: str = param("", doc="Polylines whose first line is the profile (x = r, y = z), instead of profile")
    mesh: str = param("mesh", doc="name of the TriMesh to create")
    sections: int = param(64, ge=3, le=4096, doc="segments around the axis")

    def validate(self) -> None:
        if bool(self.lines) == bool(self.profile):
            raise ValueError("give exactly one of profile ([[r, z], ...]) and lines (a Polylines name)")
        if self.lines and self.loop:
            raise ValueError("loop goes with profile; a Polylines line says itself whether it is closed")
        if any(len(p) != 2 for p in self.profile):
            raise ValueError("profile must be a list of [r, z] points")

    def domains_used(self) -> dict[str, str]:
        return {self.lines: "Polylines"} if self.lines else {}

    def step(self, state: State) -> bool:
        if self.lines:
            pl = state.get(self.lines, Polylines)
            verts, faces = lathe(pl.line(0)[:, :2], self.sections, bool(pl.closed[0]))
        else:
            verts, faces = lathe(np.asarray(self.profile, dtype=np.float64), self.sections, self.loop)
        state.add_domain(self.mesh, TriMesh(verts, faces))
        state.report(f"{self.mesh}.n_faces", len(faces))
        return True
