"""procgen rules of the crack model (3DSCA thesis 5.2): stress spectrum, propagation, a view.

``cracks.stress`` puts the stress spectrum on the surface cells' layer stack (from the layer
thickness or imposed) and relaxes it; ``cracks.propagate`` births cracks from the Pot-Crack list
series by series and walks their crack modules until the cells are stable (one iteration = one
series, so ``until = "stable"`` runs the thesis's loop 5.3 to its end); ``cracks.paint`` colours
the cells for a quick look (the cracked cells show the layer below; or the stress field).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from procgen import FieldSpec, InputError, RuleBase, State, param
from procgen.ca.subcell import slot_table
from procgen.domains import Polylines
from procgen.fields import check_field_name

from . import birth as bt
from .modules import Modules, meeting_angles
from .series import StepLog
from .stress import coplanar_slots, facet_maps, frame_weights, imposed_spectrum, relax, thickness_spectrum

CELLS = "{cells}"
THICKNESS = "layers__thickness"
SPECTRUM = "stress__spectrum"
WIDTH = "crack__width"
_MESH = ({"rule": "mesh.primitive", "params": {"shape": "tetrahedron"}},
         {"rule": "surface.cells", "params": {"target_cells": 1200}},
         {"rule": "layers.stack", "params": {"noise_scale": 0.2, "layers": [
             {"preset": "copper", "thickness": 1.0},
             {"name": "mud", "color": [0.55, 0.42, 0.3], "thickness": 1.0, "noise": 0.5}]}})
_STRESS = _MESH + ({"rule": "cracks.stress", "params": {"share": 5.0, "loops": 3}},)
_CRACKS = _STRESS + ({"rule": "cracks.propagate", "iterations": 4, "params": {"unstable_start": 0.5}},)


def _layer_indices(layers: list[int], n_layers: int, where: str) -> np.ndarray:
    idx = []
    for v in layers:
        if not -n_layers <= v < n_layers:
            raise InputError(f"{where}: layer {v} out of range for a stack of {n_layers} layers")
        idx.append(v % n_layers)
    return np.unique(np.asarray(idx, np.int64))


def _surface(state: State, name: str, where: str) -> Any:
    dom = state.get(name)
    if getattr(dom, "kind", "") != "SurfaceCells":
        raise InputError(f"{where}: {name!r} is a {dom.kind}; cracks walk on SurfaceCells (surface.cells)")
    if THICKNESS not in dom:
        raise InputError(f"{where}: {name!r} has no layer stack (run layers.stack first)")
    return dom


def _active(dom: Any) -> np.ndarray:
    """(n, L) cells that carry material in each layer (alive and of positive thickness)."""
    t = np.asarray(dom[THICKNESS], float)
    return (t > 0) & dom.alive()[:, None]


@dataclass(kw_only=True)
class CrackStress(RuleBase):
    """Stress spectrum per cell and layer (thesis 5.2.3.a, Figures 5.6-5.8), then relaxation.

    4 tension values per cell, along the axes 0, pi/4, pi/2, 3pi/4 of its facet frame, for the
    chosen layers: from the layer thickness (``mode = "thickness"``: slope and curvature along
    each axis, zero across edges between coplanar facets) or imposed (``"uniform"``: the
    ``percent`` per axis, e.g. 10/0/90/0 for plate 5.5), times ``scale``.  Then the material's
    elasticity: ``loops`` sweeps (eL) sharing ``share`` percent (eP) with the weaker neighbours.
    """

    name: ClassVar[str] = "cracks.stress"
    example: ClassVar[tuple[dict, ...]] = _STRESS
    uses: ClassVar[dict[str, str]] = {CELLS: "SurfaceCells"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(THICKNESS, CELLS, "cell", "in", units="length"),
        FieldSpec(SPECTRUM, CELLS, "cell", "out", units="1",
                  doc="tension per layer along 0, pi/4, pi/2, 3pi/4 of the facet frame"),)
    cells: str = param("cells", doc="SurfaceCells domain carrying a layer stack")
    layers: list[int] = param([-1], doc="stack layers under stress (bottom = 0, -1 = top)")
    mode: str = param("thickness", choices=("thickness", "uniform"),
                      doc="spectrum from the layer thickness, or a uniform imposed field")
    measure: str = param("slope", choices=("slope", "cell"),
                         doc="thickness mode: 'slope' (per length, the same at any cell size) or "
                             "'cell' (the thesis's difference between opposite cells: a finer "
                             "lattice holds less tension per cell)")
    gradient: float = param(1.0, ge=0.0, doc="weight of the thickness slope along each axis")
    curvature: float = param(0.0, ge=0.0, units="length",
                             doc="weight of the thickness curvature along each axis (measure "
                                 "'cell': of the second difference between cells, no unit)")
    percent: list[float] = param([10.0, 0.0, 90.0, 0.0], ge=0.0, le=100.0,
                                 doc="uniform mode: intensity per axis 0, 45, 90, 135 deg, percent")
    jitter: float = param(0.0, ge=0.0, le=1.0, doc="uniform mode: relative random variation per cell")
    scale: float = param(1.0, gt=0.0, doc="multiplies the whole field (plate 5.9: one field 4x another)")
    share: float = param(0.0, ge=0.0, le=100.0, doc="eP: elasticity sharing, percent per loop")
    loops: int = param(0, ge=0, le=100_000, doc="eL: elasticity loops (range in cells)")

    def validate(self) -> None:
        if len(self.percent) != 4:
            raise ValueError("percent must give 4 values (axes 0, 45, 90, 135 degrees)")
        if not self.layers:
            raise ValueError("layers must name at least one layer")

    def step(self, state: State) -> bool:
        dom = _surface(state, self.cells, self.name)
        t = np.asarray(dom[THICKNESS], float)
        n, n_layers = t.shape
        layers = _layer_indices(self.layers, n_layers, f"{self.name}.layers")
        graph = dom.cell_graph("moore")
        slots = slot_table(graph)
        crossed = np.zeros_like(slots, bool)
        crossed[graph.rows, graph.direction.astype(np.int64)] = graph.cross
        blocked = coplanar_slots(slots, crossed, np.asarray(dom.face), _unit_normals(dom))
        active = _active(dom)
        spec = np.zeros((n, n_layers, 4))
        rng = state.rng()
        # links between two facets: each facet's spectrum is in its own 2-D frame, so what
        # relaxation shares over such a link is turned into the other facet's frame
        cell_face = np.asarray(dom.face)
        two = cell_face[graph.rows] != cell_face[graph.indices]
        maps = facet_maps(dom.layout.frames, _unit_normals(dom), cell_face[graph.rows[two]],
                          cell_face[graph.indices[two]])
        weights = frame_weights(maps)                      # one 4 x 4 turn per cross-facet link only
        rank = np.cumsum(two) - 1                          # a cross-facet link's row in weights
        for li in layers:                                  # the stressed layers, each vectorised
            if self.mode == "thickness":
                raw = thickness_spectrum(t[:, li], slots, float(dom.size), gradient=self.gradient,
                                         curvature=self.curvature, blocked=blocked,
                                         per_cell=self.measure == "cell")
            else:
                raw = imposed_spectrum(n, self.percent, rng, self.jitter)
            raw = np.where(active[:, li, None], raw * self.scale, 0.0)
            link = active[graph.rows, li] & active[graph.indices, li]
            turn = (np.nonzero(two[link])[0], weights[rank[link & two]])
            spec[:, li] = relax(raw, graph.rows[link], graph.indices[link], self.share / 100.0, self.loops,
                                turn)
        dom.add_field(SPECTRUM, spec, at="cell", units="1",
                      doc="tension per layer along 0, pi/4, pi/2, 3pi/4 of the facet frame")
        imax = spec[:, layers].max(axis=-1)
        state.report(f"{self.cells}.stress.max", float(imax.max()) if imax.size else 0.0)
        state.report(f"{self.cells}.stress.mean", float(imax.mean()) if imax.size else 0.0)
        state.report(f"{self.cells}.stress.coplanar_zeroed_cells", int(blocked.any(axis=1).sum()))
        return True


def _unit_normals(dom: Any) -> np.ndarray:
    from procgen.geometry import face_normals
    fn = face_normals(np.asarray(dom.vertices), np.asarray(dom.faces))
    return fn / np.maximum(np.linalg.norm(fn, axis=1, keepdims=True), 1e-300)


@dataclass(kw_only=True)
class CrackPropagate(RuleBase):
    """Crack birth and crack modules over the stress spectrum (thesis 5.2.4, appendix C).

    One iteration is one series: if no crack module is alive, the Pot-Crack list (cells with
    some axis above mR, strongest first) starts the cracks at or above the threshold t, which
    then drops by Sii; every module then steps (sub-cell, vectorised) until all have ended.
    Types from Table 5.3, heads turned by (1 - Iip), forks at +-60 deg, stress released across
    each step out to d, widths growing with the release up to mcw.  The run is stable when the
    Pot-Crack list is empty, or when at most ``stop_fraction`` of the cells is still unstable.
    ``seeds`` (3-D points) replace Pot-Crack by hand-placed births (plates 5.3, 5.5, 5.6).
    With ``schedule = "step"`` one iteration is instead a whole sweep of t from M to m with
    births at every CM step while the others move (appendix C 5.3.2; plate 5.9, Figure 5.19).
    """

    name: ClassVar[str] = "cracks.propagate"
    example: ClassVar[tuple[dict, ...]] = _CRACKS
    uses: ClassVar[dict[str, str]] = {CELLS: "SurfaceCells"}
    creates: ClassVar[dict[str, str]] = {"{lines}": "Polylines", "{lines}_series": "Polylines"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(THICKNESS, CELLS, "cell", "in", units="length"),
        FieldSpec(SPECTRUM, CELLS, "cell", "inout", units="1",
                  doc="stress left after the cracks' release"),
        FieldSpec(WIDTH, CELLS, "cell", "out", units="length",
                  doc="widest crack crossing the cell per layer (0 = not cracked)"),
        FieldSpec("crack__id", CELLS, "cell", "out", dtype="int64",
                  doc="crack that cracked the cell per layer (-1 none)"),
        FieldSpec(WIDTH, "{lines}", "point", "out", units="length", doc="crack width at the vertex"),
        FieldSpec("crack__face", "{lines}", "point", "out", dtype="int64", doc="facet of the segment"),
        FieldSpec("crack__layer", "{lines}", "line", "out", dtype="int64", doc="stack layer"),
        FieldSpec("crack__type", "{lines}", "line", "out", dtype="int64", doc="0 I, 1 T, 2 Y, 3 X"),
        FieldSpec("series__line", "{lines}_series", "line", "out", dtype="int64",
                  doc="per-CM-step series (Figure 5.19): 0 CMs alive, 1 released %, 2 unstable %"),
    )
    default_iterations: ClassVar[int] = 1          # one series; run with until = "stable"
    cells: str = param("cells", doc="SurfaceCells domain with stress__spectrum")
    lines: str = param("cracks", doc="name of the Polylines domain of crack paths to create")
    resistance: float | None = param(None, gt=0.0, doc="mR: the largest stress the material holds")
    unstable_start: float | None = param(None, gt=0.0, lt=1.0,
                                         doc="or: set mR so this share of the cells starts unstable "
                                             "(plate 5.10: 0.85)")
    interval: float | None = param(None, gt=0.0, doc="Sii: threshold drop per series (default (M - m)/series)")
    series: int = param(10, ge=1, le=100_000, doc="default Sii splits the Pot-Crack range in this many")
    schedule: str = param("series", choices=("series", "step"),
                          doc="births once every module has ended ('series', one series per "
                              "iteration), or at every CM step while the modules move ('step', "
                              "appendix C 5.3.2-5.3.5: one sweep of t from M to m per iteration)")
    max_width: float = param(0.01, gt=0.0, units="length", doc="mcw: maximum crack width")
    width_scale: float = param(20.0, gt=0.0,
                               doc="released stress (in mR) at which a crack has half of mcw")
    segment_angle: float = param(8.0, gt=0.0, lt=90.0, units="deg",
                                 doc="CSa: a stored vertex where the path's chord turns by more")
    segment_tolerance: float = param(8.0, ge=0.0, lt=90.0, units="deg",
                                     doc="CSat: extra heading turn tolerated inside one segment")
    inertia: float = param(65.0, ge=0.0, le=100.0, doc="Iip: inertia influence percentage")
    potential: float = param(0.5, gt=0.0, doc="p: share of the crossed stress added to K per cell")
    drag: float = param(1.0, ge=0.0, le=1.0,
                        doc="share of the deficit below mR that a CM's K loses per cell (thesis: "
                            "K falls below the tolerance; how fast is not given; mud: low)")
    steer: str = param("unstable", choices=("unstable", "any"),
                       doc="what turns a CM: only stress above mR, or the strongest axis wherever "
                           "it is (mud, plate 5.10: heads meet cracks at about a right angle)")
    fork_epsilon: float = param(0.02, ge=0.0, doc="fork when the two strongest axes differ by < this x mR")
    release_distance: float = param(2.0, gt=0.0, le=20.0, doc="d: stress released out to d cells")
    release: float = param(2.0, ge=0.0, le=100.0,
                           doc="release intensity on the path, in units of the stress driving the CM")
    release_of: str = param("drive", choices=("drive", "cell"),
                            doc="release a share of the stress driving the CM, or of each "
                                "cell's own across stress (mud, plate 5.10)")
    step_length: float = param(0.7, gt=0.0, lt=1.0, doc="CM step in cells (shorter than a cell)")
    lookahead: float = param(1.5, ge=0.0, le=5.0, doc="a CM reads the stress this many cells ahead")
    birth_spacing: int = param(3, ge=0, le=100, doc="births of one series at least this many cells apart")
    types: list[str] = param(["I", "T", "Y", "X"], doc="crack types allowed at birth (5.10: I only)")
    t_share: float = param(0.1, ge=0.0, le=1.0, doc="Table 5.3 'I or T' rows: chance of T")
    s_floor: float = param(0.1, ge=0.0, lt=1.0, doc="Table 5.3 code S: above this share of mR")
    seeds: list[list[float]] = param([], doc="hand-placed births (3-D points); none: the Pot-Crack list")
    seed_types: list[str] = param([], doc="type per seed (I, T, Y, X); none: Table 5.3")
    stop_fraction: float = param(0.0, ge=0.0, lt=1.0,
                                 doc="stable once at most this share of cells is unstable (thesis 0.01)")
    max_module_steps: int = param(200_000, ge=1, doc="safety cap on one CM's steps")

    def validate(self) -> None:
        if (self.resistance is None) == (self.unstable_start is None):
            raise ValueError("give exactly one of resistance and unstable_start")
        bad = [t for t in list(self.types) + list(self.seed_types) if t not in bt.TYPE_NAMES]
        if bad:
            raise ValueError(f"crack types must be I, T, Y or X, got {bad}")
        if any(len(p) != 3 for p in self.seeds):
            raise ValueError("each seed must be a 3-D point [x, y, z]")
        if self.seed_types and len(self.seed_types) != len(self.seeds):
            raise ValueError(f"seed_types gives {len(self.seed_types)} types for {len(self.seeds)} seeds")
        check_field_name(self.lines.replace("-", "_") + "__x")

    def memory_estimate(self) -> int:
        return 0

    def setup(self, state: State) -> None:
        dom = _surface(state, self.cells, self.name)
        if SPECTRUM not in dom:
            raise InputError(f"{self.name}: {self.cells!r} has no {SPECTRUM} (run cracks.stress first)")
        spec = np.array(dom[SPECTRUM], dtype=float, copy=True)
        t = np.asarray(dom[THICKNESS])
        if spec.shape != t.shape + (4,):
            raise InputError(f"{self.name}: {SPECTRUM} has shape {spec.shape}, expected {t.shape + (4,)}")
        stressed = spec.reshape(len(spec), spec.shape[1], 4).max(axis=(0, 2)) > 0
        self._layers = np.nonzero(stressed)[0]
        self._active = _active(dom) & stressed[None, :]
        imax = spec.max(axis=-1)
        if self.resistance is not None:
            self.resistance_value = float(self.resistance)
        else:
            vals = imax[self._active]
            self.resistance_value = float(np.quantile(vals, 1.0 - self.unstable_start)) if vals.size else 1.0
            if self.resistance_value <= 0:
                raise InputError(f"{self.name}: unstable_start = {self.unstable_start} gives mR = 0 "
                                 "(too much of the field is null)")
        self._slots = slot_table(dom.cell_graph("moore"))
        self._mods = Modules(dom, spec, self._active, self, self._slots)
        self._t: float | None = None
        self._sii = 0.0
        self._seeded = False
        n_act = max(int(self._active.sum()), 1)
        self._start_unstable = float(((imax > self.resistance_value) & self._active).sum() / n_act)
        self._log = StepLog(spec, self._active)        # per CM step (Figure 5.19)
        self._write(state, dom)

    # -- births -------------------------------------------------------------------------------
    def _imax(self) -> np.ndarray:
        return self._mods.spec.max(axis=-1)

    def _eligible(self) -> np.ndarray:
        return self._active & ~self._mods.cracked

    def pot_crack(self) -> np.ndarray:
        """Flat (cell * L + layer) indices of the Pot-Crack list, strongest first."""
        return bt.pot_crack(self._imax().ravel(), self.resistance_value, self._eligible().ravel())

    def unstable_fraction(self) -> float:
        n_act = max(int(self._active.sum()), 1)
        return float(((self._imax() > self.resistance_value) & self._eligible()).sum() / n_act)

    def _births(self, state: State) -> bool:
        mods, n_layers = self._mods, self._active.shape[1]
        rng = state.rng()
        if self.seeds:
            if self._seeded:
                return False
            self._seeded = True
            from scipy.spatial import cKDTree
            dom = mods.sc
            top = self._layers[-1] if len(self._layers) else n_layers - 1
            cand = np.nonzero(self._active[:, top])[0]
            if len(cand) == 0:
                return False
            _, near = cKDTree(np.asarray(dom.center3d)[cand]).query(np.asarray(self.seeds, float))
            cells = cand[np.atleast_1d(near)]
            layers = np.full(len(cells), top)
            forced = np.array([bt.TYPE_NAMES.index(s) for s in self.seed_types], np.int64) \
                if self.seed_types else None
            return self._start(cells, layers, rng, forced)
        pot = self.pot_crack()
        if len(pot) == 0:
            return False
        imax = self._imax().ravel()
        if self._t is None:
            hi, lo = float(imax[pot[0]]), float(imax[pot[-1]])
            self._t = hi
            self._sii = self.interval or max((hi - lo) / self.series, 1e-12 * max(hi, 1e-300))
        while imax[pot[0]] < self._t:                      # lower t until a series starts
            self._t -= self._sii
        cand = pot[imax[pot] >= self._t]
        self._t -= self._sii
        return self._start(*self._spaced(cand, n_layers), rng, None)

    def _spaced(self, cand: np.ndarray, n_layers: int) -> tuple[np.ndarray, np.ndarray]:
        """(cells, layers) of the candidate (cell, layer) slots that keep ``birth_spacing``
        apart on each stressed layer, in the candidates' order."""
        cells, layers = cand // n_layers, cand % n_layers
        keep = np.zeros(len(cand), bool)
        for li in np.unique(layers):                       # per stressed layer
            sel = np.nonzero(layers == li)[0]
            chosen = bt.spaced(cells[sel], self._slots, self.birth_spacing)
            keep[sel[np.isin(cells[sel], chosen)]] = True
        return cells[keep], layers[keep]

    def _start(self, cells: np.ndarray, layers: np.ndarray, rng: np.random.Generator,
               forced: np.ndarray | None) -> bool:
        if len(cells) == 0:
            return False
        spec = self._mods.spec[cells, layers]
        allowed = {bt.TYPE_NAMES.index(t) for t in self.types}
        types = forced if forced is not None else \
            bt.crack_types(spec, self.resistance_value, self.s_floor, self.t_share, allowed, rng)
        direction = bt.crack_axis(spec, self.s_floor, self.resistance_value)
        flip = rng.uniform(size=len(cells)) < 0.5             # which side a T's third head takes
        direction = np.where(flip & (types == bt.T), direction + np.pi, direction)
        who, heading = bt.initial_heads(types, direction)
        self._mods.birth(cells, layers, types, who, heading)
        return True

    # -- the loop -----------------------------------------------------------------------------
    def step(self, state: State) -> bool:
        dom = _surface(state, self.cells, self.name)
        mods = self._mods
        if self.schedule == "step" and not self.seeds:
            return self._sweep(state, dom)
        if mods.n_live == 0 and not self._births(state):
            self._write(state, dom)
            return False
        while mods.n_live:                                 # every CM to its end (5.3.4)
            mods.step()
            self._log.record(mods.n_live, mods.released)
        self._log.end_series(self.unstable_fraction())
        self._write(state, dom)
        if not self.seeds and self.unstable_fraction() <= self.stop_fraction:
            return False
        return True

    def _sweep(self, state: State, dom: Any) -> bool:
        """One sweep of the threshold t from M down to m, births at every CM step (appendix C).

        5.3.1 t = M, the strongest cell of the Pot-Crack list, m its weakest; 5.3.2 at every
        CM step the Pot-Crack cells at or above t start cracks and t drops by Sii (straight
        down to the strongest waiting cell while no CM is alive); 5.3.4 every CM moves one
        step; 5.3.5 once every CM has ended and no waiting cell is left (born, cracked, or
        released below mR), the next iteration refills the list and resets M, m and t (as
        stress only falls, the refill finds nothing and the run is stable after one sweep,
        unless ``max_iterations`` cut it).  Cracks are thus born while earlier ones still run,
        so the number of CMs alive rises as t reaches the many cells just above mR and falls
        once it has passed them (Figure 5.19).  Each step reads only the waiting cells (the
        Pot-Crack list of the sweep's start: a cell's stress only ever falls, so no other cell
        can rise above t), never the whole spectrum.
        """
        mods, n_layers = self._mods, self._active.shape[1]
        waiting = self.pot_crack()
        if len(waiting) == 0 and mods.n_live == 0:
            self._write(state, dom)
            return False
        rng = state.rng()
        flat, cracked = mods.flat, mods.cracked.reshape(-1)
        cur = flat[waiting].max(axis=1)
        t = float(cur[0]) if len(cur) else 0.0
        sii = self.interval or max((float(cur[0]) - float(cur[-1])) / self.series, 1e-12 * max(t, 1e-300)) \
            if len(cur) else 1.0
        while len(waiting) or mods.n_live:
            if len(waiting):
                cur = flat[waiting].max(axis=1)
                keep = ~cracked[waiting] & (cur > self.resistance_value)
                waiting, cur = waiting[keep], cur[keep]
            if len(waiting):
                if mods.n_live == 0 and cur.max() < t:       # 5.3.2: lower t while no CM moves
                    t -= sii * np.ceil((t - float(cur.max())) / sii)
                born = np.nonzero(cur >= t)[0]
                if len(born):
                    cand = waiting[born[np.lexsort((waiting[born], -cur[born]))]]
                    self._start(*self._spaced(cand, n_layers), rng, None)
                t -= sii
            if mods.n_live == 0:
                if len(waiting):
                    continue
                break
            mods.step()
            self._log.record(mods.n_live, mods.released)
        self._log.end_series(self.unstable_fraction())
        self._write(state, dom)
        return self.unstable_fraction() > self.stop_fraction and len(self.pot_crack()) > 0

    def _write(self, state: State, dom: Any) -> None:
        mods = self._mods
        dom.add_field(SPECTRUM, mods.spec.copy(), at="cell", units="1",
                      doc="tension per layer along 0, pi/4, pi/2, 3pi/4 of the facet frame")
        dom.add_field(WIDTH, mods.width.copy(), at="cell", units="length",
                      doc="widest crack crossing the cell per layer (0 = not cracked)")
        dom.add_field("crack__id", mods.crack_of.copy(), at="cell",
                      doc="crack that cracked the cell per layer (-1 none)")
        pts, off, pf, lf = mods.polylines()
        pl = Polylines(pts, off)
        pl.add_field(WIDTH, pf[WIDTH], at="point", units="length", doc="crack width at the vertex")
        pl.add_field("crack__face", pf["crack__face"], at="point", doc="facet of the segment")
        pl.add_field("crack__layer", lf["crack__layer"], at="line", doc="stack layer")
        pl.add_field("crack__type", lf["crack__type"], at="line", doc="0 I, 1 T, 2 Y, 3 X")
        state.add_domain(self.lines, pl)

    def finish(self, state: State) -> None:
        mods, key = self._mods, "cracks"
        state.report(f"{key}.unstable_fraction", self.unstable_fraction())
        state.report(f"{key}.unstable_start_fraction", self._start_unstable)
        state.report(f"{key}.resistance", self.resistance_value)
        state.report(f"{key}.cracks", int(mods.n_cracks))
        state.report(f"{key}.cracked_fraction",
                     float((mods.cracked & self._active).sum() / max(int(self._active.sum()), 1)))
        for name, val in mods.stats.items():
            state.report(f"{key}.{name}", float(val) if isinstance(val, float) else int(val))
        state.report(f"{key}.max_step_cells", mods.stats["max_step"] / float(mods.size))
        pts, off, _, _ = mods.polylines()
        angles = meeting_angles(pts, off, float(mods.size))
        state.report(f"{key}.meetings", int(len(angles)))
        state.report(f"{key}.meeting_angle_deg", float(np.median(angles)) if len(angles) else 0.0)
        self._log.publish(state, self.lines, start_unstable=self._start_unstable,    # this run's own
                          unstable=self.unstable_fraction(), active_cells=int(self._active.sum()),
                          cracks=int(mods.n_cracks))


@dataclass(kw_only=True)
class PaintCracks(RuleBase):
    """A quick look at the crack model: colours per cell (for ``surface_png`` / ``surface_obj``).

    ``show = "cracks"``: the stack's unlit colours (as ``layers.shade lit=false``) with the
    cracked layer removed where ``crack__width`` > 0, so the layer below shows through;
    ``"stress"``: the strongest axis of a layer's spectrum through a colour map (plates 5.1, 5.2);
    ``"cracked"``: the data view of plate 5.17 (a), the cells of the layer's cracks in black on
    white, as the peeling starts from them (the palette of ``cracks.peel``'s views).
    """

    name: ClassVar[str] = "cracks.paint"
    example: ClassVar[tuple[dict, ...]] = _STRESS + ({"rule": "cracks.paint", "params": {"show": "stress"}},)
    uses: ClassVar[dict[str, str]] = {CELLS: "SurfaceCells"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(THICKNESS, CELLS, "cell", "in", units="length"),
        FieldSpec("{field}", CELLS, "cell", "out", units="rgb", doc="colour in [0, 1]"),)
    cells: str = param("cells", doc="SurfaceCells domain")
    show: str = param("cracks", choices=("cracks", "stress", "cracked"),
                      doc="what to colour: the stack through the cracks, the stress, or cracked cells black")
    field: str = param("surface__color", doc="cell colour field to write")
    layer: int = param(-1, doc="stack layer shown (cracked or stressed; -1 = top)")
    cmap: str = param("magma", doc="stress: matplotlib colour map")
    vmax: float | None = param(None, gt=0.0, doc="stress: value at the top of the colour map (default max)")

    def validate(self) -> None:
        check_field_name(self.field)

    def step(self, state: State) -> bool:
        from procgen.exchange.image import to_rgb8
        from procgen_layers.light import shade_stack
        from procgen_layers.stack import load_table

        dom = _surface(state, self.cells, self.name)
        t = np.array(dom[THICKNESS], dtype=float, copy=True)
        li = _layer_indices([self.layer], t.shape[1], f"{self.name}.layer")[0]
        if self.show == "stress":
            if SPECTRUM not in dom:
                raise InputError(f"{self.name}: no {SPECTRUM} on {self.cells!r} (run cracks.stress first)")
            v = np.asarray(dom[SPECTRUM], float)[:, li].max(axis=-1)
            rgb = to_rgb8(v[None, :], self.cmap, 0.0, self.vmax or float(v.max()) or 1.0)[0] / 255.0
        elif self.show == "cracked":
            if WIDTH not in dom:
                raise InputError(f"{self.name}: no {WIDTH} on {self.cells!r} (run cracks.propagate first)")
            cracked = np.asarray(dom[WIDTH])[:, li] > 0
            rgb = np.repeat(np.where(cracked, 0.0, 1.0)[:, None], 3, axis=1)
        else:
            if WIDTH in dom:
                t[np.asarray(dom[WIDTH])[:, li] > 0, li] = 0.0
            rgb = shade_stack(None, t, load_table(dom, self.name), light=np.array([0.0, 0.0, 1.0]),
                              lit=False, white_highlights=True)
        dom.add_field(self.field, rgb, at="cell", units="rgb", doc="colour in [0, 1]")
        return True


RULES = [CrackStress, CrackPropagate, PaintCracks]
