"""Rules that build a cellular network: polygons -> triangles -> cells -> links (sections 3-4)."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, InputError, RuleBase, State, TriMesh, param
from procgen.recipes import memory_limit_bytes

from .boxes import check_stencil, pairs_brute, pairs_kdtree, pairs_within
from .network import CellNetwork
from .polygons import polygons_mesh
from .seeding import (BYTES_PER_CELL, DENSITY, GRIDS, SHELL, bond_length, link_radius,
                      seed_cells)
from .states import ACTIVE, put_states

PYRAMID = [[[[0, 0, 0], [4, 0, 0], [2, 2, 2]]], [[[4, 0, 0], [4, 4, 0], [2, 2, 2]]],
           [[[4, 4, 0], [0, 4, 0], [2, 2, 2]]], [[[0, 4, 0], [0, 0, 0], [2, 2, 2]]],
           [[[0, 0, 0], [0, 4, 0], [4, 4, 0], [4, 0, 0]]]]


@dataclass(kw_only=True)
class PolygonMesh(RuleBase):
    """Generator: planar 3-D polygons (convex, concave, with holes; several objects) as a TriMesh.

    Each polygon is ``[outline, hole, ...]``, each loop a list of [x, y, z] vertices. It is
    triangulated in its plane (constrained Delaunay, holes kept) and its triangles carry
    ``face__polygon``, ``face__object`` and ``face__material`` (section 3.3: any polygon).
    """

    name: ClassVar[str] = "cellnet.polygons"
    creates: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("face__polygon", domain="{mesh}", at="face", intent="out", doc="source polygon"),
        FieldSpec("face__object", domain="{mesh}", at="face", intent="out", doc="source object"),
        FieldSpec("face__material", domain="{mesh}", at="face", intent="out", doc="material id"),
    )

    mesh: str = param("mesh", doc="name of the TriMesh to create")
    polygons: list[list[list[list[float]]]] = param(PYRAMID, doc="polygons: [outline, hole, ...] "
                                                    "loops of [x, y, z] vertices")
    objects: list[int] | None = param(None, doc="object id of every polygon (default 0)")
    materials: list[int] | None = param(None, doc="material id of every polygon (default 0)")
    scale: float = param(1.0, gt=0.0, units="length", doc="factor applied to every coordinate")

    def step(self, state: State) -> bool:
        polys = [[[[c * self.scale for c in p] for p in loop] for loop in poly]
                 for poly in self.polygons]
        mesh = polygons_mesh(polys, self.objects, self.materials, self.name)
        state.add_domain(self.mesh, mesh)
        state.report(f"{self.mesh}.n_faces", mesh.n_faces)
        return True


def _face_ids(mesh: TriMesh, name: str, dtype: type) -> np.ndarray:
    return np.asarray(mesh[name], dtype) if name in mesh else np.zeros(mesh.n_faces, dtype)


@dataclass(kw_only=True)
class CellSeeding(RuleBase):
    """Generator: cells on a mesh's polygons by a square, triangle, hexagon or random pattern.

    Section 3.2-3.3: every plane of the mesh gets one lattice frame (so a polygon's
    decomposition does not matter, Figure 8), nodes inside any of its triangles become cells,
    cells closer than cs/4 across creases merge.  ``cs`` is the bond (link rest) length; or give
    ``target_cells`` and cs follows from the area.  Normals per face or interpolated from the
    vertex normals.  Cells start ACTIVE and carry the source face's polygon, object, material.
    """

    name: ClassVar[str] = "cellnet.seed"
    uses: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    creates: ClassVar[dict[str, str]] = {"{cells}": "CellNetwork"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("cell__normal", domain="{cells}", at="cell", intent="out", doc="unit normal"),
        FieldSpec("cell__state", domain="{cells}", at="cell", intent="out", doc="general state"),
        FieldSpec("cell__polygon", domain="{cells}", at="cell", intent="out", doc="source polygon"),
        FieldSpec("cell__object", domain="{cells}", at="cell", intent="out", doc="source object"),
        FieldSpec("cell__material", domain="{cells}", at="cell", intent="out", doc="material id"),
        FieldSpec("cell__region", domain="{cells}", at="cell", intent="out", doc="plane region"),
        FieldSpec("cell__alive", domain="{cells}", at="cell", intent="out", doc="False on transparent cells"),
    )
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "cube"}},
        {"rule": "cellnet.seed", "params": {"target_cells": 600}},
    )

    mesh: str = param("mesh", doc="TriMesh whose polygons carry the cells")
    cells: str = param("cells", doc="name of the CellNetwork to create")
    grid: str = param("triangle", choices=GRIDS, doc="cell pattern (square4/square8 are the same "
                      "lattice, linked with 4 or 8 neighbours)")
    cs: float | None = param(None, gt=0.0, units="length", doc="bond length (cell size)")
    target_cells: int | None = param(20000, ge=1, le=200_000_000,
                                     doc="wanted cell count when cs is not given")
    normals: str = param("face", choices=("face", "vertex"), doc="per-face or interpolated normals")
    equal_density: bool = param(False, doc="rescale the bond so every grid has cs^2 per cell "
                                "(Figure 6: about the same cell count for every grid)")
    skip_faces: list[int] | None = param(None, doc="faces left without cells (Figure 10: the "
                                         "bunny with one triangle missing)")

    def validate(self) -> None:
        if self.cs is None and self.target_cells is None:
            raise ValueError("give cs or target_cells")

    def memory_estimate(self) -> int:
        return 0 if self.cs is not None else int(self.target_cells) * BYTES_PER_CELL

    def cell_size(self, mesh: TriMesh) -> float:
        if self.cs is not None:
            return bond_length(self.grid, self.cs, self.equal_density)
        area = float(mesh.face_areas.sum())
        per_cell = area / self.target_cells
        return math.sqrt(per_cell if self.equal_density or self.grid == "random"
                         else per_cell * DENSITY[self.grid])

    def step(self, state: State) -> bool:
        mesh = state.get(self.mesh, TriMesh)
        if mesh.vertices.shape[1] != 3:
            raise InputError(f"{self.name}: mesh {self.mesh!r} is 2-D; cells need 3-D polygons")
        if self.skip_faces:
            bad = [f for f in self.skip_faces if not 0 <= f < mesh.n_faces]
            if bad:
                raise InputError(f"{self.name}: skip_faces {bad} not in 0..{mesh.n_faces - 1}")
            keep = np.setdiff1d(np.arange(mesh.n_faces), self.skip_faces)
            sub = TriMesh(mesh.vertices, mesh.faces[keep])
            for name, arr, info in mesh.fields():
                if info.at == "face":
                    sub.add_field(name, arr[keep], at="face", doc=info.doc)
            mesh = sub
        cs = self.cell_size(mesh)
        s = seed_cells(mesh.vertices, mesh.faces, self.grid, cs, normals=self.normals,
                       rng=state.rng(), vertex_normals=mesh.vertex_normals,
                       max_bytes=memory_limit_bytes())
        if len(s.positions) == 0:
            raise InputError(f"{self.name}: no cell fits on mesh {self.mesh!r} at cs = {cs:g}")
        net = CellNetwork(s.positions, cs=cs, grid=self.grid, normals=self.normals)
        net.add_field("cell__normal", s.normals, at="cell", doc="unit normal")
        put_states(net, np.full(net.n_cells, ACTIVE, np.int8))
        poly = _face_ids(mesh, "face__polygon", np.int32) if "face__polygon" in mesh else \
            np.arange(mesh.n_faces, dtype=np.int32)
        net.add_field("cell__polygon", poly[s.face], at="cell", doc="source polygon")
        net.add_field("cell__object", _face_ids(mesh, "face__object", np.int32)[s.face], at="cell",
                      doc="source object")
        net.add_field("cell__material", _face_ids(mesh, "face__material", np.int16)[s.face],
                      at="cell", doc="material id")
        net.add_field("cell__region", s.region.astype(np.int32), at="cell", doc="plane region")
        state.add_domain(self.cells, net)
        state.report(f"{self.cells}.n_cells", net.n_cells)
        state.report(f"{self.cells}.cs", cs)
        return True


METHODS = ("boxes", "kdtree", "brute")


@dataclass(kw_only=True)
class CellLinking(RuleBase):
    """Links every cell to every cell closer than r_i, found by the 27-box search (section 4.3).

    r_i defaults to the grid's first forbidden shell minus eps (sqrt 2, 2, sqrt 3 and sqrt 3 cs
    for square-4, square-8, triangle, hexagon; sqrt 3 cs for random).  Boxes have side kb * cs
    and must not be smaller than r_i (the paper's kb = 1 misses links).  ``kdtree`` and
    ``brute`` give the identical link set.  ``min_normal_dot`` drops links between cells whose
    normals disagree more (links through thin walls).
    """

    name: ClassVar[str] = "cellnet.link"
    uses: ClassVar[dict[str, str]] = {"{cells}": "CellNetwork"}
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "cube"}},
        {"rule": "cellnet.seed", "params": {"target_cells": 600}},
        {"rule": "cellnet.link"},
    )

    cells: str = param("cells", doc="CellNetwork to link")
    ri: float | None = param(None, gt=0.0, units="cs", doc="link radius in cs (default from the grid)")
    eps: float = param(0.01, ge=0.0, lt=0.5, units="cs", doc="slack below the grid's next shell")
    kb: float = param(2.0, gt=0.0, le=100.0, units="cs", doc="box side in cs (>= r_i / cs)")
    method: str = param("boxes", choices=METHODS, doc="27-box search, scipy cKDTree, or all pairs")
    min_normal_dot: float | None = param(None, ge=-1.0, le=1.0,
                                         doc="drop links whose normals' dot product is below this")

    def radius_cs(self, grid: str) -> float:
        return self.ri if self.ri is not None else SHELL[grid] - self.eps

    def _check_kb(self, ri: float) -> None:
        if self.method == "boxes" and self.kb < ri:
            raise ValueError(f"kb = {self.kb:g} is smaller than the link radius ri = {ri:g} cs: "
                             f"the 27-box search would miss links (use kb >= {math.ceil(ri)})")

    def validate(self) -> None:
        if self.ri is not None:
            self._check_kb(self.ri)

    def check_chain(self, earlier: list[RuleBase]) -> None:
        seeds = [r for r in earlier if isinstance(r, CellSeeding) and r.cells == self.cells]
        if seeds:
            self._check_kb(self.radius_cs(seeds[-1].grid))

    def step(self, state: State) -> bool:
        net = state.get(self.cells, CellNetwork)
        r = self.radius_cs(net.grid) * net.cs
        bs = self.kb * net.cs
        if self.method == "boxes":
            check_stencil(r, bs, net.cs, self.name)
            links = pairs_within(net.positions, r, net.box_index(bs))
        elif self.method == "kdtree":
            links = pairs_kdtree(net.positions, r)
        else:
            links = pairs_brute(net.positions, r)
        if self.min_normal_dot is not None:
            n = net.normals()
            links = links[np.einsum("ij,ij->i", n[links[:, 0]], n[links[:, 1]]) >= self.min_normal_dot]
        out = net.with_links(links, radius=r)
        state.add_domain(self.cells, out)
        state.report(f"{self.cells}.n_links", out.n_links)
        state.report(f"{self.cells}.n_boxes", net.box_index(bs).n_boxes)
        state.report(f"{self.cells}.mean_degree", float(2 * out.n_links / max(out.n_cells, 1)))
        return True


__all__ = ["PolygonMesh", "CellSeeding", "CellLinking", "link_radius"]
