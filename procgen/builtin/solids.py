"""2-D outlines and profiles to 3-D meshes: extrusion (a slab) and lathing (a vase, cup or ring).

They let a snaxel cloud outline or a smoothed contour become a surface that mesh automata
grow on. Caps are triangulated from the outline plus interior Poisson-disk points, so the
mesh has well-shaped triangles inside (surface cells need them), not long fan slivers.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..domains import Polylines, TriMesh
from ..errors import InputError
from ..geometry import ccw_faces, ccw_ring, signed_area
from ..params import param
from ..rules import RuleBase
from ..state import State


def resample_ring(ring: np.ndarray, spacing: float) -> np.ndarray:
    """Points every ``spacing`` along a closed ring (at least 8), counter-clockwise."""
    ring = np.asarray(ring, dtype=np.float64)[:, :2]
    if np.allclose(ring[0], ring[-1]):
        ring = ring[:-1]
    closed = np.vstack([ring, ring[:1]])
    seg = np.linalg.norm(np.diff(closed, axis=0), axis=1)
    s = np.concatenate([[0], np.cumsum(seg)])
    n = max(8, int(np.ceil(s[-1] / spacing)))
    t = np.linspace(0, s[-1], n, endpoint=False)
    return ccw_ring(np.column_stack([np.interp(t, s, closed[:, 0]), np.interp(t, s, closed[:, 1])]))


def triangulate_polygon(ring: np.ndarray, spacing: float, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(points, ccw faces) covering the polygon: boundary every ``spacing`` + interior samples.

    Delaunay of boundary + interior points, keeping triangles whose centroid lies inside; with
    the boundary sampled as densely as the interior, Delaunay recovers the boundary edges.
    """
    import shapely
    from scipy.spatial import Delaunay

    from .poisson import poisson_disk

    boundary = resample_ring(ring, spacing)
    poly = shapely.Polygon(boundary)
    if not poly.is_valid or poly.area <= 0:
        raise InputError("outline is not a simple polygon with area (self-intersecting or degenerate)")
    x0, y0, x1, y1 = poly.bounds
    inner = poisson_disk(rng, (x1 - x0, y1 - y0), spacing, origin=(x0, y0))
    keep = shapely.contains_xy(poly.buffer(-0.5 * spacing), inner[:, 0], inner[:, 1])
    pts = np.vstack([boundary, inner[keep]])
    faces = Delaunay(pts).simplices
    cen = pts[faces].mean(axis=1)
    faces = faces[shapely.contains_xy(poly, cen[:, 0], cen[:, 1])]
    return pts, ccw_faces(pts, faces)


def _outer_ring(pl: Polylines, which: str) -> np.ndarray:
    rings = [pl.line(i) for i in range(pl.n_lines) if pl.closed[i] and len(pl.line(i)) >= 3]
    if not rings:
        raise InputError(f"{which}: the Polylines hold no closed ring to use as an outline")
    areas = [abs(signed_area(r)) for r in rings]
    return rings[int(np.argmax(areas))]


@dataclass(kw_only=True)
class Extrude(RuleBase):
    """Converter: the largest closed outline of a Polylines extruded into a closed slab mesh.

    A cloud or contour becomes a watertight solid (caps + side wall) for mesh automata.
    """

    name: ClassVar[str] = "mesh.extrude"
    uses: ClassVar[dict[str, str]] = {"{lines}": "Polylines"}
    creates: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "points.poisson_disk", "params": {"radius": 0.1}}, {"rule": "mesh.delaunay"},
        {"rule": "mesh.boundary"}, {"rule": "mesh.extrude", "params": {"lines": "outline", "spacing": 0.1}})

    lines: str = param("outline", doc="Polylines whose largest closed ring is extruded")
    mesh: str = param("solid", doc="name of the TriMesh to create")
    depth: float = param(0.1, gt=0.0, units="length", doc="extrusion depth along z")
    spacing: float = param(0.02, gt=0.0, units="length", doc="target edge length of the mesh")

    def step(self, state: State) -> bool:
        ring = _outer_ring(state.get(self.lines, Polylines), self.name)
        pts, faces = triangulate_polygon(ring, self.spacing, state.rng())
        n = len(pts)
        nb = max(8, int(np.ceil(_perimeter(ring) / self.spacing)))  # boundary points come first
        layers = max(1, int(np.ceil(self.depth / self.spacing)))
        z = np.linspace(0.0, self.depth, layers + 1)
        verts = [np.column_stack([pts, np.full(n, self.depth)]), np.column_stack([pts, np.zeros(n)])]
        top = faces
        bottom = faces[:, ::-1] + n
        rings = [np.arange(nb) + n if k == 0 else None for k in range(layers + 1)]
        wall_ids = [np.arange(nb) + n]                        # z = 0 ring is the bottom cap boundary
        offset = 2 * n
        for k in range(1, layers):
            verts.append(np.column_stack([pts[:nb], np.full(nb, z[k])]))
            wall_ids.append(np.arange(nb) + offset)
            offset += nb
        wall_ids.append(np.arange(nb))                        # z = depth ring is the top cap boundary
        del rings
        walls = []
        for lo, hi in zip(wall_ids[:-1], wall_ids[1:]):
            lo2, hi2 = np.roll(lo, -1), np.roll(hi, -1)
            walls += [np.stack([lo, lo2, hi2], 1), np.stack([lo, hi2, hi], 1)]
        mesh = TriMesh(np.vstack(verts), np.vstack([top, bottom, *walls]))
        state.add_domain(self.mesh, mesh)
        return True


def _perimeter(ring: np.ndarray) -> float:
    r = np.asarray(ring)[:, :2]
    if np.allclose(r[0], r[-1]):
        r = r[:-1]
    return float(np.linalg.norm(np.diff(np.vstack([r, r[:1]]), axis=0), axis=1).sum())


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
