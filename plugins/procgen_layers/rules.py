"""procgen rules of the layered-materials family: build a stack, corrode it, shade it.

Every rule runs on any cell domain (a Grid, the surface cells of a mesh, ...) through the
cell-domain protocol of :mod:`procgen.ca.cells`, and couples to other rules by field names
only (``layers__thickness`` and the ``material__*`` table, see docs/fields.md).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from procgen import FieldSpec, InputError, RuleBase, State, param
from procgen.ca.cells import CELL_DOMAIN, cell_graph, cell_size, cell_values, n_cells, put_cell_values
from procgen.ca.cells import cell_centres as domain_cell_centres
from procgen.ca.coverage import CoverageLog
from procgen.ca.graph import MOORE
from procgen.exchange.preview import camera_basis
from procgen.domains import Grid
from procgen.fields import check_field_name
from procgen.lighting import heightfield_normals, light_direction
from procgen.noise import value_noise_3d

from . import corrosion as cz
from .bake import bake_field_specs, bake_stack
from .light import scale_opacity, shade_stack
from .materials import MaterialTable, preset, split_layer_specs
from .stack import (THICKNESS, cell_areas, cell_centres, load_table, noisy_layer,
                    put_thickness, store_table, table_field_specs)

CELLS = "{cells}"
_GRID = ({"rule": "grid.noise", "params": {"grid": "cells", "nx": 24, "ny": 20}},)
_STACK = _GRID + ({"rule": "layers.stack"},)
STACK_GEOMETRY_KEYS = ("thickness", "noise", "hurst", "smoothness")


def parse_stack(specs: Any, where: str = "layers") -> tuple[MaterialTable, list[dict[str, float]]]:
    """Recipe layer list -> (MaterialTable, per-layer thickness/noise/hurst/smoothness)."""
    table, raw = split_layer_specs(specs, STACK_GEOMETRY_KEYS, where)
    geos = []
    for i, geo in enumerate(raw):
        for key in STACK_GEOMETRY_KEYS:
            val = geo.get(key, 0.0)
            if isinstance(val, bool) or not isinstance(val, (int, float)) or not np.isfinite(val) or val < 0:
                raise InputError(f"{where}[{i}]: {key} must be a finite number >= 0, got {val!r}")
        geos.append({"thickness": float(geo.get("thickness", 0.0)), "noise": float(geo.get("noise", 0.0)),
                     "hurst": float(geo.get("hurst", 0.7)), "smoothness": float(geo.get("smoothness", 1.0))})
    return table, geos


@dataclass(kw_only=True)
class StackLayers(RuleBase):
    """Layer stack on the cells (metal, oxide, paint, glaze...): thickness per cell and layer.

    Per layer: nominal ``thickness`` + fractal noise of amplitude ``noise`` (3-D value noise at
    the cell centres, so it is seamless across a mesh's triangle edges), smoothed over the cell
    graph (``smoothness`` = the Gaussian sigma in cells).  Materials come from the presets of
    this family or from tables (thesis 2.1, App. A).
    """

    name: ClassVar[str] = "layers.stack"
    example: ClassVar[tuple[dict, ...]] = _STACK
    uses: ClassVar[dict[str, str]] = {CELLS: CELL_DOMAIN}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(THICKNESS, CELLS, "cell", "out", units="length", doc="thickness per layer, bottom first"),
    ) + table_field_specs(CELLS) + bake_field_specs(CELLS)
    cells: str = param("cells", doc="cell domain (Grid or surface cells)")
    layers: list[Any] = param([{"preset": "copper", "thickness": 1.0},
                               {"preset": "patina", "thickness": 0.0}],
                              doc="bottom-first list of preset names or tables (material keys + "
                                  "thickness, noise, hurst, smoothness)")
    noise_scale: float | None = param(None, gt=0.0, units="length",
                                      doc="feature size of the noise (default: 1/4 of the domain size)")

    def validate(self) -> None:
        try:
            parse_stack(self.layers)
        except InputError as exc:
            raise ValueError(str(exc)) from None

    def step(self, state: State) -> bool:
        dom = state.get(self.cells, CELL_DOMAIN)
        graph = cell_graph(dom, "moore", self.name)
        table, geo = parse_stack(self.layers, f"{self.name}.layers")
        centres = cell_centres(dom)
        scale = self.noise_scale or 0.25 * float(np.linalg.norm(np.ptp(centres, axis=0)))
        rng = state.rng()
        out = np.zeros((len(centres), len(table)))
        for li, g in enumerate(geo):                  # one pass per layer
            rel = g["noise"] / g["thickness"] if g["thickness"] > 0 else 0.0
            out[:, li] = noisy_layer(centres, graph, rng, nominal=g["thickness"], noise=rel,
                                     smoothing=int(round(g["smoothness"] ** 2 / 0.375)),
                                     scale=scale, hurst=g["hurst"])
        put_thickness(dom, out, table)
        bake_stack(dom, table)
        store_table(dom, table)
        return True


@dataclass(kw_only=True)
class Corrode(RuleBase):
    """Attack/defence corrosion of the layer stack (thesis 2.4.1, ch. 4.2, App. A).

    Strong cells (random, the top of a surface noise, ranked by a field or a field used as a
    mask), new seeds per step up to a maximum, 1..7 attacks per corroded cell weighted by a 3x3
    Gaussian (tilted downhill on a height field if ``downhill`` > 0), attack (age, corroded
    helpers) against defence (strong helpers); corroded cells lose k1 of the ``consume`` layers
    (top first), the ``product`` layer grows by k2 up to k3; nothing left to consume -> hole
    (the thesis's NO_MORE_CELL).  A layer other than the product lying over the consumed ones
    protects them (paint until water washes it away).  Patina on copper, tarnish on gold,
    fire (several consumed layers, product = char), mildew (k1 = 0).  A later step on the same
    cells resumes from the ``corrosion__*`` fields.

    Fields during a run: ``corrosion__state`` / ``_age`` / ``_strong`` are the kernel's own
    arrays, ``_seeded`` / ``_time`` are set at the few cells a step seeds or corrodes, and the
    kernel adds each step's change of solid to ``layers__source`` where it thins (the same
    per-step sum, each term computed as before, so the ledger is exact); these are current after
    every step.  The thickness, ``cell__alive``, ``corrosion__map`` and the coverage curve are
    copied from the kernel's state by :meth:`publish` (before a frame, and at the end): nothing
    reads them between two iterations, and keeping them current cost the compiled path up to
    half its step (512 x 512 cells).
    """

    name: ClassVar[str] = "layers.corrode"
    default_iterations: ClassVar[int] = 950
    example: ClassVar[tuple[dict, ...]] = _STACK + (
        {"rule": "layers.corrode", "iterations": 15, "params": {"seed_rate": 0.01, "b0": 1.2, "initial_seeds": 2}},)
    uses: ClassVar[dict[str, str]] = {CELLS: CELL_DOMAIN}
    creates: ClassVar[dict[str, str]] = {"{coverage}": "Polylines"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(THICKNESS, CELLS, "cell", "inout", units="length",
                  doc="layer stack (consumed layers thin, product grows)"),
        FieldSpec("layers__source", CELLS, "cell", "out", units="volume",
                  doc="solid made (+) or destroyed (-) in place, cumulative"),
        FieldSpec("corrosion__state", CELLS, "cell", "out", dtype="int8", doc="0 sound, 1 corroded, 2 hole"),
        FieldSpec("corrosion__age", CELLS, "cell", "out", dtype="int64", units="steps", doc="steps since corroded"),
        FieldSpec("corrosion__time", CELLS, "cell", "out", dtype="int64", units="steps",
                  doc="iteration at which the cell corroded (-1 never)"),
        FieldSpec("corrosion__strong", CELLS, "cell", "out", dtype="bool", doc="strong (resisting) cell"),
        FieldSpec("corrosion__seeded", CELLS, "cell", "out", dtype="bool", doc="cell was a seed"),
        FieldSpec("corrosion__map", CELLS, "cell", "out", units="1",
                  doc="0 strong, 1 weak, 2 corroded, 3 hole (plate 2.2 maps)"),
        FieldSpec("cell__alive", CELLS, "cell", "out", dtype="bool", doc="false on holes"),
    ) + bake_field_specs(CELLS)
    cells: str = param("cells", doc="cell domain carrying a layer stack")
    consume: list[str] = param([], doc="layers eaten, top one first ([] = every corrodible layer)")
    product: str = param("patina", doc="layer that grows on corroded cells")
    k1: float = param(0.0005, ge=0.0, units="length/step", doc="consumed thickness per step")
    k2: float = param(0.02, ge=0.0, units="length/step", doc="product growth per step")
    k3: float = param(1.0, ge=0.0, units="length", doc="maximum product thickness")
    seed_rate: float = param(1e-6, ge=0.0, le=1.0, units="1/step", doc="new seeds per cell per step")
    seeding: str = param("binomial", choices=("binomial", "fixed"),
                         doc="new seeds per step: Binomial(cells, seed_rate) or floor(seed_rate * cells)")
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
    downhill: float = param(0.0, ge=0.0, doc="tilt of the Gaussian towards lower height_field cells")
    height_field: str = param("surface__height", doc="cell field of heights for the downhill tilt")
    strong_fraction: float = param(0.3, ge=0.0, le=1.0, doc="fraction of strong cells")
    strong_from: str = param("random", choices=("random", "noise", "field", "mask"),
                             doc="strong cells at random, from surface noise, ranked by strong_field, "
                                 "or where strong_field > 0.5 (mask)")
    strong_field: str = param("", doc="cell field ranking (field) or marking (mask) strong cells")
    strong_high: bool = param(True, doc="strong_field: high values are strong (False: low values)")
    noise_scale: float | None = param(None, gt=0.0, units="length", doc="surface noise feature size")
    coverage: str = param("coverage", doc="Polylines domain receiving the coverage curve")
    baseline: str = param("", doc="report key of an earlier step's steps to 95 % (e.g. cells.voronoi."
                                  "steps_to_95): also report saturation_ratio = our steps to 95 % / it")

    def field_specs(self) -> list[FieldSpec]:
        specs = super().field_specs()
        if self.strong_field:
            specs.append(FieldSpec(self.strong_field, self.cells, "cell", "in"))
        if self.downhill > 0:
            specs.append(FieldSpec(self.height_field, self.cells, "cell", "in", units="length"))
        return specs

    def validate(self) -> None:
        if (self.strong_from in ("field", "mask")) != bool(self.strong_field):
            raise ValueError("strong_field names the field exactly when strong_from is 'field' or 'mask'")
        g = self.gaussian
        if g is not None:
            a = np.asarray(g, dtype=float) if all(len(r) == 3 for r in g) and len(g) == 3 else None
            if a is None or np.any(a < 0) or a.sum() <= a[1, 1]:
                raise ValueError("gaussian must be a 3x3 matrix of non-negative weights with some "
                                 "weight off the centre")
        if self.initial_seeds > self.max_seeds:
            raise ValueError("initial_seeds must not exceed max_seeds")
        if self.product in self.consume:
            raise ValueError(f"the product layer {self.product!r} cannot also be consumed")

    def check_chain(self, earlier: list[RuleBase]) -> None:
        """The stack built earlier on these cells has the consumed and product layers."""
        made = [r for r in earlier if isinstance(getattr(r, "layers", None), list)
                and self.cells in (getattr(r, "cells", None), getattr(r, "grid", None))]
        if made:
            table = parse_stack_table(made[-1].layers)
            self._layer_indices(table)

    def _layer_indices(self, table: MaterialTable) -> tuple[list[int], int]:
        where = f"{self.name}"
        cons = [table.index(n, f"{where}.consume") for n in self.consume] if self.consume else \
            [i for i, m in enumerate(table) if m.corrodible]
        if not cons:
            raise InputError(f"{where}: no layer to consume (name them in 'consume' or mark a "
                             "material corrodible)")
        return cons, table.index(self.product, f"{where}.product")

    def setup(self, state: State) -> None:
        dom = state.get(self.cells, CELL_DOMAIN)
        self._graph = cell_graph(dom, "moore", self.name)
        table = load_table(dom, self.name)
        self._table = table
        self._cons, self._prod = self._layer_indices(table)
        t = np.array(cell_values(dom, THICKNESS), dtype=float)       # private copy, then republished
        put_thickness(dom, t, table)
        bake_stack(dom, table)
        self._t = cell_values(dom, THICKNESS)
        n = len(t)
        above = [i for i in range(max(self._cons) + 1, len(table)) if i not in self._cons and i != self._prod]
        self._blocked = (t[:, above] > 0).any(axis=1) if above else None     # covered: protected
        g = cz.gaussian_matrix(self.sigma) if self.gaussian is None else np.asarray(self.gaussian, float)
        self._weights = cz.direction_weights(g)
        self._edge_logw = self._downhill(dom) if self.downhill > 0 else None
        self._area = cell_areas(dom)
        rng = state.rng()
        resume = "corrosion__state" in dom
        strong = self._strong(dom, n, rng, cell_values(dom, "corrosion__strong") if resume else None)
        if resume:
            status = np.array(cell_values(dom, "corrosion__state"), np.int8)
            age = np.array(cell_values(dom, "corrosion__age"), np.int64)
            seeded = np.array(cell_values(dom, "corrosion__seeded"), bool)
            when = np.array(cell_values(dom, "corrosion__time"), np.int64)
        else:
            alive = np.asarray(cell_values(dom, "cell__alive"), bool) if "cell__alive" in dom else np.ones(n, bool)
            status = np.where(alive, cz.NORMAL, cz.HOLE).astype(np.int8)
            age, seeded, when = np.zeros(n, np.int64), np.zeros(n, bool), np.full(n, -1, np.int64)
        self._st = cz.CorrosionState(status=status, consumable=t[:, self._cons].copy(),
                                     product=t[:, self._prod].copy(), age=age, strong=strong,
                                     seeds_used=int(seeded.sum()))
        self._t0 = int(max(when.max(initial=-1), -1)) + 1
        pool = np.nonzero((status == cz.NORMAL) & ~strong)[0]
        k = min(self.initial_seeds, len(pool), self.max_seeds - self._st.seeds_used)
        if k > 0:
            first = rng.choice(pool, k, replace=False)
            status[first], seeded[first], when[first] = cz.CORRODED, True, self._t0
            self._st.seeds_used += k
        self._seeded, self._when = seeded, when
        self._n0 = int(np.count_nonzero(status == cz.NORMAL)) + max(k, 0)
        self._touched = int(np.count_nonzero(status != cz.NORMAL))     # kept by each step from here
        self._n_corroded = int(np.count_nonzero(status == cz.CORRODED))  # kept by each step from here
        self._stats = {"new_seeds": max(k, 0), "max_attacks_per_cell": 0, "attack_limit_violations": 0}
        self._log = CoverageLog()
        self._log.add(self._changed_fraction(), max(k, 0) / max(n, 1))
        src = np.array(cell_values(dom, "layers__source"), float) if "layers__source" in dom else np.zeros(n)
        put_cell_values(dom, "layers__source", src, units="volume",
                        doc="solid made (+) or destroyed (-) in place, cumulative")
        self._st.ledger, self._st.area = cell_values(dom, "layers__source"), self._area   # booked in place
        self._write(dom)
        self._published = False
        self.publish(state)

    def _strong(self, dom: Any, n: int, rng: np.random.Generator, stored: np.ndarray | None) -> np.ndarray:
        """Strong cells: recomputed from a field, else kept from an earlier step, else drawn."""
        if self.strong_from in ("field", "mask"):
            if self.strong_field not in dom or dom.field_info(self.strong_field).at != "cell":
                raise InputError(f"{self.name}: strong_field {self.strong_field!r} is not a cell field of "
                                 f"{self.cells!r} (cell fields: {', '.join(dom.field_names('cell'))})")
            v = np.asarray(cell_values(dom, self.strong_field), dtype=float).reshape(n, -1)[:, 0]
            if self.strong_from == "mask":
                return (v > 0.5) if self.strong_high else ~(v > 0.5)
            return cz.strong_mask(n, self.strong_fraction, rng, v if self.strong_high else -v)
        if stored is not None:
            return np.array(stored, bool)
        noise = None
        if self.strong_from == "noise":
            centres = cell_centres(dom)
            scale = self.noise_scale or 0.1 * float(np.linalg.norm(np.ptp(centres, axis=0)))
            noise = value_noise_3d(centres, rng, scale=scale)
        return cz.strong_mask(n, self.strong_fraction, rng, noise)

    def _downhill(self, dom: Any) -> np.ndarray:
        """Extra log-weight per neighbour entry: downhill * slope towards the neighbour."""
        h = np.asarray(cell_values(dom, self.height_field), dtype=float)
        gr = self._graph
        offset = MOORE[gr.direction]
        run = np.hypot(offset[:, 0], offset[:, 1]) * cell_size(dom)
        return self.downhill * (h[gr.rows] - h[gr.indices]) / run

    def _changed_fraction(self) -> float:
        return float(self._touched - (len(self._st.status) - self._n0)) / max(self._n0, 1)

    def _write(self, dom: Any) -> None:
        """Make the fields: state/age/strong share the kernel's arrays and seeded/time the rule's,
        so they stay current; cell__alive and the map are filled by :meth:`publish`."""
        st = self._st
        n = len(st.status)
        for name, arr, units, doc in (
                ("corrosion__state", st.status, "", "0 sound, 1 corroded, 2 hole"),
                ("corrosion__age", st.age, "steps", "steps since corroded"),
                ("corrosion__strong", st.strong, "", "strong (resisting) cell"),
                ("corrosion__seeded", self._seeded, "", "cell was a seed"),
                ("corrosion__time", self._when, "steps", "iteration at which the cell corroded (-1 never)")):
            put_cell_values(dom, name, arr, units=units, doc=doc)
        put_cell_values(dom, "cell__alive", np.empty(n, bool), doc="false on holes")
        put_cell_values(dom, "corrosion__map", np.empty(n), units="1",
                        doc="0 strong, 1 weak, 2 corroded, 3 hole (plate 2.2 maps)")
        self._alive, self._map = cell_values(dom, "cell__alive"), cell_values(dom, "corrosion__map")

    def publish(self, state: State) -> None:
        """Copy the kernel's state into the fields it does not share (the thickness of the
        consumed and product layers, cell__alive, the map) and the coverage curve: whole-grid
        copies, so made only when someone looks (a frame, the end), once per step at most."""
        if self._published:
            return
        st = self._st
        self._t[:, self._cons] = st.consumable
        self._t[:, self._prod] = st.product
        np.not_equal(st.status, cz.HOLE, out=self._alive)
        np.copyto(self._map, np.where(st.status > 0, 1.0 + st.status, 1.0 - st.strong))
        bake_stack(state.get(self.cells, CELL_DOMAIN), self._table)
        state.add_domain(self.coverage, self._log.domain())
        self._published = True

    def step(self, state: State) -> bool:
        """One kernel step, then only what it reports: the newly corroded cells are dated and
        the seeds marked (a few cells), the counts kept; no whole-grid pass (the kernel books
        the ledger; the rest waits for :meth:`publish`).  A normal cell can only corrode and a
        corroded one only become a hole, so the corroded count is kept from the step's counts
        (tests/test_corrode_rule_fields.py checks every field against a recomputation).
        """
        st = self._st
        out = cz.corrosion_step(self._graph, st, self, state.rng(), weights=self._weights,
                                edge_logw=self._edge_logw, blocked=self._blocked)
        self._when[out.newly_cells] = self._t0 + state.iteration
        self._touched += out.newly_corroded
        self._n_corroded += out.newly_corroded - out.new_holes
        if out.new_seeds:
            self._seeded[out.seed_cells] = True
        s = self._stats
        s["new_seeds"] += out.new_seeds
        s["max_attacks_per_cell"] = max(s["max_attacks_per_cell"], out.max_attacks_per_cell)
        s["attack_limit_violations"] += out.max_allowed_violation
        self._log.add(self._changed_fraction(), out.changed / max(len(st.status), 1))
        self._published = False
        return bool(out.changed or self._n_corroded)

    def finish(self, state: State) -> None:
        self.publish(state)
        st = self._st
        key = f"{self.cells}.corrosion"
        self._log.report(state, key)
        state.report(f"{key}.holes", int(np.count_nonzero(st.status == cz.HOLE)))
        state.report(f"{key}.seeds", int(st.seeds_used))
        state.report(f"{key}.corroded_fraction", float(np.mean(st.status >= cz.CORRODED)))
        state.report(f"{key}.max_attacks_per_cell", self._stats["max_attacks_per_cell"])
        state.report(f"{key}.attack_limit_violations", self._stats["attack_limit_violations"])
        if self.baseline:
            # thesis 4.2.4 / Fig. 4.9: patina saturates about 9x later than the Voronoi diagram
            base, ours = state.reports.get(self.baseline), self._log.steps_to(95)
            if not base:
                raise InputError(f"{self.name}: baseline {self.baseline!r} is not a step count reported "
                                 f"by an earlier step")
            state.report(f"{key}.saturation_ratio", None if ours is None else ours / base)


@dataclass(kw_only=True)
class Tool(RuleBase):
    """A virtual tool swept along a path cuts a groove into the layer stack (plate D-13(b)).

    The thesis's "sharp concrete texture manufactured by a virtual tool (making the two lines
    with a right angle)": every cell whose centre lies within ``radius`` of the ``path``
    polyline loses ``depth`` of thickness, taken from the top layer down, with a flat (square
    tool) or round (ball tool, depth * sqrt(1 - (d/r)^2)) cross-section.  Cutting is geometric,
    not a CA: one sweep per iteration (more iterations cut deeper).
    """

    name: ClassVar[str] = "layers.tool"
    example: ClassVar[tuple[dict, ...]] = _STACK + (
        {"rule": "layers.tool", "params": {"path": [[2.0, 2.0], [20.0, 2.0], [20.0, 16.0]], "radius": 1.5,
                                           "depth": 0.4}},)
    uses: ClassVar[dict[str, str]] = {CELLS: CELL_DOMAIN}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(THICKNESS, CELLS, "cell", "inout", units="length", doc="stack cut along the path"),) + bake_field_specs(CELLS)
    cells: str = param("cells", doc="cell domain carrying a layer stack")
    path: list[list[float]] = param([[0.0, 0.0], [1.0, 0.0]],
                                    doc="tool path: points in the domain's coordinates (2-D grid, 3-D surface)")
    radius: float = param(0.02, gt=0.0, units="length", doc="half width of the groove")
    depth: float = param(0.5, gt=0.0, units="length", doc="thickness removed on the path per sweep")
    profile: str = param("flat", choices=("flat", "round"), doc="groove cross-section: square or ball tool")

    def validate(self) -> None:
        if len(self.path) < 2 or len({len(p) for p in self.path}) != 1 or len(self.path[0]) not in (2, 3):
            raise ValueError("path must be at least two points of 2 or 3 coordinates")

    def step(self, state: State) -> bool:
        dom = state.get(self.cells, CELL_DOMAIN)
        table = load_table(dom, self.name)
        centres = domain_cell_centres(dom)          # (x, y) on a Grid, 3-D on surface cells
        pts = np.asarray(self.path, dtype=float)
        if pts.shape[1] != centres.shape[1]:
            raise InputError(f"{self.name}: path points need {centres.shape[1]} coordinates on a "
                             f"{dom.kind}, got {pts.shape[1]}")
        d = np.full(len(centres), np.inf)
        for a, b in zip(pts[:-1], pts[1:]):            # a few segments: one pass each
            ab = b - a
            u = np.clip((centres - a) @ ab / max(float(ab @ ab), 1e-300), 0.0, 1.0)
            d = np.minimum(d, np.linalg.norm(centres - a - u[:, None] * ab, axis=1))
        x = np.clip(d / self.radius, 0.0, 1.0)
        cut = self.depth * np.where(d <= self.radius, 1.0 if self.profile == "flat" else np.sqrt(1 - x * x), 0.0)
        t = np.array(cell_values(dom, THICKNESS), dtype=float)
        before = t.sum(axis=1)
        above = np.cumsum(t[:, ::-1], axis=1)[:, ::-1] - t      # thickness lying over each layer
        t = np.clip(t - np.clip(cut[:, None] - above, 0.0, None), 0.0, None)
        put_thickness(dom, t, table)
        bake_stack(dom, table)
        state.report(f"{self.cells}.tool.removed_volume",
                     float(np.sum((before - t.sum(axis=1)) * cell_areas(dom).ravel())))
        return bool(np.any(cut > 0))


def parse_stack_table(specs: Any) -> MaterialTable:
    """The material table of a recipe layer list (either layer syntax: both share the keys)."""
    return split_layer_specs(specs, GEOMETRY_KEYS_ANY)[0]


#: geometry keys of every stack builder (layers.stack here, water.surface's raster masks)
GEOMETRY_KEYS_ANY = STACK_GEOMETRY_KEYS + ("coverage", "coverage_scale", "rect", "spots",
                                           "n_spots", "spot_radius", "edge")


@dataclass(kw_only=True)
class Shade(RuleBase):
    """Colour per cell seen through the layer stack (thesis 2.5, 3.4, App. B): on any cell domain.

    Each layer's material colour is lit first (Phong; on a Grid with the normal of that layer's
    own top surface, on mesh cells with the cell normal), or left unlit (``lit = false``: the
    albedo for texture baking, the viewer lights the mesh), then the layers are combined by the
    share of light each absorbs.  Liquid held in a layer darkens it (``wet_field``), a liquid
    film can lie on top (``film_field``: the drops of plate 2.5), holes (``cell__alive`` false)
    and empty stacks show the background.
    """

    name: ClassVar[str] = "layers.shade"
    example: ClassVar[tuple[dict, ...]] = _STACK + ({"rule": "layers.shade"},)
    uses: ClassVar[dict[str, str]] = {CELLS: CELL_DOMAIN}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(THICKNESS, CELLS, "cell", "in", units="length"),
        FieldSpec("{field}", CELLS, "cell", "out", units="rgb", doc="colour in [0, 1]"),) + bake_field_specs(CELLS)
    cells: str = param("cells", doc="cell domain carrying a layer stack")
    field: str = param("surface__color", doc="cell field to write (e.g. stage_b__color to keep a stage)")
    lit: bool = param(True, doc="Phong per layer (True) or the unlit albedo for texture baking (False)")
    light_azimuth: float = param(135.0, ge=-360.0, le=360.0, units="deg", doc="light azimuth from +x")
    light_elevation: float = param(50.0, gt=0.0, le=90.0, units="deg", doc="light elevation")
    extra_lights: list[list[float]] = param([], doc="more lights, each [azimuth deg, elevation deg, "
                                                    "intensity] (plate D-13(a): two light sources)")
    through: bool = param(True, doc="light through the layers (False: the top non-empty layer only, "
                                    "as the thesis rendered plate 2.1)")
    eye_azimuth: float = param(0.0, ge=-360.0, le=360.0, units="deg", doc="eye azimuth from +x")
    eye_elevation: float = param(90.0, gt=0.0, le=90.0, units="deg", doc="eye elevation (90: straight above)")
    white_highlights: bool = param(False, doc="white specular highlights (False: tinted by the material, as the thesis)")
    z_scale: float = param(1.0, gt=0.0, doc="Grid: relief exaggeration for the normals")
    base_relief: float = param(1.0, ge=0.0, le=1.0, doc="Grid: share of surface__base relief in the "
                                                       "normals (0 = shade a tilted plate face-on)")
    opacity_scale: float = param(1.0, gt=0.0, doc="multiply every layer's f(o) (plate 2.3: rising opacity)")
    wet_field: str = param("", doc="cell field of liquid held per layer (e.g. water__held; '' = dry)")
    wet_darkening: float = param(0.45, ge=0.0, le=1.0, doc="how much saturation darkens a layer")
    film_field: str = param("", doc="cell field of a liquid film depth on top ('' = none)")
    film_material: str = param("water", doc="material preset of the film")
    film_gain: float = param(1.0, gt=0.0, doc="scale of the film depth")
    background: list[float] = param([0.05, 0.05, 0.08], ge=0.0, le=1.0, doc="colour of holes and empty cells")

    def validate(self) -> None:
        if len(self.background) != 3:
            raise ValueError("background must be 3 numbers")
        for lt in self.extra_lights:
            if len(lt) != 3 or not (0 < lt[1] <= 90) or lt[2] < 0:
                raise ValueError("extra_lights: each light is [azimuth, elevation in (0, 90], intensity >= 0]")
        check_field_name(self.field)
        for f in (self.wet_field, self.film_field):
            if f:
                check_field_name(f)
        try:
            preset(self.film_material)
        except InputError as exc:
            raise ValueError(str(exc)) from None

    def step(self, state: State) -> bool:
        dom = state.get(self.cells, CELL_DOMAIN)
        table = load_table(dom, self.name)
        if self.opacity_scale != 1.0:
            table = scale_opacity(table, self.opacity_scale)
        t = np.asarray(dom[THICKNESS], dtype=float)             # the domain's own layout
        shape = t.shape[:-1]
        light = light_direction(self.light_azimuth, self.light_elevation)
        eye = np.array([0.0, 0.0, 1.0]) if self.eye_elevation == 90 else \
            camera_basis(self.eye_azimuth, self.eye_elevation)[0]
        film = None
        if self.film_field and self.film_field in dom:
            film = np.asarray(dom[self.film_field], dtype=float) * self.film_gain
        if isinstance(dom, Grid):
            base = self.base_relief * np.asarray(dom["surface__base"], float) if "surface__base" in dom \
                else np.zeros(shape)
            tops = base[..., None] + np.cumsum(t, axis=-1)
            normals = np.stack([heightfield_normals(self.z_scale * tops[..., li], dom.spacing, dom.periodic)
                                for li in range(t.shape[-1])], axis=-2)
            film_normals = None if film is None else \
                heightfield_normals(self.z_scale * (tops[..., -1] + film), dom.spacing, dom.periodic)
        else:
            normals = film_normals = cell_normals(dom)
        held = np.asarray(dom[self.wet_field], float) if self.wet_field and self.wet_field in dom else None
        alive = np.asarray(dom["cell__alive"], bool).reshape(shape) if "cell__alive" in dom else None
        rgb = shade_stack(normals, t, table, light=light, eye=eye, lit=self.lit,
                          white_highlights=self.white_highlights, per_layer=isinstance(dom, Grid), held=held,
                          cell_area=cell_areas(dom).reshape(shape), wet_darkening=self.wet_darkening,
                          film=film, film_normals=film_normals, film_material=preset(self.film_material),
                          hole=None if alive is None else ~alive, background=tuple(self.background),
                          extra_lights=tuple((light_direction(a, e), i) for a, e, i in self.extra_lights),
                          through=self.through)
        dom.add_field(self.field, rgb, at="cell", units="rgb", doc="colour seen through the layers")
        bake_stack(dom, load_table(dom, self.name))        # a stack another family thinned
        return True


def cell_normals(dom: Any) -> np.ndarray:
    """(n, 3) cell normals: the surface cells' own, or straight up on a flat raster."""
    nrm = getattr(dom, "normal", None)
    if nrm is not None and len(nrm) == n_cells(dom):
        return np.asarray(nrm, float)
    return np.tile([0.0, 0.0, 1.0], (n_cells(dom), 1))


def cell_stack_colors(dom: Any, *, lit: bool, light: np.ndarray, eye: np.ndarray) -> np.ndarray:
    """(n, 3) colour per cell through its stack, white highlights, computed directly (the
    exporters use the baked lobes of procgen_layers.bake, which reproduce this exactly)."""
    table = load_table(dom, "shade")
    t = np.asarray(cell_values(dom, THICKNESS), dtype=float)
    return shade_stack(cell_normals(dom) if lit else None, t, table, light=light, eye=eye, lit=lit,
                       white_highlights=True)


RULES = [StackLayers, Corrode, Shade, Tool]
