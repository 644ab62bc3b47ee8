"""procgen rules of the 3DSCA family: primitives, cells, Voronoi (layers, corrosion and shading
are the layered-materials family's rules, run on these cells)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, InputError, RuleBase, State, TriMesh, param
from procgen.ca.coverage import CoverageLog

from .domain import SurfaceCells
from .primitives import cup, lattice
from .voronoi import P_DIAGONAL, VoronoiGrowth, place_seeds


# -- primitives ------------------------------------------------------------------------------

@dataclass(kw_only=True)
class CupPrimitive(RuleBase):
    """Generator: a closed cup (surface of revolution: foot, bellied wall, rim, inside, floor).

    The thesis's plates 3.1, 4.2 and D-8 are cups; the profile is revolved about z.
    """

    name: ClassVar[str] = "surface.cup"
    creates: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    mesh: str = param("mesh", doc="name of the TriMesh to create")
    radius: float = param(1.0, gt=0.0, units="length", doc="outer rim radius")
    height: float = param(1.1, gt=0.0, units="length", doc="cup height")
    wall: float = param(0.06, gt=0.0, units="length", doc="wall thickness")
    foot: float = param(0.55, gt=0.0, lt=1.0, doc="foot radius as a fraction of the rim radius")
    rings: int = param(12, ge=1, le=400, doc="profile segments along each wall")
    sections: int = param(24, ge=3, le=2000, doc="segments around the axis")

    def step(self, state: State) -> bool:
        v, f = cup(self.radius, self.height, self.wall, self.foot, self.rings, self.sections)
        state.add_domain(self.mesh, TriMesh(v, f))
        state.report(f"{self.mesh}.n_faces", len(f))
        return True


@dataclass(kw_only=True)
class RevolvePrimitive(RuleBase):
    """Generator: the surface of revolution of an (r, z) profile about z (cups, vases, tori).

    An open profile must start and end on the axis; ``loop`` revolves a closed profile into a
    torus-like ring (e.g. 4 points x 4 sections = the 32-facet object of plate 2-9).
    """

    name: ClassVar[str] = "surface.revolve"
    creates: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    mesh: str = param("mesh", doc="name of the TriMesh to create")
    profile: list[list[float]] = param([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]],
                                       doc="(r, z) points of the profile")
    sections: int = param(24, ge=3, le=2000, doc="segments around the axis")
    loop: bool = param(False, doc="profile is a closed loop off the axis (torus-like)")

    def validate(self) -> None:
        if any(len(p) != 2 for p in self.profile) or len(self.profile) < 3:
            raise ValueError("profile must be at least 3 [r, z] points")

    def step(self, state: State) -> bool:
        from procgen.builtin.solids import revolve, revolve_loop
        p = np.asarray(self.profile, dtype=float)
        v, f = revolve_loop(p, self.sections) if self.loop else revolve(p, self.sections)
        state.add_domain(self.mesh, TriMesh(v, f))
        state.report(f"{self.mesh}.n_faces", len(f))
        return True


@dataclass(kw_only=True)
class LatticePrimitive(RuleBase):
    """Generator: a closed lattice of square bars (voxel-union surface), e.g. the bronze lattice."""

    name: ClassVar[str] = "surface.lattice"
    creates: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    mesh: str = param("mesh", doc="name of the TriMesh to create")
    cells: list[int] = param([3, 3, 1], doc="lattice cells along x, y, z")
    period: int = param(4, ge=2, le=64, doc="bar spacing in bar widths")
    size: float = param(1.0, gt=0.0, units="length", doc="length of the longest side")

    def validate(self) -> None:
        if len(self.cells) != 3 or min(self.cells) < 1 or max(self.cells) > 64:
            raise ValueError("cells must be three integers in 1..64")

    def step(self, state: State) -> bool:
        v, f = lattice(tuple(self.cells), self.period, self.size)
        state.add_domain(self.mesh, TriMesh(v, f))
        state.report(f"{self.mesh}.n_faces", len(f))
        return True


# -- cells -----------------------------------------------------------------------------------

def carry_mesh_fields(mesh: TriMesh, sc: SurfaceCells) -> None:
    """The mesh's fields onto the cells, so families chain (a grid's water paths -> cell weakness).

    Numeric vertex fields are interpolated at each cell centre (barycentric, exact for linear
    fields); face fields stay on the source faces.
    """
    corners = sc.faces[sc.face]                                   # (n, 3) vertex ids per cell
    a, b, c = (sc.vertices[corners[:, k]] for k in range(3))
    v0, v1, v2 = b - a, c - a, sc.center3d - a
    d00, d01, d11 = (v0 * v0).sum(1), (v0 * v1).sum(1), (v1 * v1).sum(1)
    d20, d21 = (v2 * v0).sum(1), (v2 * v1).sum(1)
    den = np.where(np.abs(d00 * d11 - d01 * d01) > 0, d00 * d11 - d01 * d01, 1.0)
    w1, w2 = (d11 * d20 - d01 * d21) / den, (d00 * d21 - d01 * d20) / den
    bary = np.column_stack([1 - w1 - w2, w1, w2])
    for name, arr, info in mesh.fields():
        if info.at == "vertex" and np.issubdtype(arr.dtype, np.number) and arr.dtype != bool:
            vals = np.asarray(arr, dtype=np.float64)[corners]        # (n, 3, ...)
            sc.add_field(name, np.einsum("nk,nk...->n...", bary, vals), at="cell", units=info.units, doc=info.doc)
        elif info.at == "face":
            sc.add_field(name, arr.copy(), at="face", units=info.units, doc=info.doc)


@dataclass(kw_only=True)
class BuildCells(RuleBase):
    """Converter: 3DSCA cells on every triangle of a TriMesh, with the cross-edge neighbour graph.

    One square grid of common cell size s per triangle (thesis 3.2), cells clipped exactly
    (COMP-IN / PART-IN), and neighbours across edges by unfolding (default) or the thesis's
    nearest-projection pairs.  The cell size comes from ``cell_size``, ``target_cells`` or
    "min(side, height) / k".  Degenerate triangles get no cells and are counted.
    """

    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "icosphere", "subdivisions": 1}},
        {"rule": "surface.cells", "params": {"target_cells": 1500}},)
    name: ClassVar[str] = "surface.cells"
    uses: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    creates: ClassVar[dict[str, str]] = {"{cells}": "SurfaceCells"}
    passes_fields: ClassVar[dict[str, str]] = {"{cells}": "{mesh}"}
    mesh: str = param("mesh", doc="TriMesh to cover with cells")
    cells: str = param("cells", doc="name of the SurfaceCells domain to create")
    cell_size: float | None = param(None, gt=0.0, units="length", doc="explicit cell size s")
    target_cells: int | None = param(None, ge=1, doc="aim for about this many cells")
    k: float | None = param(None, gt=0.0, doc="s = min(triangle side, height) / k")
    frame: str = param("thesis", choices=("thesis", "longest"),
                       doc="triangle frame: first edge with A/B swap (thesis) or longest edge")
    neighbours: str = param("unfold", choices=("unfold", "pairs", "none"),
                            doc="cross-edge links: unfolded Moore slots, thesis pairs, or none")
    max_cells: int = param(20_000_000, ge=1, doc="refuse meshes needing more candidate cells")

    def validate(self) -> None:
        if sum(x is not None for x in (self.cell_size, self.target_cells, self.k)) != 1:
            raise ValueError("give exactly one of cell_size, target_cells, k")
        if self.target_cells is not None and self.target_cells > self.max_cells:
            raise ValueError(f"target_cells = {self.target_cells:,} exceeds max_cells = {self.max_cells:,} "
                             f"(about {self.memory_estimate() / 2**30:.1f} GiB)")

    def memory_estimate(self) -> int:
        # measured order of magnitude: topology, 8-entry CSR graph and build temporaries per cell
        return 600 * int(self.target_cells or 0)

    def step(self, state: State) -> bool:
        m = state.get(self.mesh, TriMesh)
        if m.dim != 3:
            raise InputError(f"surface.cells: mesh {self.mesh!r} is 2-D; 3DSCA needs a 3-D surface")
        sc = SurfaceCells.from_mesh(m.vertices, m.faces, cell_size=self.cell_size,
                                    target_cells=self.target_cells, k=self.k, frame=self.frame,
                                    neighbours=self.neighbours, max_cells=self.max_cells)
        carry_mesh_fields(m, sc)
        state.add_domain(self.cells, sc)
        err = sc.edge_errors()
        from .geometry import triangle_metrics
        met = triangle_metrics(sc.vertices, sc.faces)
        ok = ~met["degenerate"]
        too_big = int(np.sum(ok & ((met["sides"].min(1) <= sc.size) | (met["heights"].min(1) <= sc.size))))
        c = self.cells
        state.report(f"{c}.n_cells", sc.n_cells)
        state.report(f"{c}.cell_size", sc.size)
        state.report(f"{c}.comp_in_fraction", float(sc.comp_in.mean()))
        state.report(f"{c}.mean_neighbours", float(np.mean(np.diff(sc.indptr))))
        state.report(f"{c}.degenerate_faces_skipped", sc.n_degenerate)
        from .neighbours import edge_topology
        topo = edge_topology(sc.faces, sc.valid)
        state.report(f"{c}.boundary_edges", int(np.sum(topo.valence == 1)))   # 0: closed (thesis 6.3 step 1)
        state.report(f"{c}.non_manifold_edges", int(np.sum(topo.valence > 2)))
        state.report(f"{c}.faces_smaller_than_cell_rule", too_big)
        state.report(f"{c}.edge_error_mean", float(err.mean()) if len(err) else 0.0)
        state.report(f"{c}.edge_error_analytic", float(1 - 2 * np.sqrt(2) / np.pi))
        return True


# -- Voronoi ---------------------------------------------------------------------------------

@dataclass(kw_only=True)
class SurfaceVoronoi(RuleBase):
    """3-D surface Voronoi diagram by systematic propagation (thesis 4.1).

    Seeds get labels 1..s; labels spread to side neighbours always and to diagonal ones with
    probability P = sqrt(2)/2 - 1/2, until every cell is labelled (run with until = "stable").
    """

    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "icosphere", "subdivisions": 1}},
        {"rule": "surface.cells", "params": {"target_cells": 1500}},
        {"rule": "surface.voronoi", "params": {"seeds": 3}, "until": "stable", "max_iterations": 500},)
    name: ClassVar[str] = "surface.voronoi"
    default_iterations: ClassVar[int] = 2000
    uses: ClassVar[dict[str, str]] = {"{cells}": "SurfaceCells"}
    creates: ClassVar[dict[str, str]] = {"{coverage}": "Polylines"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("voronoi__label", domain="{cells}", at="cell", intent="out",
                  doc="region label 1..seeds, 0 = not reached yet"),)
    cells: str = param("cells", doc="SurfaceCells domain")
    seeds: int = param(12, ge=1, doc="number of random seeds")
    seed_points: list[list[float]] | None = param(
        None, doc="explicit 3-D seed positions (nearest cell each) instead of random seeds")
    p_diagonal: float = param(P_DIAGONAL, ge=0.0, le=1.0, doc="diagonal propagation probability")
    coverage: str = param("coverage", doc="Polylines domain receiving the coverage curve")

    def setup(self, state: State) -> None:
        sc = state.get(self.cells, SurfaceCells)
        if self.seed_points:
            pts = np.asarray(self.seed_points, dtype=float)
            if pts.ndim != 2 or pts.shape[1] != 3:
                raise InputError("surface.voronoi: seed_points must be a list of [x, y, z]")
            from scipy.spatial import cKDTree
            _, near = cKDTree(sc.center3d).query(pts)
            labels = np.zeros(sc.n_cells, np.int32)
            labels[near] = np.arange(1, len(pts) + 1, dtype=np.int32)
        else:
            labels = place_seeds(sc.n_cells, self.seeds, state.rng(), sc.alive())
        labels[~sc.alive()] = -1
        self._grow = VoronoiGrowth(sc.graph, labels, self.p_diagonal)
        self._log = CoverageLog()
        self._log.add(self._grow.coverage, int(np.sum(labels > 0)) / sc.n_cells)
        sc.add_field("voronoi__label", np.maximum(labels, 0), at="cell", doc="Voronoi region")
        state.add_domain(self.coverage, self._log.domain())

    def step(self, state: State) -> bool:
        sc = state.get(self.cells, SurfaceCells)
        n_new = self._grow.step(state.rng())
        if n_new == 0 and len(self._grow.frontier) == 0:
            return False                  # finished: keep the log as it is (cheap idle steps)
        if n_new:
            sc["voronoi__label"] = np.maximum(self._grow.labels, 0)
        self._log.add(self._grow.coverage, n_new / sc.n_cells)
        state.add_domain(self.coverage, self._log.domain())
        return n_new > 0

    def finish(self, state: State) -> None:
        self._log.report(state, self.cells + ".voronoi")
