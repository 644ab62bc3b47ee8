"""Converters that show a network's structure: links, boxes, the 27-box search, the force curve.

For the paper's structural figures: the network drawn as lines (Figures 3(c), 6, 8(d)), the
non-empty boxes as cubes ("DDST voxels", Figures 1(e), 8(c), 10(b)), the roles of cells in the
27-box search of one box (Figure 3: tested, candidates, never tested), Equation (1)'s force
curve (Figure 7), and planar cells rasterised onto a Grid for PNG/NPY output.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, Grid, InputError, Polylines, RuleBase, State, TriMesh, param

from .cellrule import EXAMPLE_NET
from .harmonize import force
from .network import CellNetwork
from .states import TRANSPARENT, states

#: the 8 corners and 12 triangles of a unit cube (outward, counter-clockwise)
_CUBE_V = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                    [0, 0, 1], [1, 0, 1], [1, 1, 1], [0, 1, 1]], float)
_CUBE_F = np.array([[0, 2, 1], [0, 3, 2], [4, 5, 6], [4, 6, 7], [0, 1, 5], [0, 5, 4],
                    [1, 2, 6], [1, 6, 5], [2, 3, 7], [2, 7, 6], [3, 0, 4], [3, 4, 7]])


@dataclass(kw_only=True)
class NetworkLines(RuleBase):
    """Converter: every link as a 2-point line (the network drawings of Figures 3, 6, 8(d))."""

    name: ClassVar[str] = "cellnet.to_lines"
    uses: ClassVar[dict[str, str]] = {"{cells}": "CellNetwork"}
    creates: ClassVar[dict[str, str]] = {"{lines}": "Polylines"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("line__length", domain="{lines}", at="line", intent="out", units="length",
                  doc="link length"),)
    example: ClassVar[tuple[dict, ...]] = EXAMPLE_NET + ({"rule": "cellnet.to_lines"},)

    cells: str = param("cells", doc="CellNetwork to draw")
    lines: str = param("links", doc="name of the Polylines to create")

    def step(self, state: State) -> bool:
        net = state.get(self.cells, CellNetwork)
        present = states(net) != TRANSPARENT
        lk = net.links[present[net.links[:, 0]] & present[net.links[:, 1]]]
        pts = net.positions[lk.reshape(-1)]
        offsets = np.arange(0, 2 * len(lk) + 1, 2)
        out = Polylines(pts, offsets, np.zeros(len(lk), bool))
        out.add_field("line__length", np.linalg.norm(pts[1::2] - pts[::2], axis=1), at="line",
                      units="length", doc="link length")
        state.add_domain(self.lines, out)
        return False


@dataclass(kw_only=True)
class BoxCubes(RuleBase):
    """Converter: the non-empty boxes of side kb cs as cubes (the DDST voxels of Figure 10(b))."""

    name: ClassVar[str] = "cellnet.to_boxes"
    uses: ClassVar[dict[str, str]] = {"{cells}": "CellNetwork"}
    creates: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("face__cells", domain="{mesh}", at="face", intent="out", doc="cells in the box"),
        FieldSpec("vertex__color", domain="{mesh}", at="vertex", intent="out",
                  doc="box colour by cell count"),)
    example: ClassVar[tuple[dict, ...]] = EXAMPLE_NET + ({"rule": "cellnet.to_boxes"},)

    cells: str = param("cells", doc="CellNetwork whose boxes to draw")
    mesh: str = param("boxes", doc="name of the TriMesh to create")
    kb: float = param(2.0, gt=0.0, le=100.0, units="cs", doc="box side in cs")
    shrink: float = param(0.9, gt=0.0, le=1.0, doc="cube size as a fraction of the box (gaps show)")

    def step(self, state: State) -> bool:
        net = state.get(self.cells, CellNetwork)
        bs = self.kb * net.cs
        idx = net.box_index(bs)
        lo = (idx.keys + 0.5 * (1 - self.shrink)) * bs
        v = (lo[:, None, :] + _CUBE_V[None] * self.shrink * bs).reshape(-1, 3)
        f = (np.arange(idx.n_boxes)[:, None, None] * 8 + _CUBE_F[None]).reshape(-1, 3)
        mesh = TriMesh(v, f)
        count = np.repeat(idx.counts, 12)
        mesh.add_field("face__cells", count.astype(np.int32), at="face", doc="cells in the box")
        rgb = np.repeat(np.column_stack([0.35 + 0.5 * np.minimum(idx.counts / idx.counts.max(), 1),
                                         np.full(idx.n_boxes, 0.55), np.full(idx.n_boxes, 0.8)]),
                        8, axis=0)
        mesh.add_field("vertex__color", rgb.astype(np.float32), at="vertex", doc="box colour by cell count")
        state.add_domain(self.mesh, mesh)
        state.report(f"{self.mesh}.n_boxes", idx.n_boxes)
        state.report(f"{self.mesh}.n_x_nodes", len(idx.x_nodes))
        state.report(f"{self.mesh}.n_columns", idx.n_columns)
        return False


ROLE_FIELD = "boxes__role"


@dataclass(kw_only=True)
class BoxSearchRoles(RuleBase):
    """Marks the cells of one 27-box search (Figure 3): 3 tested, 2 linked, 1 candidate, 0 never.

    The tested box is the one holding the cell nearest ``point`` (default: the centroid).
    Candidates are the cells of its 26 neighbour boxes; of those, the ones within the link
    radius of a tested cell are linked.
    """

    name: ClassVar[str] = "cellnet.box_roles"
    uses: ClassVar[dict[str, str]] = {"{cells}": "CellNetwork"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(ROLE_FIELD, domain="{cells}", at="cell", intent="out",
                  doc="0 never tested, 1 candidate, 2 linked candidate, 3 in the tested box"),)
    example: ClassVar[tuple[dict, ...]] = EXAMPLE_NET + ({"rule": "cellnet.box_roles"},)

    cells: str = param("cells", doc="linked CellNetwork")
    kb: float = param(2.0, gt=0.0, le=100.0, units="cs", doc="box side in cs")
    point: list[float] | None = param(None, doc="[x, y, z] inside the box to test (default: centroid)")

    def step(self, state: State) -> bool:
        net = state.get(self.cells, CellNetwork)
        if not net.linked:
            raise InputError(f"{self.name}: network {self.cells!r} has no links yet")
        idx = net.box_index(self.kb * net.cs)
        target = net.positions.mean(axis=0) if self.point is None else np.asarray(self.point, float)
        box = idx.cell_box[np.argmin(np.linalg.norm(net.positions - target, axis=1))]
        role = np.zeros(net.n_cells, np.int8)
        for b in idx.neighbour_boxes(box):
            role[idx.cells_of(b)] = 1
        tested = idx.cells_of(box)
        mark = np.zeros(net.n_cells, bool)
        mark[tested] = True
        lk = net.links[mark[net.links[:, 0]] | mark[net.links[:, 1]]]
        role[lk.reshape(-1)] = np.maximum(role[lk.reshape(-1)], 2)
        role[tested] = 3
        net.add_field(ROLE_FIELD, role, at="cell", doc="role in the 27-box search of one box")
        return False


@dataclass(kw_only=True)
class ForceCurve(RuleBase):
    """Generator: Equation (1)'s force F(d) on [0, dmax] as a line, with the d and F axes (Figure 7).

    Coordinates are (d / cs, F / k) scaled by ``scale`` so the curve reads as a plot.
    """

    name: ClassVar[str] = "cellnet.force_curve"
    creates: ClassVar[dict[str, str]] = {"{lines}": "Polylines"}

    lines: str = param("force", doc="name of the Polylines to create")
    ri: float = param(1.7320508075688772, gt=1.0, units="cs", doc="link radius r_i")
    dmax: float = param(2.0, gt=0.0, units="cs", doc="release distance (right end)")
    samples: int = param(200, ge=8, le=100_000, doc="points on the curve")
    scale: float = param(1.0, gt=0.0, doc="vertical exaggeration of F / k")

    def step(self, state: State) -> bool:
        d = np.linspace(0.0, self.dmax, self.samples)
        f = force(d, 1.0, self.ri, 1.0) * self.scale
        curve = np.column_stack([d, f])
        axes = [np.array([[0.0, 0.0], [self.dmax, 0.0]]), np.array([[0.0, f.min()], [0.0, f.max()]])]
        ticks = [np.array([[x, -0.05], [x, 0.05]]) for x in (1.0, self.ri)]
        state.add_domain(self.lines, Polylines.from_list([curve] + axes + ticks,
                                                         closed=[False] * (3 + len(ticks))))
        return False


@dataclass(kw_only=True)
class CellRaster(RuleBase):
    """Converter: a planar network's fields sampled onto a Grid (nearest cell), for PNG / NPY.

    The network must lie in a plane z = const.  Every listed cell field is sampled at the
    nearest cell; pixels farther than a cell from any cell, or on a transparent cell, get
    ``fill``.
    """

    name: ClassVar[str] = "cellnet.rasterize"
    uses: ClassVar[dict[str, str]] = {"{cells}": "CellNetwork"}
    creates: ClassVar[dict[str, str]] = {"{grid}": "Grid"}
    example: ClassVar[tuple[dict, ...]] = EXAMPLE_NET + (
        {"rule": "cellnet.rasterize", "params": {"names": ["cell__state"], "resolution": 32}},)

    cells: str = param("cells", doc="planar CellNetwork")
    grid: str = param("raster", doc="name of the Grid to create")
    names: list[str] = param(["surface__color"], doc="cell fields to sample")
    resolution: int = param(512, ge=8, le=8192, doc="pixels along the longer side")
    fill: float = param(0.0, doc="value of pixels with no cell (away from the network or holes)")

    def field_specs(self) -> list[FieldSpec]:
        return [FieldSpec(n, domain=self.grid, at="cell", intent="out", doc="sampled cell field")
                for n in self.names] + [FieldSpec(n, domain=self.cells, at="cell", intent="in",
                                                  doc="cell field to sample") for n in self.names]

    def step(self, state: State) -> bool:
        from scipy.spatial import cKDTree

        net = state.get(self.cells, CellNetwork)
        p = net.positions
        if np.ptp(p[:, 2]) > 1e-6 * max(float(np.ptp(p[:, :2])), 1e-300):
            raise InputError(f"{self.name}: network {self.cells!r} is not planar in z")
        lo, hi = p[:, :2].min(axis=0), p[:, :2].max(axis=0)
        spacing = float((hi - lo).max()) / self.resolution
        nx = max(1, int(np.ceil((hi[0] - lo[0]) / spacing)))
        ny = max(1, int(np.ceil((hi[1] - lo[1]) / spacing)))
        g = Grid((ny, nx), spacing=spacing, origin=(lo[0], lo[1]))
        yy, xx = np.meshgrid(g.y, g.x, indexing="ij")
        dist, near = cKDTree(p[:, :2]).query(np.column_stack([xx.ravel(), yy.ravel()]))
        far = dist > net.cs
        keep = states(net)[near] != TRANSPARENT
        for name in self.names:
            a = np.asarray(net[name])
            vals = a[near]
            empty = (far | ~keep).reshape((-1,) + (1,) * (vals.ndim - 1))
            vals = np.where(empty, np.asarray(self.fill).astype(vals.dtype), vals)
            g.add_field(name, vals.reshape((ny, nx) + a.shape[1:]), at="cell",
                        doc=net.field_info(name).doc)
        state.add_domain(self.grid, g)
        return False
