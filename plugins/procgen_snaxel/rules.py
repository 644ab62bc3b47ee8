"""procgen rules of the snaxel family: ``snaxel.grow`` (one cloud) and ``snaxel.cloudscape``."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, ClassVar

import numpy as np

from procgen import FieldSpec, Grid, InputError, Polylines, State, TriMesh, param

from .fractal import ensemble_dimension
from .growth import CloudGrowth, Snapshot
from .params import _EXAMPLE_GROWTH, GrowthParams
from .sketch import check_inside, mark_vertices, strokes_from_lists, strokes_from_svg
from .tile_poisson import tile_sampler
from .tiles import TiledTopology
from .topology import Topology, mesh_topology

SKETCH_DIR = Path(__file__).parent / "sketches"


class GrowthRule(GrowthParams):
    """What both snaxel rules do with the parameters: checks, the tessellation, one growth."""

    def validate(self) -> None:
        super().validate()
        if self.bounds is not None:
            x0, y0, x1, y1 = self.bounds
            room = min(x1 - x0, y1 - y0) - 2.0 * self.margin
            if room < self.g_min:
                raise ValueError(f"bounds {self.bounds} leave {room:g} inside the margin, less than one cluster's "
                                 f"growth g_min = {self.g_min:g}: too small for this cloud (enlarge bounds or drop them)")
        if self.guide_svg is not None:
            self.guide_lines(self.recipe_dir)          # a readable SVG with a stroke, before any compute
        if self.sketch:
            if self.bounds is None:
                raise ValueError("sketch mode needs bounds = [x0, y0, x1, y1] so the sketch can be checked")
            check_inside(self.sketch_strokes(self.recipe_dir), self.domain_box())
        elif self.source is not None:
            m = self.margin
            if self.bounds is not None:
                x0, y0, x1, y1 = self.bounds
                if not (x0 + m <= self.source[0] <= x1 - m and y0 + m <= self.source[1] <= y1 - m):
                    raise ValueError(f"source {self.source} is outside the domain {self.bounds} minus margin {m:g}")
            if self.condensation_level is not None and self.source[1] < self.condensation_level:
                raise ValueError(f"source {self.source} lies below condensation_level = {self.condensation_level:g}")

    # -- helpers ---------------------------------------------------------------------------
    def domain_box(self, xy: np.ndarray | None = None) -> tuple[float, float, float, float]:
        """(x0, x1, y0, y1) as the core's domains store bounds: ``bounds``, else the outline's
        box grown by 5% (unbounded growth)."""
        if self.bounds is not None:
            x0, y0, x1, y1 = self.bounds
            return (float(x0), float(x1), float(y0), float(y1))
        assert xy is not None
        (x0, y0), (x1, y1) = xy.min(0), xy.max(0)
        pad = 0.05 * max(x1 - x0, y1 - y0, 1e-9)
        return (float(x0 - pad), float(x1 + pad), float(y0 - pad), float(y1 + pad))

    def sketch_strokes(self, base_dir: Path | None = None) -> list[np.ndarray]:
        if self.strokes is not None:
            return strokes_from_lists(self.strokes)
        return strokes_from_svg(resolve_sketch(str(self.sketch_svg), base_dir), self.domain_box())

    def guide_lines(self, base_dir: Path | None = None) -> list[np.ndarray]:
        if self.guide_strokes is not None:
            return strokes_from_lists(self.guide_strokes)
        return strokes_from_svg(resolve_sketch(str(self.guide_svg), base_dir), self.domain_box())

    def seed_guide(self, state: State) -> Callable[[np.ndarray], np.ndarray] | None:
        """Attraction of points for seed_policy field (the guide field, bilinear, clamped to the
        raster) or sketch (minus the distance to the nearest guide stroke); None otherwise."""
        if self.seed_policy == "field":
            from scipy.interpolate import RegularGridInterpolator

            grid = state.get(str(self.guide_grid), Grid)
            if self.guide_field not in grid:
                raise InputError(f"{self.name}: guide_grid {self.guide_grid!r} has no field {self.guide_field!r} "
                                 f"(it has {', '.join(grid.field_names()) or 'none'})")
            vals = np.asarray(grid[self.guide_field], np.float64)
            if vals.shape != grid.shape:
                raise InputError(f"{self.name}: guide field {self.guide_field!r} must hold one number per cell")
            ys, xs = grid.y, grid.x
            if len(ys) == 1 or len(xs) == 1:      # a single row / column: constant across it
                ys, xs = np.append(ys, ys[-1] + 1.0), np.append(xs, xs[-1] + 1.0)
                vals = np.broadcast_to(vals, (len(ys), len(xs))) if vals.size == 1 else \
                    np.repeat(np.repeat(vals, 2 if len(grid.y) == 1 else 1, 0), 2 if len(grid.x) == 1 else 1, 1)
            interp = RegularGridInterpolator((ys, xs), vals)
            return lambda p: interp(np.column_stack([np.clip(p[:, 1], ys[0], ys[-1]), np.clip(p[:, 0], xs[0], xs[-1])]))
        if self.seed_policy == "sketch":
            import shapely

            lines = shapely.MultiLineString(self.guide_lines(state.base_dir))
            return lambda p: -shapely.distance(shapely.points(p), lines)
        return None

    def make_topology(self, state: State, rng: np.random.Generator) -> Topology:
        """The eager mesh named by ``mesh``, or lazy tiles seeded from ``rng``."""
        if self.mesh is None:
            return TiledTopology(self.radius, self.tile_side, np.random.SeedSequence(rng.integers(0, 2**32, 4)))
        mesh = state.get(self.mesh, TriMesh)
        try:
            return mesh_topology(mesh)
        except InputError as exc:
            raise InputError(f"{self.name}: mesh {self.mesh!r}: {exc}") from None

    def make_growth(self, state: State, rng: np.random.Generator, topo: Topology,
                    source: list[float] | None = None) -> CloudGrowth:
        cfg = self
        if source is not None:
            level = source[1] - self.base_depth if getattr(self, "base_depth", None) is not None else None
            cfg = dataclasses.replace(self, source=source, condensation_level=level)
        if cfg.speed_cap * cfg.dt > topo.min_edge:
            raise InputError(f"{self.name}: dt = {cfg.dt:g} lets a snaxel travel {cfg.speed_cap * cfg.dt:g} per step, "
                             f"more than the shortest edge {topo.min_edge:.3g}; use dt <= {topo.min_edge / cfg.speed_cap:.3g}")
        marked = None
        bounds = None if self.bounds is None else tuple(map(float, self.bounds))
        try:
            if cfg.sketch:
                strokes = self.sketch_strokes(state.base_dir)
                allp = np.vstack(strokes)
                pad = (cfg.c_t + 2.0) * max(topo.mean_edge, 2.0 * topo.min_edge)
                (x0, y0), (x1, y1) = allp.min(0) - pad, allp.max(0) + pad
                topo.ensure_box(x0, y0, x1, y1)
                marked = mark_vertices(topo, strokes, cfg.c_t)
            growth = CloudGrowth(topo, cfg, rng, bounds=bounds, marked=marked,  # type: ignore[arg-type]
                                 guide=self.seed_guide(state))
        except ValueError as exc:
            raise InputError(f"{self.name}: {exc}") from None
        if growth.snapshot_every == 0:
            growth.snapshot_every = max(1, int(round(4.0 * topo.mean_edge / (cfg.v_max * cfg.dt))))
        if isinstance(topo, TiledTopology) and tile_sampler(topo.accelerate) == "numba":
            # numba is loaded for the tiles anyway, so the events take their compiled path (the
            # same chains, procgen_snaxel.events_numba) at any chain length, not from MIN_SNAXELS
            growth.snake.accelerate = True
        return growth


def resolve_sketch(name: str, base_dir: Path | None = None) -> Path:
    p = Path(name).expanduser()
    cands = [p] if p.is_absolute() else ([base_dir / p] if base_dir else []) + [Path.cwd() / p, SKETCH_DIR / p]
    for c in cands:
        if c.is_file():
            return c
    raise ValueError(f"sketch_svg {name!r} not found (looked in {', '.join(str(c.parent) for c in cands)})")


def contour_domain(xy: np.ndarray, curve: np.ndarray, cluster: np.ndarray,
                   box: tuple[float, float, float, float]) -> Polylines:
    """The snake as one closed line with per-snaxel curve and cluster ids."""
    dom = Polylines(xy, np.array([0, len(xy)]), closed=[True], bounds=box)
    dom.add_field("snaxel__curve", curve, at="point", doc="curve id of each snaxel")
    dom.add_field("snaxel__cluster", cluster, at="point", doc="cluster id of each snaxel's curve")
    return dom


def history_domain(snaps: list[Snapshot], box: tuple[float, float, float, float]) -> Polylines:
    """Earlier contours (oldest first) for the process figure and the animation."""
    dom = Polylines.from_list([s.xy for s in snaps], closed=True, bounds=box)
    dom.add_field("snaxel__curve", np.concatenate([s.curve for s in snaps]), at="point", doc="curve id")
    dom.add_field("snaxel__cluster", np.concatenate([s.cluster for s in snaps]), at="point", doc="cluster id")
    dom.add_field("snapshot__step", np.array([s.step for s in snaps]), at="line", doc="Euler step of the snapshot")
    return dom


def view_domain(topo: Topology, xy: np.ndarray, window: list[float] | None,
                box: tuple[float, float, float, float]) -> Polylines:
    """Figure 1.2: tessellation edges in a window (lines of kind 0) and the snake (kind 1)."""
    if window is None:
        c = xy[np.argmax(xy[:, 0])]
        h = 9.0 * topo.mean_edge
        window = [c[0] - h, c[1] - h, c[0] + h, c[1] + h]
    x0, y0, x1, y1 = window
    p = topo.points
    e = topo.edges()
    inside = (p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 1] >= y0) & (p[:, 1] <= y1)
    e = e[inside[e[:, 0]] | inside[e[:, 1]]]
    lines = [p[[a, b]] for a, b in e]
    kinds = [0] * len(lines)
    lines.append(xy)
    kinds.append(1)
    closed = np.zeros(len(lines), bool)
    closed[-1] = True
    dom = Polylines.from_list(lines, closed=closed, bounds=(x0, x1, y0, y1))
    dom.add_field("view__kind", np.array(kinds), at="line", doc="0 tessellation edge, 1 snake")
    return dom


@dataclass(kw_only=True)
class GrowCloud(GrowthRule):
    """Grow one 2-D cumulus outline with snaxels on a tessellation (thesis seed 004).

    One iteration is one Euler step of the whole snake; the run ends (step returns False) once
    n_c clusters have grown. Creates the contour ``{cloud}`` (refreshed before each of the
    runner's frames), and at the end ``{cloud}_history`` (earlier contours, for the process figure and
    animations) and ``{cloud}_view`` (tessellation/snake/snaxel close-up of Figure 1.2).
    Reports N_s, N_v and event counts.
    """

    name: ClassVar[str] = "snaxel.grow"
    default_iterations: ClassVar[int] = 100000
    example: ClassVar[tuple[dict[str, Any], ...]] = (
        {"rule": "snaxel.grow", "params": _EXAMPLE_GROWTH, "until": "stable"},)
    creates: ClassVar[dict[str, str]] = {"{cloud}": "Polylines", "{cloud}_history": "Polylines",
                                         "{cloud}_view": "Polylines"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        *(FieldSpec(name, domain=dom, at="point", intent="out", doc=doc)
          for dom in ("{cloud}", "{cloud}_history")
          for name, doc in (("snaxel__curve", "curve id of each snaxel"),
                            ("snaxel__cluster", "cluster id of each snaxel's curve"))),
        FieldSpec("snapshot__step", domain="{cloud}_history", at="line", intent="out",
                  doc="Euler step of the snapshot"),
        FieldSpec("view__kind", domain="{cloud}_view", at="line", intent="out",
                  doc="0 tessellation edge, 1 snake"),
    )

    cloud: str = param("cloud", doc="name of the Polylines holding the cloud outline")
    view_window: list[float] | None = param(None, doc="[x0, y0, x1, y1] of the Figure 1.2 close-up; None: auto")

    def setup(self, state: State) -> None:
        rng = state.rng()
        self._topo = self.make_topology(state, rng)
        self._growth = self.make_growth(state, rng, self._topo)
        self.publish(state)

    def publish(self, state: State) -> None:
        """Copy the snake into the {cloud} Polylines (the runner calls it before each frame)."""
        g = self._growth
        c = g.snake.ints[:, 2]
        xy = g.snake.xy()
        self._box = self.domain_box(xy)
        state.add_domain(self.cloud, contour_domain(xy, c, g.cluster_of[c], self._box))

    def step(self, state: State) -> bool:
        return self._growth.step()

    def ensemble_statistics(self, reports: list[dict]) -> dict[str, float]:
        """Over a sweep's runs: Lovejoy's area-perimeter dimension D of all recorded contours, and
        the band of aspect ratio and solidity of the final outlines (``procgen sweep``)."""
        c = self.cloud
        out = ensemble_dimension([r[f"{c}.area_history"] for r in reports], [r[f"{c}.perimeter_history"] for r in reports],
                                 max(r[f"{c}.raster_pixel"] for r in reports))
        for key in ("aspect", "solidity"):
            v = [r[f"{c}.{key}"] for r in reports]
            out.update({f"{key}_min": min(v), f"{key}_median": round(float(np.median(v)), 4), f"{key}_max": max(v)})
        out["runs"] = len(reports)
        return out

    def finish(self, state: State) -> None:
        g = self._growth
        g.snapshot()
        self.publish(state)
        state.add_domain(f"{self.cloud}_history", history_domain(g.snapshots, self._box))
        state.add_domain(f"{self.cloud}_view", view_domain(self._topo, g.snake.xy(), self.view_window, self._box))
        if isinstance(self._topo, TiledTopology):
            state.report(f"{self.cloud}.tiles", self._topo.n_tiles)
            state.report(f"{self.cloud}.tile_sampler", tile_sampler(self._topo.accelerate))
        for k, v in g.report().items():
            state.report(k if k in ("N_s", "N_v") else f"{self.cloud}.{k}", v)
        state.report(f"{self.cloud}.clusters", g.stats.cluster_log)
        state.report(f"{self.cloud}.finished", bool(g.done))


@dataclass(kw_only=True)
class Cloudscape(GrowthRule):
    """Several clouds grown with their own seeds and sources, for back-to-front compositing.

    The thesis's section 1.2 idea (layering separately grown outlines), which it never built:
    cloud i grows on the same tessellation from its own source with its own random stream.
    Creates ``{scape}``: one closed line per cloud, with line field cloud__depth (0 = farthest).
    """

    name: ClassVar[str] = "snaxel.cloudscape"
    example: ClassVar[tuple[dict[str, Any], ...]] = (
        {"rule": "snaxel.cloudscape", "params": dict(_EXAMPLE_GROWTH, n_clouds=2, margin=20.0)},)
    creates: ClassVar[dict[str, str]] = {"{scape}": "Polylines"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("cloud__depth", domain="{scape}", at="line", intent="out", doc="0 = farthest, drawn first"),
        FieldSpec("snaxel__curve", domain="{scape}", at="point", intent="out",
                  doc="curve id of each snaxel (per cloud)"),
    )

    scape: str = param("cloudscape", doc="name of the Polylines holding every cloud outline")
    n_clouds: int = param(4, ge=1, le=64, doc="number of clouds")
    sources: list[list[float]] | None = param(None, doc="[[x, y], ...] one per cloud; None: random x, far ones lower")
    base_depth: float | None = param(None, gt=0.0, units="length",
                                     doc="flat bases: each cloud's condensation level lies this far below its source")

    def validate(self) -> None:
        super().validate()
        if self.sources is not None and len(self.sources) != self.n_clouds:
            raise ValueError(f"sources has {len(self.sources)} entries for n_clouds = {self.n_clouds}")
        if self.sketch_svg is not None or self.strokes is not None:
            raise ValueError("snaxel.cloudscape does not take a sketch; use snaxel.grow")

    def step(self, state: State) -> bool:
        rng = state.rng()
        topo = self.make_topology(state, rng)
        if self.bounds is not None:
            x0, y0, x1, y1 = self.bounds
        elif not topo.unbounded:
            (x0, y0), (x1, y1) = topo.points.min(0), topo.points.max(0)
        elif self.sources is None:
            raise InputError(f"{self.name}: unbounded growth needs bounds or sources to place the clouds")
        m = self.margin
        if self.sources is not None:
            sources = [list(map(float, s)) for s in self.sources]
        else:    # back (depth 0) clouds sit lower, towards the horizon: a base plane seen from below
            depth_y = np.linspace(0.34, 0.66, self.n_clouds)
            xs = (rng.permutation(self.n_clouds) + rng.uniform(0.3, 0.7, self.n_clouds)) / self.n_clouds
            sources = [[x0 + m + (x1 - x0 - 2 * m) * float(xs[i]), y0 + m + (y1 - y0 - 2 * m) * float(depth_y[i])]
                       for i in range(self.n_clouds)]
        lines, curves, stats = [], [], []
        for child, src in zip(rng.spawn(self.n_clouds), sources):
            growth = self.make_growth(state, child, topo, source=src)
            growth.snapshot_every = 0
            growth.run()
            lines.append(growth.snake.xy())
            curves.append(growth.snake.ints[:, 2].copy())
            stats.append(growth.report())
        dom = Polylines.from_list(lines, closed=True, bounds=self.domain_box(np.vstack(lines)))
        dom.add_field("cloud__depth", np.arange(self.n_clouds), at="line", doc="0 = farthest, drawn first")
        dom.add_field("snaxel__curve", np.concatenate(curves), at="point", doc="curve id of each snaxel (per cloud)")
        state.add_domain(self.scape, dom)
        state.report("N_v", topo.n_vertices)
        state.report("N_s", [s["N_s"] for s in stats])
        state.report(f"{self.scape}.steps", [s["steps"] for s in stats])
        return True
