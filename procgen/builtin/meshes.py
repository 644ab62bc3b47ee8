"""Mesh generators and converters: Delaunay, file loading, primitives, boundary loops."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Mapping

import numpy as np

from ..data import meshes_dir
from ..domains import PointSet, Polylines, TriMesh
from ..errors import InputError
from ..exchange.input_files import refuse_special
from ..exchange.mesh_read import check_mesh_file, read_mesh
from ..fields import FieldSpec
from ..geometry import ccw_faces
from ..params import param
from ..rules import RuleBase
from ..state import State


@dataclass(kw_only=True)
class DelaunayTessellation(RuleBase):
    """Converter: the Delaunay triangulation (scipy/Qhull) of a 2-D PointSet as a TriMesh.

    Triangles are stored counter-clockwise; point fields become vertex fields.
    """

    example: ClassVar[tuple[dict, ...]] = ({"rule": "points.poisson_disk", "params": {"radius": 0.08}}, {"rule": "mesh.delaunay"})
    name: ClassVar[str] = "mesh.delaunay"
    uses: ClassVar[dict[str, str]] = {"{points}": "PointSet"}
    creates: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    passes_fields: ClassVar[dict[str, str]] = {"{mesh}": "{points}"}

    points: str = param("points", doc="PointSet to triangulate")
    mesh: str = param("tessellation", doc="name of the TriMesh to create")

    def step(self, state: State) -> bool:
        from scipy.spatial import Delaunay, QhullError

        ps = state.get(self.points, PointSet)
        pts = ps.points[:, :2]
        if len(pts) < 3:
            raise InputError(f"mesh.delaunay: need at least 3 points, {self.points!r} has {len(pts)}")
        try:
            tri = Delaunay(pts)
        except QhullError as exc:
            raise InputError(f"mesh.delaunay: points are degenerate ({str(exc).splitlines()[0]})") from None
        mesh = TriMesh(pts, ccw_faces(pts, tri.simplices))
        mesh.copy_fields_from(ps, {"point": "vertex"})
        state.add_domain(self.mesh, mesh)
        state.report(f"{self.mesh}.n_vertices", mesh.n_vertices)
        state.report(f"{self.mesh}.n_faces", mesh.n_faces)
        return True


def resolve_mesh_path(path: str, base_dir: Path | None) -> Path:
    """Absolute path, path relative to the recipe's folder, or a name in procgen/data/meshes."""
    p = Path(path).expanduser()
    candidates = [p] if p.is_absolute() else ([base_dir / p] if base_dir else []) + [Path.cwd() / p, meshes_dir() / p]
    for c in candidates:
        refuse_special(c, path)
        if c.is_file():
            return c
    places = list(dict.fromkeys(str(c.parent) for c in candidates[:-1])) + ["the shipped meshes"] \
        if not p.is_absolute() else [str(p.parent)]
    raise InputError(f"file {path!r} not found (looked in: {', '.join(places)})")


#: face-corner texture coordinates read from a mesh file (the vocabulary's ``mesh__uv``)
UV_FIELD = "mesh__uv"


def load_mesh_file(path: Path) -> TriMesh:
    """Read OBJ/PLY/STL/OFF/glTF/GLB with trimesh (quads and n-gons triangulated), as one TriMesh.

    The file and every file it names are checked first (procgen.exchange.mesh_read: regular
    files only, bounded in size); materials are not read.

    Texture coordinates in the file become the face field ``mesh__uv`` (m, 3, 2): one UV per
    face corner, so a seam (one position, two UVs) keeps both sides' coordinates even after
    ``clean_mesh`` welds the positions into one vertex.
    """
    import trimesh

    loaded: Any = read_mesh(path)
    if not isinstance(loaded, trimesh.Trimesh) or len(loaded.faces) == 0 or len(loaded.vertices) < 3:
        raise InputError(f"mesh.load: {path.name}: no triangles in the file")
    faces = np.asarray(loaded.faces)
    v = np.asarray(loaded.vertices, dtype=np.float64)
    if v.ndim != 2 or v.shape[1] != 3 or faces.ndim != 2 or faces.shape[1] != 3:
        raise InputError(f"mesh.load: {path.name}: vertices are not 3-D points or faces not triangles")
    if not np.all(np.isfinite(v)):
        raise InputError(f"mesh.load: {path.name}: vertices contain NaN or inf")
    if faces.min() < 0 or faces.max() >= len(v):
        raise InputError(f"mesh.load: {path.name}: faces reference missing vertices")
    mesh = TriMesh(v, faces)
    uv = getattr(loaded.visual, "uv", None)
    if uv is not None and len(uv) == len(v):
        uv = np.asarray(uv, dtype=np.float64)[:, :2]
        if not np.all(np.isfinite(uv)):
            raise InputError(f"mesh.load: {path.name}: texture coordinates contain NaN or inf")
        mesh.add_field(UV_FIELD, uv[faces], at="face",
                       doc=f"texture coordinates of each face corner, from {path.name}")
    return mesh


@dataclass(kw_only=True)
class LoadMesh(RuleBase):
    """Load a triangle mesh from OBJ/PLY/STL (trimesh): quads and n-gons are triangulated.

    Duplicate vertices are merged and degenerate/duplicate faces dropped when ``clean`` is on,
    because scanned and exported meshes often carry them and surface automata need a connected
    edge graph. ``normalize`` scales the mesh into a unit box centred at the origin. The file's
    texture coordinates are kept per face corner in ``mesh__uv`` (seams split UVs, not the
    surface), so ``mesh.image_field`` and ``surface.image_field`` sample textures through them.
    """

    example: ClassVar[tuple[dict, ...]] = ({"rule": "mesh.load", "params": {"path": "spot.obj"}},)
    name: ClassVar[str] = "mesh.load"
    creates: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(UV_FIELD, "{mesh}", "face", "out",
                  doc="texture coordinates of each face corner (only when the file has them)"),)

    path: str = param(doc="mesh file: absolute, relative to the recipe, or a shipped name (spot.obj)")
    mesh: str = param("mesh", doc="name of the TriMesh to create")
    clean: bool = param(True, doc="merge duplicate vertices, drop degenerate and duplicate faces")
    normalize: bool = param(False, doc="fit into a unit box centred at the origin")

    #: bytes loading, cleaning and holding one face takes (measured: 1M faces, 430 MB peak)
    BYTES_PER_FACE: ClassVar[int] = 500

    def validate(self) -> None:
        try:
            path = resolve_mesh_path(self.path, self.recipe_dir)
            faces = check_mesh_file(path)
        except InputError as exc:
            raise ValueError(str(exc)) from None
        from ..recipes import memory_limit_bytes

        need, limit = self.BYTES_PER_FACE * faces, memory_limit_bytes()
        if need > limit:
            raise ValueError(f"{path.name}: {faces:,} faces need about {need / 2**30:.1f} GiB to load, more than "
                             f"the {limit / 2**30:.1f} GiB this machine can give; decimate the mesh first")
        object.__setattr__(self, "_faces", faces)

    def memory_estimate(self, sizes: object = None) -> int:
        """From the face count in the file (read at validate)."""
        return self.BYTES_PER_FACE * int(getattr(self, "_faces", 0))

    def domain_sizes(self, sizes: Mapping[str, int]) -> dict[str, int]:
        faces = int(getattr(self, "_faces", 0))
        return {self.mesh: faces} if faces else {}

    def step(self, state: State) -> bool:
        mesh = load_mesh_file(resolve_mesh_path(self.path, state.base_dir))
        if self.clean:
            mesh = clean_mesh(mesh)
        if self.normalize:
            v = mesh.vertices
            lo, hi = v.min(axis=0), v.max(axis=0)
            scaled = TriMesh((v - (lo + hi) / 2) / max(float((hi - lo).max()), 1e-12), mesh.faces)
            scaled.copy_fields_from(mesh, {"vertex": "vertex", "face": "face"})
            mesh = scaled
        state.add_domain(self.mesh, mesh)
        state.report(f"{self.mesh}.n_faces", mesh.n_faces)
        return True


def clean_mesh(mesh: TriMesh) -> TriMesh:
    """Weld coincident vertices, drop degenerate and duplicate faces and unused vertices.

    trimesh's own cleaning, with tolerances relative to the mesh size (1e-9 of its extent)
    rather than trimesh's absolute default, so tiny and huge models clean alike. Face fields
    (a file's corner UVs) follow the faces that are kept; vertex fields are dropped.
    """
    v = mesh.vertices
    scale = max(float(np.ptp(v, axis=0).max()), 1e-12)
    tm = mesh.to_trimesh()
    tm.merge_vertices(digits_vertex=int(np.ceil(-np.log10(scale * 1e-9))))
    kept = np.nonzero(tm.nondegenerate_faces(height=scale * 1e-9))[0]
    tm.update_faces(kept)
    unique = tm.unique_faces()
    kept = kept[unique]
    tm.update_faces(unique)
    tm.remove_unreferenced_vertices()
    if len(tm.faces) == 0:
        raise InputError("mesh.load: every face is degenerate")
    out = TriMesh(np.asarray(tm.vertices)[:, : mesh.dim], np.asarray(tm.faces))
    for name, arr, info in mesh.fields():
        if info.at == "face":
            out.add_field(name, arr[kept], at="face", units=info.units, doc=info.doc)
    return out


@dataclass(kw_only=True)
class MeshPrimitive(RuleBase):
    """A primitive mesh: icosphere, plane, cylinder, torus, cube or tetrahedron (unit size)."""

    name: ClassVar[str] = "mesh.primitive"
    creates: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}

    mesh: str = param("mesh", doc="name of the TriMesh to create")
    shape: str = param("icosphere", choices=("icosphere", "plane", "cylinder", "torus", "cube", "tetrahedron"),
                       doc="which primitive")
    size: float = param(1.0, gt=0.0, units="length", doc="radius (sphere, cylinder, torus) or edge length")
    subdivisions: int = param(3, ge=0, le=7, doc="icosphere subdivisions / plane and cube cells per side")
    sections: int = param(32, ge=3, le=1024, doc="segments around (cylinder, torus)")
    height: float = param(1.0, gt=0.0, units="length", doc="cylinder height")
    minor_radius: float = param(0.3, gt=0.0, units="length", doc="torus tube radius")

    def step(self, state: State) -> bool:
        import trimesh

        s = self.size
        if self.shape == "icosphere":
            tm = trimesh.creation.icosphere(subdivisions=self.subdivisions, radius=s)
        elif self.shape == "cylinder":
            tm = trimesh.creation.cylinder(radius=s, height=self.height, sections=self.sections)
        elif self.shape == "torus":
            tm = trimesh.creation.torus(major_radius=s, minor_radius=self.minor_radius,
                                        major_sections=self.sections, minor_sections=max(8, self.sections // 2))
        elif self.shape == "tetrahedron":
            v = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float) * s / np.sqrt(8)
            f = np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])
            tm = trimesh.Trimesh(v, f, process=False)
        elif self.shape == "plane":
            n = max(1, 2 ** self.subdivisions)
            xs = np.linspace(-s / 2, s / 2, n + 1)
            xx, yy = np.meshgrid(xs, xs)
            from .grids import grid_faces

            tm = trimesh.Trimesh(np.column_stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)]),
                                 grid_faces(n + 1, n + 1), process=False)
        else:
            tm = trimesh.creation.box(extents=(s, s, s))
            if self.subdivisions > 0:
                v, f = np.asarray(tm.vertices), np.asarray(tm.faces)
                for _ in range(self.subdivisions):
                    v, f = trimesh.remesh.subdivide(v, f)
                tm = trimesh.Trimesh(v, f, process=False)
        state.add_domain(self.mesh, TriMesh.from_trimesh(tm))
        return True


@dataclass(kw_only=True)
class MeshBoundary(RuleBase):
    """Converter: the boundary loops of a TriMesh as closed Polylines (outer loop counter-clockwise)."""

    example: ClassVar[tuple[dict, ...]] = ({"rule": "points.poisson_disk", "params": {"radius": 0.08}}, {"rule": "mesh.delaunay"},
                                             {"rule": "mesh.boundary"})
    name: ClassVar[str] = "mesh.boundary"
    uses: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    creates: ClassVar[dict[str, str]] = {"{lines}": "Polylines"}

    mesh: str = param("tessellation", doc="TriMesh whose boundary to trace")
    lines: str = param("outline", doc="name of the Polylines to create")

    def step(self, state: State) -> bool:
        m = state.get(self.mesh, TriMesh)
        loops = boundary_loops(m)
        if not loops:
            raise InputError(f"mesh.boundary: mesh {self.mesh!r} is closed (no boundary edges)")
        state.add_domain(self.lines, Polylines.from_list([m.vertices[l] for l in loops], closed=True))
        return True


def boundary_loops(m: TriMesh) -> list[np.ndarray]:
    """Vertex index loops along boundary edges, oriented as the faces that own them.

    Walking a successor map is inherently sequential; it runs once per conversion, not per step.
    """
    fe = m.face_edges
    on_boundary = m.is_boundary_edge[fe]
    a = m.faces[on_boundary]
    b = np.roll(m.faces, -1, axis=1)[on_boundary]
    nxt = dict(zip(a.tolist(), b.tolist()))
    loops, seen = [], set()
    for start in sorted(nxt):
        if start in seen:
            continue
        loop, v = [], start
        while v not in seen and v in nxt:
            seen.add(v)
            loop.append(v)
            v = nxt[v]
        if len(loop) >= 3:
            loops.append(np.array(loop))
    return loops
