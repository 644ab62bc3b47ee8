"""procgen rules of the water family: 2.5-D surface, drops, weak map, snapshots.

Corrosion and shading of the layer stack are the layered-materials family's (layers.corrode,
layers.shade); they run on the grids this family builds."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from procgen import FieldSpec, Grid, InputError, RuleBase, State, param
from procgen.fields import check_field_name

from procgen_layers.stack import THICKNESS, store_table, table_field_specs

from . import particles as P
from .weak_map import REGROUP_POWERS, weak_cells, weakness_score
from .layers import base_surface, check_grid, layer_thickness, parse_layers
from .render import water_depth_map
from .state_io import (drop_specs, drops_from_domain, drops_to_domain, ensure_water_fields, map_specs,
                       surface_view, update_derived)

SURF = "{grid}"
_DEFAULT_LAYERS: list[Any] = [{"preset": "stone", "thickness": 1.0, "noise": 0.05, "hurst": 0.7},
                              {"preset": "red_patina", "thickness": 0.3, "noise": 0.1, "coverage": 0.5}]
_SMALL = ({"rule": "water.surface", "params": {"nx": 24, "ny": 20}},)


@dataclass(kw_only=True)
class MultiLayerSurface(RuleBase):
    """A 2.5D multi-layer surface: base relief plus stacked layers of given materials.

    Each layer has a material (preset name and/or properties: see procgen_layers.materials) and a
    thickness map: nominal thickness + midpoint-displacement noise (Hurst exponent) smoothed by
    the smoothness coefficient, restricted to a coverage / rect / spots mask (thesis 2.4.1).
    ``base = 'grid'`` lays the layers on a Grid an earlier step made (grid.load: a heightmap,
    a DEM), keeping its shape, spacing, origin and other fields (and its ``periodic`` flag).
    ``periodic``: a tileable surface on a torus grid (noise, blurs and spots wrap; drops that
    leave an edge come back at the opposite one).
    """

    name: ClassVar[str] = "water.surface"
    example: ClassVar[tuple[dict, ...]] = _SMALL
    creates: ClassVar[dict[str, str]] = {SURF: "Grid"}
    passes_fields: ClassVar[dict[str, str]] = {SURF: "{base_grid}"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("surface__base", SURF, "cell", "out", units="length", doc="substrate height"),
        FieldSpec(THICKNESS, SURF, "cell", "out", units="length", doc="thickness per layer, bottom first"),
        FieldSpec("layers__top", SURF, "cell", "out", units="length", doc="top of each layer"),
        FieldSpec("surface__height", SURF, "cell", "out", units="length", doc="top surface"),
        FieldSpec("water__saturation", SURF, "cell", "out", units="1", doc="held water / capacity of the exposed layer"),
    ) + map_specs(SURF, "out") + table_field_specs(SURF)

    grid: str = param("terrain", doc="name of the Grid to create")
    nx: int = param(128, ge=3, le=8192, units="cells", doc="cells across")
    ny: int = param(128, ge=3, le=8192, units="cells", doc="cells down")
    spacing: float = param(1.0, gt=0.0, units="length", doc="cell size")
    layers: list[Any] = param(_DEFAULT_LAYERS, doc="layers bottom first: preset names or tables "
                              "(material keys + thickness, noise, hurst, smoothness, coverage, rect, spots...)")
    base: str = param("flat", choices=("flat", "tilt", "fbm", "mountain", "grid"), doc="substrate relief")
    base_grid: str = param("", doc="base = 'grid': the Grid whose surface__height is the substrate ('' = 'grid')")
    base_amplitude: float = param(0.0, ge=0.0, units="length", doc="height of fbm/mountain relief")
    base_hurst: float = param(0.8, gt=0.0, le=1.0, doc="Hurst exponent of the base relief")
    base_smoothness: float = param(1.0, ge=0.0, units="cells", doc="Gaussian blur of the base relief")
    tilt_deg: float = param(0.0, ge=0.0, lt=89.0, units="deg", doc="tilt of the base (high at max y)")
    periodic: bool = param(False, doc="tileable: a torus grid whose maps and drops wrap at the edges")

    def validate(self) -> None:
        if self.base_grid and self.base != "grid":
            raise ValueError(f"base_grid = {self.base_grid!r} needs base = 'grid'")
        if self.periodic and (self.base in ("tilt", "mountain") or self.tilt_deg):
            raise ValueError(f"periodic = true needs base = 'flat', 'fbm' or 'grid' and no tilt "
                             f"(a {'tilt' if self.tilt_deg else self.base} does not tile)")
        try:
            parse_layers(self.layers)
            check_grid((self.ny, self.nx), "water.surface")
        except InputError as exc:
            raise ValueError(str(exc)) from None

    def memory_estimate(self) -> int:
        return int(self.nx * self.ny * 8 * (12 + 8 * len(self.layers)))

    def check_chain(self, earlier: list[RuleBase]) -> None:
        src = self.base_grid or self.grid
        if self.base == "grid" and not any(src in r.domains_created() for r in earlier):
            raise ValueError(f"base = 'grid' needs a Grid {src!r} made by an earlier step (grid.load)")
        maker = next((r for r in reversed(earlier) if src in r.domains_created()), None)
        if self.base == "grid" and self.periodic and not getattr(maker, "periodic", False):
            # a torus laid on heights that do not wrap would carry their seam into every map
            raise ValueError(f"periodic = true needs a tileable Grid {src!r} (grid.noise with periodic = true), "
                             f"but {maker.name} makes one that does not wrap")

    def step(self, state: State) -> bool:
        table, geos = parse_layers(self.layers)
        rng = state.rng()
        src = state.get(self.base_grid or self.grid, Grid) if self.base == "grid" else None
        periodic = self.periodic or (src is not None and src.periodic)
        if src is not None:
            shape, spacing, origin = src.shape, src.spacing, src.origin
            check_grid(shape, "water.surface")
            base = np.array(src["surface__height"], np.float64)
        else:
            shape, spacing, origin = (self.ny, self.nx), self.spacing, (0.0, 0.0)
            base = base_surface(self.base, shape, self.spacing, rng, amplitude=self.base_amplitude,
                                hurst=self.base_hurst, smoothness=self.base_smoothness, tilt_deg=self.tilt_deg,
                                periodic=periodic)
        t = np.stack([layer_thickness(geo, shape, rng, periodic) for geo in geos], axis=-1)
        g = Grid(shape, spacing, origin, periodic=periodic)
        for name, arr, info in (src.fields() if src is not None else ()):
            if name not in {spec.name for spec in self.fields}:
                g.add_field(name, arr.copy(), at=info.at, units=info.units, doc=info.doc)
        g.add_field("surface__base", base, at="cell", units="length", doc="substrate height")
        g.add_field(THICKNESS, t, at="cell", units="length",
                    doc="thickness per layer, bottom first: " + ", ".join(table.names))
        store_table(g, table)
        state.add_domain(self.grid, g)
        ensure_water_fields(g, len(table))
        g["sediment__baseline"] = t.sum(axis=-1) * spacing ** 2
        _, s, _ = surface_view(state, self.grid)
        update_derived(g, s, table)
        return True


@dataclass(kw_only=True)
class WaterDrops(RuleBase):
    """Water drops on the multi-layer surface: absorption, erosion, sediment, evaporation.

    A batch of particles per step (thesis 2.4.2): gravity, friction, roughness and adhesion move
    them; they wet the exposed layer up to its capacity, erode weak (saturated) erodible layers
    in proportion to the liquid involved, carry one sediment type, deposit it when absorbed (or
    beyond a sediment capacity), drain off the edges or stabilise.  A step only moves the drops;
    the derived fields (heights, saturation, water depth), the drops' PointSet and the water and
    sediment ledgers are brought up to date when someone looks: at each frame and at the end
    (``publish``; at 512 x 512 they cost more than a compiled step).  The ledgers are cumulative,
    so water or solid lost at any step still shows at every later check; their errors go to
    run.json.
    """

    name: ClassVar[str] = "water.drops"
    default_iterations: ClassVar[int] = 100
    example: ClassVar[tuple[dict, ...]] = _SMALL + ({"rule": "water.drops", "iterations": 3,
                                                     "params": {"drops": 50}},)
    uses: ClassVar[dict[str, str]] = {SURF: "Grid"}
    creates: ClassVar[dict[str, str]] = {"{drops_domain}": "PointSet"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(THICKNESS, SURF, "cell", "inout", units="length"),
        FieldSpec("surface__height", SURF, "cell", "inout", units="length"),
        FieldSpec("layers__top", SURF, "cell", "inout", units="length"),
        FieldSpec("water__depth", SURF, "cell", "out", units="length"),
        FieldSpec("water__saturation", SURF, "cell", "out", units="1"),
    ) + map_specs(SURF, "inout", ("water__held", "sediment__deposit", "water__emitted", "water__evaporated",
                                  "water__drained", "sediment__drained", "water__path")) + drop_specs("{drops_domain}")

    grid: str = param("terrain", doc="Grid built by water.surface")
    drops_domain: str = param("drops", doc="PointSet holding the drops between steps")
    drops: int = param(1000, ge=0, le=10_000_000, doc="drops emitted at the first iteration")
    rain: int = param(0, ge=0, le=10_000_000, doc="drops emitted at every iteration")
    rain_steps: int = param(0, ge=0, doc="iterations with rain (0 = all)")
    emission: str = param("uniform", choices=("uniform", "top", "weights"), doc="where drops appear")
    band: float = param(0.1, gt=0.0, le=1.0, doc="height of the top band, fraction of the grid")
    weights_field: str = param("", doc="cell field of emission weights (emission = 'weights')")
    drop_volume: float = param(1.0, gt=0.0, units="volume", doc="initial drop volume")
    gravity: float = param(1.0, ge=0.0, units="length/step^2", doc="gravity")
    friction: float = param(0.05, ge=0.0, le=1.0, doc="viscous damping of velocity per step")
    adhesion: float = param(0.0, ge=0.0, doc="contact adhesion (per contact area)")
    contact_angle: float = param(60.0, gt=0.0, le=180.0, units="deg", doc="drop contact angle")
    max_speed: float = param(1.0, gt=0.0, le=1.0, units="cells/step", doc="speed cap")
    stable_speed: float = param(0.02, ge=0.0, units="cells/step", doc="below: drop may stabilise")
    max_age: int = param(0, ge=0, units="steps", doc="stabilise after this many steps (0 = never)")
    speed_ref: float = param(0.5, gt=0.0, units="length/step", doc="absorption halves at this speed")
    evaporation: float = param(0.002, ge=0.0, units="volume/area/step", doc="evaporation of held water")
    sediment_capacity: float | None = param(None, ge=0.0, doc="k in capacity = k V speed slope (None = unlimited)")
    min_slope: float = param(0.01, ge=0.0, doc="slope floor in the capacity")
    deposition_rate: float = param(0.3, ge=0.0, le=1.0, doc="share of over-capacity load dropped per step")
    max_concentration: float = param(1.0, gt=0.0, le=1.0, doc="max sediment volume / water volume")
    footprint: str = param("cell", choices=("cell", "bilinear", "disc"), doc="cells a drop erodes/deposits on")
    brush_radius: float = param(2.5, gt=0.5, le=8.0, units="cells", doc="radius of the 'disc' footprint")
    erode_stabilised: bool = param(False, doc="stabilised drops keep eroding")
    capacity_fade: bool = param(False, doc="sediment capacity fades to 0 at max_age (gradual deposition)")
    depth_gain: float = param(1.0, gt=0.0, doc="scale of water__depth (drop volume per area)")

    def memory_estimate(self) -> int:
        # per live drop: its arrays plus the footprint pair temporaries (disc: ~21 pairs)
        per = 2500 if self.footprint == "disc" else 600
        return int((self.drops + 100 * self.rain) * per)

    def validate(self) -> None:
        if self.emission == "weights" and not self.weights_field:
            raise ValueError("emission = 'weights' needs weights_field")

    def setup(self, state: State) -> None:
        g, s, table = surface_view(state, self.grid)
        check_grid(g.shape, self.name)
        self._g, self._s, self._table = g, s, table
        self._d = drops_from_domain(state, self.drops_domain, g)
        self._baseline = float(g["sediment__baseline"].sum())
        self._max_err = {"water": 0.0, "sediment": 0.0}
        self._emitted_before = float(s.emitted.sum())
        self._published = False

    def step(self, state: State) -> bool:
        s, p, it = self._s, self, state.iteration
        rng = state.rng()
        n_new = (self.drops if it == 0 else 0) + (self.rain if (self.rain_steps == 0 or it < self.rain_steps) else 0)
        if n_new:
            w = None
            if self.emission == "weights":
                w = np.asarray(self._g[self.weights_field], float)
                w = w if w.ndim == 2 else w.sum(axis=-1)
            self._d = self._d.concat(P.emit(s, p, rng, n_new, self.emission, self.band, w))
        had_water = len(self._d) > 0 or bool(s.held.any())
        self._d = P.step(s, self._d, p, continued=it > 0)      # (only this step writes s)
        self._published = False
        return len(self._d) > 0 or had_water

    def publish(self, state: State) -> None:
        if self._published:
            return
        self._check()
        self._sync(state)
        self._published = True

    def _check(self) -> None:
        wl = P.water_ledger(self._s, self._d)
        sl = P.sediment_ledger(self._s, self._d, self._baseline)
        self._max_err["water"] = max(self._max_err["water"], wl["error"] / max(wl["emitted"], 1e-300))
        self._max_err["sediment"] = max(self._max_err["sediment"], sl["error"] / max(self._baseline, 1e-300))
        self._ledgers = (wl, sl)

    def _sync(self, state: State) -> None:
        g, s, d = self._g, self._s, self._d
        drops_to_domain(state, self.drops_domain, g, d)
        update_derived(g, s, self._table)
        g.add_field("water__depth", water_depth_map(g.shape, d.pos, d.volume, g.spacing, self.depth_gain),
                    at="cell", units="length", doc="standing/moving drop water per cell area")

    def finish(self, state: State) -> None:
        self.publish(state)
        wl, sl = self._ledgers
        key = f"step{state.step_index}.water"
        state.report(f"{key}.water_ledger", {k: round(v, 10) for k, v in wl.items()})
        state.report(f"{key}.sediment_ledger", {k: round(v, 10) for k, v in sl.items()})
        state.report(f"{key}.max_relative_ledger_error", dict(self._max_err))
        d = self._d
        state.report(f"{key}.drops", {"alive": len(d), "moving": int(d.moving.sum()),
                                      "stabilised": int((~d.moving).sum())})


@dataclass(kw_only=True)
class WeakMap(RuleBase):
    """Weak/strong ('wet') map for corrosion: regrouped random map, altitude, water-path trace.

    Plate D-1: a pure random map regrouped by a linear / square / cubic / x^4 kernel, then a
    binary threshold giving exactly ``weak_fraction`` weak cells.  ``trace_field`` (e.g.
    water__path from an earlier water.drops run) weights the map by where water flowed (the
    thesis's section 2.7 proposal).
    """

    name: ClassVar[str] = "water.weak_map"
    example: ClassVar[tuple[dict, ...]] = _SMALL + ({"rule": "water.weak_map"},)
    uses: ClassVar[dict[str, str]] = {SURF: "Grid"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("surface__height", SURF, "cell", "in", units="length"),
        FieldSpec("corrosion__weak_score", SURF, "cell", "out", units="1"),
        FieldSpec("corrosion__weak", SURF, "cell", "out", units="1"),
    )
    grid: str = param("terrain", doc="Grid to mark")
    weak_fraction: float = param(0.5, ge=0.0, le=1.0, doc="share of weak cells")
    regroup: str = param("linear", choices=tuple(REGROUP_POWERS), doc="regrouping kernel (1-d/R)^p")
    radius: float = param(6.0, ge=1.0, units="cells", doc="regrouping radius R")
    altitude_weight: float = param(0.0, ge=0.0, le=1.0, doc="weight of low altitude (lower = weaker)")
    trace_field: str = param("", doc="cell field of a water-path trace ('' = none)")
    trace_weight: float = param(0.0, ge=0.0, le=1.0, doc="weight of the trace")

    def step(self, state: State) -> bool:
        g = state.get(self.grid, Grid)
        trace = np.asarray(g[self.trace_field], float) if self.trace_field else None
        score = weakness_score(g.shape, state.rng(), regroup=self.regroup, radius=self.radius,
                               height=np.asarray(g["surface__height"]), altitude_weight=self.altitude_weight,
                               trace=trace, trace_weight=self.trace_weight, periodic=g.periodic)
        g.add_field("corrosion__weak_score", score, at="cell", units="1", doc="weakness (1 = weakest)")
        g.add_field("corrosion__weak", weak_cells(score, self.weak_fraction).astype(float), at="cell",
                    units="1", doc="1 = weak ('wet') cell, 0 = strong")
        return True


@dataclass(kw_only=True)
class Snapshot(RuleBase):
    """Copy a grid field under a new name, to keep a stage of a run for the outputs."""

    name: ClassVar[str] = "water.snapshot"
    example: ClassVar[tuple[dict, ...]] = _SMALL + (
        {"rule": "water.snapshot", "params": {"src": "surface__height", "dst": "stage_a__height"}},)
    uses: ClassVar[dict[str, str]] = {SURF: "Grid"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("{src}", SURF, "cell", "in"),
        FieldSpec("{dst}", SURF, "cell", "out"),
    )
    grid: str = param("terrain", doc="Grid holding the field")
    src: str = param("surface__color", doc="field to copy")
    dst: str = param("stage__color", doc="name of the copy")

    def validate(self) -> None:
        check_field_name(self.src)
        check_field_name(self.dst)

    def step(self, state: State) -> bool:
        g = state.get(self.grid, Grid)
        info = g.field_info(self.src)
        g.add_field(self.dst, np.array(g[self.src]), at="cell", units=info.units,
                    doc=f"copy of {self.src}: {info.doc}")
        return True


RULES = [MultiLayerSurface, WaterDrops, WeakMap, Snapshot]
