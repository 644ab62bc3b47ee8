"""procgen rules of the 3DSCA family: primitives and the surface cells themselves.

Everything that runs on the cells is written for any cell domain elsewhere: Voronoi propagation
is the core's generic ``ca.voronoi``; layers, corrosion and shading are the layered-materials
family's ``layers.*`` rules.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import InputError, RuleBase, State, TriMesh, param

from .domain import SurfaceCells
from .primitives import cup, lattice


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
    from procgen.geometry import barycentric

    corners = sc.faces[sc.face]                                   # (n, 3) vertex ids per cell
    bary = barycentric(sc.vertices[corners], sc.center3d)
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
