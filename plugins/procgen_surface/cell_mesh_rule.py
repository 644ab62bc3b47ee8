"""``surface.cell_mesh``: the cells as an exact polygon mesh (holes cut per cell, rounded facets).

A converter, so the core's ``obj`` / ``glb`` / ``preview_png`` exporters write it: the mesh
carries the cells' atlas (``surface__uv`` / ``surface__texture``) and vertex colours
(``surface__color``).  See :mod:`.cell_mesh` for why it exists beside the lattice export.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, InputError, RuleBase, State, TriMesh, param

from .cell_mesh import boundary_edges, boundary_loops, cell_mesh
from .domain import SurfaceCells

MESH = "{mesh}"


def max_crease_deg(vertices: np.ndarray, faces: np.ndarray) -> float:
    """Largest angle (degrees) between the normals of two triangles sharing an edge."""
    from procgen import geometry as geo

    fn = geo.face_normals(vertices, faces)
    e = np.sort(np.concatenate([faces[:, [0, 1]], faces[:, [1, 2]], faces[:, [2, 0]]]), axis=1)
    tri = np.tile(np.arange(len(faces)), 3)
    order = np.lexsort((e[:, 1], e[:, 0]))
    e, tri = e[order], tri[order]
    same = np.all(e[1:] == e[:-1], axis=1)
    a, b = tri[:-1][same], tri[1:][same]
    ok = (np.linalg.norm(fn[a], axis=1) > 0) & (np.linalg.norm(fn[b], axis=1) > 0)
    if not ok.any():
        return 0.0
    cos = np.clip(np.sum(fn[a[ok]] * fn[b[ok]], axis=1), -1.0, 1.0)
    return float(np.degrees(np.arccos(cos)).max())


@dataclass(kw_only=True)
class CellMeshRule(RuleBase):
    """Converter: the living cells' clipped polygons as a mesh; holes exactly where cells are gone.

    3DSCA thesis Appendix B §6 (plate B.2): a cell that corroded through (``cell__alive`` false,
    e.g. after ``layers.corrode`` ate its last metal) leaves a real hole in the exported mesh,
    bounded exactly by its polygon.  Appendix B §7 (Figure B.16, plate B.3): the layer surface
    stands off by the stacked thickness (times ``exaggerate``) along the interpolated vertex
    normals (``rounded``, the thesis's ``rounded_facet``), or along each facet's own normal;
    ``shape`` > 0 also curves the facets themselves (Phong tessellation, beyond the thesis).
    """

    name: ClassVar[str] = "surface.cell_mesh"
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "icosphere", "subdivisions": 1}},
        {"rule": "surface.cells", "params": {"target_cells": 1500}},
        {"rule": "surface.cell_mesh"})
    uses: ClassVar[dict[str, str]] = {"{cells}": "SurfaceCells"}
    creates: ClassVar[dict[str, str]] = {MESH: "TriMesh"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("surface__uv", MESH, "face", "out", doc="atlas UV of each face corner"),
        FieldSpec("surface__texture", MESH, "domain", "out", doc="RGBA cell atlas"),
        FieldSpec("surface__color", MESH, "vertex", "out", units="rgb",
                  doc="mean colour of the cells at a vertex"),)
    cells: str = param("cells", doc="SurfaceCells to mesh")
    mesh: str = param("cell_mesh", doc="name of the TriMesh to create")
    rounded: bool = param(True, doc="layer surface along interpolated vertex normals (else face normals)")
    shape: float = param(0.0, ge=0.0, le=1.0, doc="rounded only: also curve each facet by Phong "
                         "tessellation by this factor (not in the thesis; 0 = the thesis's flat facets)")
    exaggerate: float = param(0.02, ge=0.0, doc="displacement = exaggerate x stacked layer thickness")
    color_by: str = param("surface__color", doc="cell colours: a field, or cells / voronoi / layers")
    texels: int = param(4, ge=1, le=16, doc="atlas texels per cell side")

    def step(self, state: State) -> bool:
        from .exporters import DEFAULT, _colors, bake_atlas, stored_atlas

        sc = state.get(self.cells, SurfaceCells)
        if sc.n_cells == 0:
            raise InputError(f"{self.name}: the cells {self.cells!r} are empty")
        alive = sc.alive()
        if not alive.any():
            raise InputError(f"{self.name}: every cell of {self.cells!r} is a hole; nothing to mesh")
        h = np.zeros(sc.n_cells)
        if "layers__thickness" in sc:
            h = self.exaggerate * np.asarray(sc["layers__thickness"], float).sum(axis=1)
        cm = cell_mesh(sc, h, alive, rounded=self.rounded, shape=self.shape)
        rgb = _colors(sc, self.color_by)
        atlas = stored_atlas(sc) if self.color_by == DEFAULT else None
        if atlas is None:
            atlas = bake_atlas(sc, rgb, texels=self.texels, per_texel=self.color_by == DEFAULT)
        tm = TriMesh(cm.vertices, cm.faces)
        uv = atlas.uv(np.repeat(cm.face_src, 3), cm.corner_xy.reshape(-1, 2), sc.size)
        tm.add_field("surface__uv", uv.reshape(-1, 3, 2), at="face", doc="atlas UV of each face corner")
        tm.add_field("surface__texture", atlas.image, at="domain", doc="RGBA cell atlas")
        col = np.zeros((len(cm.vertices), 3))
        cnt = np.zeros(len(cm.vertices))
        np.add.at(col, cm.faces.ravel(), np.repeat(rgb[cm.face_cell], 3, axis=0))
        np.add.at(cnt, cm.faces.ravel(), 1.0)
        tm.add_field("surface__color", col / np.maximum(cnt, 1.0)[:, None], at="vertex", units="rgb",
                     doc="mean colour of the cells at a vertex")
        state.add_domain(self.mesh, tm)
        # what the plates claim, measured on this mesh
        from procgen import geometry as geo
        base_area = 0.5 * float(np.linalg.norm(geo.triangle_cross(cm.base, cm.faces), axis=1).sum())
        m = self.mesh
        state.report(f"{m}.n_faces", len(cm.faces))
        state.report(f"{m}.removed_cells", int(np.count_nonzero(~alive)))
        state.report(f"{m}.removed_area", float(sc.area[~alive].sum()))
        state.report(f"{m}.missing_area", float(sc.area.sum() - base_area))
        state.report(f"{m}.removed_area_fraction", float(sc.area[~alive].sum() / sc.area.sum()))
        state.report(f"{m}.missing_area_fraction", float(1.0 - base_area / sc.area.sum()))
        state.report(f"{m}.boundary_edges", len(boundary_edges(cm.faces)))
        state.report(f"{m}.boundary_loops", boundary_loops(cm.faces))
        state.report(f"{m}.max_crease_deg", max_crease_deg(cm.vertices, cm.faces))
        state.report(f"{m}.input_crease_deg", max_crease_deg(sc.vertices, sc.faces))
        state.report(f"{m}.max_offset", float(h.max()) if len(h) else 0.0)
        return False
