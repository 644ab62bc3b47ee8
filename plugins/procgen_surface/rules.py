"""procgen rules of the 3DSCA family: primitives, cells, layers, corrosion, shading.

Voronoi propagation is the core's generic ``ca.voronoi`` (procgen.ca.propagation), which runs
on these cells as on any cell domain.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from procgen import FieldSpec, InputError, Polylines, RuleBase, State, TriMesh, param
from procgen.exchange.preview import camera_basis
from procgen.lighting import light_direction
from procgen.materials import MaterialTable, split_layer_specs

from procgen.ca import corrosion as cz
from procgen.ca.coverage import CoverageLog
from .domain import SurfaceCells
from .layers import layer_stack
from .primitives import cup, lattice
from .shading import label_colors, shade_cells


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


# -- layers ----------------------------------------------------------------------------------

LAYER_GEOMETRY_KEYS = ("thickness", "noise", "hurst", "smoothness")


def parse_surface_layers(specs: Any, where: str = "layers") -> tuple[MaterialTable, list[dict]]:
    """Recipe layer list -> (MaterialTable, geometry dicts); the shared layer syntax of both plugins."""
    table, raw = split_layer_specs(specs, LAYER_GEOMETRY_KEYS, where)
    geos = []
    for i, geo in enumerate(raw):
        for key, lo in (("thickness", 0.0), ("noise", 0.0), ("smoothness", 0.0), ("hurst", 0.0)):
            val = geo.get(key, 0.0)
            if isinstance(val, bool) or not isinstance(val, (int, float)) or not np.isfinite(val) or val < lo:
                raise InputError(f"{where}[{i}]: {key} must be a finite number >= {lo}, got {val!r}")
        geos.append({"thickness": float(geo.get("thickness", 0.0)), "noise": float(geo.get("noise", 0.0)),
                     "hurst": float(geo.get("hurst", 0.7)), "smoothness": float(geo.get("smoothness", 1.0))})
    return table, geos


@dataclass(kw_only=True)
class SurfaceLayers(RuleBase):
    """Multi-layer thickness per cell (metal, oxide, paint, glaze...), stacked along the normal.

    Per layer: nominal ``thickness`` + fractal noise of amplitude ``noise`` (3-D value noise, so
    it is seamless across triangle edges), smoothed over the cell graph (``smoothness`` = the
    Gaussian sigma in cells, as in the 2.5D plugin).  Materials come from the shared table.
    """

    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "icosphere", "subdivisions": 1}},
        {"rule": "surface.cells", "params": {"target_cells": 1500}},
        {"rule": "surface.layers"},)
    name: ClassVar[str] = "surface.layers"
    uses: ClassVar[dict[str, str]] = {"{cells}": "SurfaceCells"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("layers__thickness", domain="{cells}", at="cell", intent="out", units="thickness",
                  doc="(n, L) thickness per layer, bottom first"),)
    cells: str = param("cells", doc="SurfaceCells domain")
    layers: list[Any] = param([{"preset": "copper", "thickness": 1.0},
                               {"preset": "patina", "thickness": 0.0}],
                              doc="bottom-first list of preset names or tables (material keys + "
                                  "thickness, noise, hurst, smoothness)")
    noise_scale: float | None = param(None, gt=0.0, units="length",
                                      doc="feature size of the noise (default: 1/4 of the mesh size)")

    def validate(self) -> None:
        try:
            parse_surface_layers(self.layers)
        except InputError as exc:
            raise ValueError(str(exc)) from None

    def step(self, state: State) -> bool:
        sc = state.get(self.cells, SurfaceCells)
        table, geo = parse_surface_layers(self.layers, f"{self.name}.layers")
        scale = self.noise_scale or 0.25 * float(np.linalg.norm(np.ptp(sc.vertices, axis=0)))
        rng = state.rng()
        out = np.zeros((sc.n_cells, len(table)))
        for li, g in enumerate(geo):                  # one pass per layer
            rel = g["noise"] / g["thickness"] if g["thickness"] > 0 else 0.0
            iters = int(round(g["smoothness"] ** 2 / 0.375))
            out[:, li] = layer_stack(sc.center3d, sc.graph, rng, nominal=[g["thickness"]],
                                     noise=[rel], smoothing=[iters], scale=scale,
                                     hurst=g["hurst"])[:, 0]
        sc.add_field("layers__thickness", out, at="cell", units="thickness",
                     doc="thickness per layer, bottom first: " + ", ".join(table.names))
        sc.set_materials(table)
        return True


# -- corrosion / patina ----------------------------------------------------------------------

@dataclass(kw_only=True)
class SurfaceCorrosion(RuleBase):
    """Copper patina / corrosion on the cells (thesis ch. 4.2, attack-defence state machine).

    Strong cells (random or the top of a surface noise), new seeds per step up to a maximum,
    1..7 attacks per corroded cell weighted by a 3x3 Gaussian, attack (age, corroded helpers)
    against defence (strong helpers); corroded cells lose k1 of the ``consume`` layers (top
    first), the ``product`` layer grows by k2 up to k3; metal gone -> hole (NO_MORE_CELL).
    Also fire (consume several layers, product = char) and mildew (k1 = 0) in the gallery.
    """

    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "icosphere", "subdivisions": 1}},
        {"rule": "surface.cells", "params": {"target_cells": 1500}},
        {"rule": "surface.layers"},
        {"rule": "surface.corrosion", "iterations": 15, "params": {"seed_rate": 0.01, "b0": 1.2}},)
    name: ClassVar[str] = "surface.corrosion"
    default_iterations: ClassVar[int] = 950
    uses: ClassVar[dict[str, str]] = {"{cells}": "SurfaceCells"}
    creates: ClassVar[dict[str, str]] = {"{coverage}": "Polylines"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("layers__thickness", domain="{cells}", at="cell", intent="inout", units="thickness",
                  doc="layer stack (consumed layers thin, product grows)"),
        FieldSpec("corrosion__status", domain="{cells}", at="cell", intent="out",
                  doc="0 normal, 1 corroded, 2 hole"),
        FieldSpec("corrosion__age", domain="{cells}", at="cell", intent="out", units="steps"),
        FieldSpec("corrosion__strong", domain="{cells}", at="cell", intent="out"),
        FieldSpec("cell__alive", domain="{cells}", at="cell", intent="out", doc="False on holes"),
    )
    cells: str = param("cells", doc="SurfaceCells domain")
    consume: list[str] = param(["copper"], doc="layers eaten by corrosion (top one first)")
    product: str = param("patina", doc="layer that grows on corroded cells")
    k1: float = param(0.0005, ge=0.0, units="thickness/step", doc="consumed thickness per step")
    k2: float = param(0.02, ge=0.0, units="thickness/step", doc="product growth per step")
    k3: float = param(1.0, ge=0.0, units="thickness", doc="maximum product thickness")
    seed_rate: float = param(1e-6, ge=0.0, le=1.0, units="1/step", doc="new seeds per cell per step")
    max_seeds: int = param(60, ge=0, doc="maximum number of seeds in total")
    initial_seeds: int = param(1, ge=0, doc="seeds placed before the first step")
    max_attacks: int = param(7, ge=1, le=7, doc="attacks per corroded cell are 1..this (never 8)")
    age_step: float = param(12.0, gt=0.0, units="steps", doc="f1: one more attack per this much age")
    a0: float = param(1.0, doc="base attack")
    a1: float = param(0.02, ge=0.0, doc="attack per step of age")
    a2: float = param(0.15, ge=0.0, doc="attack per corroded helper of the attacker")
    b0: float = param(1.9, doc="base defence")
    b1: float = param(0.35, ge=0.0, doc="defence per strong helper of the defender")
    strong_bonus: float = param(1.5, ge=0.0, doc="extra defence of a strong cell")
    noise: float = param(1.0, ge=0.0, doc="attack += noise * U(0, 1)")
    sigma: float = param(1.0, gt=0.0, units="cells", doc="Gaussian direction weights sigma")
    gaussian: list[list[float]] | None = param(None, doc="explicit 3x3 direction weight matrix")
    strong_fraction: float = param(0.3, ge=0.0, le=1.0, doc="fraction of strong cells")
    strong_from: str = param("random", choices=("random", "noise", "field"),
                             doc="strong cells at random, from surface noise, or from strong_field")
    strong_field: str = param("", doc="cell field that ranks cells for strength (strong_from = 'field')")
    strong_high: bool = param(True, doc="with strong_field: its highest values are strong (False: its lowest)")
    noise_scale: float | None = param(None, gt=0.0, units="length", doc="surface noise feature size")
    coverage: str = param("coverage", doc="Polylines domain receiving the coverage curve")

    def _params(self) -> cz.CorrosionParams:
        g = cz.gaussian_matrix(self.sigma) if self.gaussian is None else np.asarray(self.gaussian, float)
        prm = cz.CorrosionParams(k1=self.k1, k2=self.k2, k3=self.k3, seed_rate=self.seed_rate,
                                 max_seeds=self.max_seeds, max_attacks=self.max_attacks,
                                 age_step=self.age_step, a0=self.a0, a1=self.a1, a2=self.a2,
                                 b0=self.b0, b1=self.b1, strong_bonus=self.strong_bonus,
                                 noise=self.noise, gaussian=tuple(map(tuple, g)))
        prm.check()
        return prm

    def validate(self) -> None:
        if (self.strong_from == "field") != bool(self.strong_field):
            raise ValueError("strong_field names the field exactly when strong_from = 'field'")
        if self.gaussian is not None and (len(self.gaussian) != 3 or any(len(r) != 3 for r in self.gaussian)):
            raise ValueError("gaussian must be a 3x3 matrix")
        if self.initial_seeds > self.max_seeds:
            raise ValueError("initial_seeds must not exceed max_seeds")

    def check_chain(self, earlier: list[RuleBase]) -> None:
        """Consumed and product layers must exist in the surface.layers stack of these cells."""
        made = [r for r in earlier if r.name == "surface.layers" and getattr(r, "cells", None) == self.cells]
        if made:
            table = parse_surface_layers(made[-1].layers)[0]
            for name in self.consume:
                table.index(name, "consume")
            table.index(self.product, "product")

    def setup(self, state: State) -> None:
        sc = state.get(self.cells, SurfaceCells)
        if sc.materials is None or "layers__thickness" not in sc:
            raise InputError(f"surface.corrosion: run surface.layers on {self.cells!r} first")
        self._prm = self._params()
        self._cons = [sc.materials.index(n, "surface.corrosion.consume") for n in self.consume]
        self._prod = sc.materials.index(self.product, "surface.corrosion.product")
        if self._prod in self._cons:
            raise InputError("surface.corrosion: the product layer cannot also be consumed")
        rng = state.rng()
        t = np.array(sc["layers__thickness"], dtype=float)       # private copy, then republished
        sc["layers__thickness"] = t
        noise = None
        if self.strong_from == "noise":
            from .layers import value_noise_3d
            scale = self.noise_scale or 0.1 * float(np.linalg.norm(np.ptp(sc.vertices, axis=0)))
            noise = value_noise_3d(sc.center3d, rng, scale=scale)
        elif self.strong_from == "field":
            if self.strong_field not in sc or sc.field_info(self.strong_field).at != "cell":
                raise InputError(f"surface.corrosion: strong_field {self.strong_field!r} is not a cell field of "
                                 f"{self.cells!r} (cell fields: {', '.join(sc.field_names('cell'))})")
            noise = np.asarray(sc[self.strong_field], dtype=float).reshape(sc.n_cells, -1)[:, 0]
            noise = noise if self.strong_high else -noise
        alive = sc.alive()
        strong = cz.strong_mask(sc.n_cells, self.strong_fraction, rng, noise)
        status = np.where(alive, cz.NORMAL, cz.HOLE).astype(np.int8)
        self._st = cz.CorrosionState(status=status, consumable=t[:, self._cons].copy(),
                                     product=t[:, self._prod].copy(),
                                     age=np.zeros(sc.n_cells, np.int32), strong=strong)
        pool = np.nonzero(alive & ~strong)[0]
        k = min(self.initial_seeds, len(pool))
        if k:
            self._st.status[rng.choice(pool, k, replace=False)] = cz.CORRODED
            self._st.seeds_used = k
        self._log = CoverageLog()
        self._n0 = int(np.count_nonzero(status == cz.NORMAL))
        self._log.add(self._changed_fraction(), k / max(sc.n_cells, 1))
        self._write(sc)
        state.add_domain(self.coverage, self._log.domain())

    def _changed_fraction(self) -> float:
        return float(np.count_nonzero(self._st.status != cz.NORMAL) - (len(self._st.status) - self._n0)) \
            / max(self._n0, 1)

    def _write(self, sc: SurfaceCells) -> None:
        """Publish the kernel state as fields (status/age/strong share the kernel's arrays)."""
        t = sc["layers__thickness"]
        t[:, self._cons] = self._st.consumable
        t[:, self._prod] = self._st.product
        if "corrosion__status" not in sc or sc["corrosion__status"] is not self._st.status:
            sc.add_field("corrosion__status", self._st.status, at="cell", doc="0 normal, 1 corroded, 2 hole")
            sc.add_field("corrosion__age", self._st.age, at="cell", units="steps")
            sc.add_field("corrosion__strong", self._st.strong, at="cell")
        sc.add_field("cell__alive", self._st.status != cz.HOLE, at="cell", doc="False on holes")

    def step(self, state: State) -> bool:
        sc = state.get(self.cells, SurfaceCells)
        changed = cz.corrosion_step(sc.graph, self._st, self._prm, state.rng()).changed
        self._write(sc)
        self._log.add(self._changed_fraction(), changed / max(sc.n_cells, 1))
        state.add_domain(self.coverage, self._log.domain())
        return True

    def finish(self, state: State) -> None:
        self._log.report(state, self.cells + ".corrosion")
        state.report(f"{self.cells}.corrosion.holes", int(np.count_nonzero(self._st.status == cz.HOLE)))
        state.report(f"{self.cells}.corrosion.seeds", int(self._st.seeds_used))


# -- shading ---------------------------------------------------------------------------------

@dataclass(kw_only=True)
class ShadeCells(RuleBase):
    """Colour per cell (``surface__rgb``): light through the layers (albedo for texture baking,
    or Phong per layer from a fixed light and eye), Voronoi labels, or the corrosion status."""

    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "icosphere", "subdivisions": 1}},
        {"rule": "surface.cells", "params": {"target_cells": 1500}},
        {"rule": "surface.layers"},
        {"rule": "surface.shade"},)
    name: ClassVar[str] = "surface.shade"
    uses: ClassVar[dict[str, str]] = {"{cells}": "SurfaceCells"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("surface__rgb", domain="{cells}", at="cell", intent="out", doc="colour in [0, 1]"),)
    cells: str = param("cells", doc="SurfaceCells domain")
    color_by: str = param("layers", choices=("layers", "voronoi", "status", "cells"), doc="what to show")
    lit: bool = param(False, doc="Phong per layer (True) or unlit albedo for baking (False)")
    light_azimuth: float = param(40.0, units="deg", doc="light direction azimuth")
    light_elevation: float = param(50.0, units="deg", doc="light direction elevation")
    eye_azimuth: float = param(35.0, units="deg", doc="eye direction azimuth")
    eye_elevation: float = param(25.0, units="deg", doc="eye direction elevation")

    def step(self, state: State) -> bool:
        sc = state.get(self.cells, SurfaceCells)
        light = light_direction(self.light_azimuth, self.light_elevation)
        eye = camera_basis(self.eye_azimuth, self.eye_elevation)[0]
        sc.add_field("surface__rgb", cell_colors(sc, self.color_by, lit=self.lit, light=light, eye=eye),
                     at="cell", doc=f"cell colour ({self.color_by})")
        return True


def cell_colors(sc: SurfaceCells, color_by: str, *, lit: bool, light: np.ndarray,
                eye: np.ndarray) -> np.ndarray:
    """Per-cell colours; shared by the shade rule and the preview exporter."""
    if color_by == "voronoi":
        return label_colors(np.asarray(sc["voronoi__label"]))
    if color_by == "cells":
        # checkerboard of the per-triangle grids; PART-IN cells darker, triangles tinted
        checker = (sc.ij.sum(axis=1) + sc.face) % 2
        base = label_colors(sc.face % 12 + 1, seed=3)
        rgb = base * np.where(checker, 1.0, 0.75)[:, None]
        return rgb * np.where(sc.comp_in, 1.0, 0.55)[:, None]
    if color_by == "status":
        pal = np.array([[0.80, 0.45, 0.25], [0.30, 0.68, 0.52], [0.05, 0.05, 0.05]])
        return pal[np.asarray(sc["corrosion__status"])]
    if sc.materials is None or "layers__thickness" not in sc:
        raise InputError("shade: no layers on this SurfaceCells domain (run surface.layers)")
    return shade_cells(sc.normal, np.asarray(sc["layers__thickness"]), sc.materials, lit=lit,
                       light=light, eye=eye)
