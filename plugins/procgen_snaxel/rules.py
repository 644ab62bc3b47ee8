"""procgen rules of the snaxel family: ``snaxel.grow`` (one cloud) and ``snaxel.cloudscape``."""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar

import numpy as np

from procgen import InputError, Polylines, RuleBase, State, TriMesh, param

from .config import GrowthConfig
from .growth import CloudGrowth, Snapshot
from .sketch import check_inside, mark_vertices, strokes_from_lists, strokes_from_svg
from .tables import THESIS_TABLES
from .topology import Topology, build_topology

SKETCH_DIR = Path(__file__).parent / "sketches"

# a tiny tessellation and a scaled-down Table 4.5 for the contract suite's example runs
_EXAMPLE_MESH: tuple[dict[str, Any], ...] = (
    {"rule": "points.poisson_disk", "params": {"width": 100.0, "height": 100.0, "radius": 2.0}},
    {"rule": "mesh.delaunay"},
)
_EXAMPLE_GROWTH: dict[str, Any] = {"bounds": [0.0, 0.0, 100.0, 100.0], "table": [[0, 5, 40], [5, 8]], "t_max": 5.0,
                                   "g_min": 12.0, "g_max": 14.0, "n_c": 2, "margin": 3.0, "c_min": 0.5}


@dataclass(kw_only=True)
class GrowthParams(RuleBase):
    """The thesis's parameters (Table 4.2 most common row as defaults) plus the ones it leaves open."""

    mesh: str = param("tessellation", doc="TriMesh (Poisson-disk + Delaunay) the snaxels move on")
    bounds: list[float] | None = param(None, doc="drawing domain [x0, y0, x1, y1]; None: the mesh's bounding box")
    r: float = param(0.1, ge=0.0, le=10.0, units="1/length", doc="influence rate: k = exp(-r t) (Eq 3.5)")
    w_s: float = param(1.0, ge=0.0, le=1.0, doc="weight of the base speed (Eq 3.6)")
    v_min: float = param(5.0, gt=0.0, units="length/time", doc="lower end of each curve's random speeds")
    v_max: float = param(30.0, gt=0.0, units="length/time", doc="upper end of each curve's random speeds")
    c_min: float = param(3.0, ge=0.0, units="length", doc="curves shorter than this merge into a neighbour")
    G_max: float = param(10.0, gt=0.0, doc="projection segment of the circular scheme (shape knob with v)")
    table: list[list[float]] = param([list(r) for r in THESIS_TABLES["4.5"]],
                                     doc="length-limits table: rows [from, to, max length], last may be [from, max]")
    t_min: float = param(0.0, ge=0.0, units="length", doc="cluster reset distance, lower end")
    t_max: float = param(150.0, ge=0.0, units="length", doc="cluster reset distance, upper end")
    g_min: float = param(240.0, gt=0.0, units="length", doc="cluster allowed growth, lower end")
    g_max: float = param(250.0, gt=0.0, units="length", doc="cluster allowed growth, upper end")
    n_c: int = param(7, ge=1, le=1000, doc="number of clusters to grow")
    details: str = param("circular", choices=("circular", "linear"), doc="details-phase speed profile")
    base: str = param("blend", choices=("blend", "sum", "off"),
                      doc="blend (Eq 3.6), sum (Fig 3.13: b_v + l_v) or off (Fig 3.15b: l_v only)")
    seed_from: str = param("cluster", choices=("cluster", "any"),
                           doc="next cluster's seed: a curve of the cluster just stopped (thesis) or of the whole snake")
    dt: float = param(0.05, gt=0.0, le=10.0, units="time", doc="Euler time step")
    source: list[float] | None = param(None, doc="[x, y] of the source vertex; None: domain centre")
    margin: float = param(10.0, ge=0.0, units="length", doc="snaxels heading closer than this to the border stop")
    init_offset: float = param(0.05, gt=0.0, lt=0.5, doc="initial snaxels' offset along their edges (fraction)")
    max_steps: int = param(20000, ge=1, doc="hard cap on Euler steps")
    guard_steps: int = param(200, ge=1, doc="progress guard: steps allowed without guard_delta of progress")
    guard_delta: float = param(1.0, gt=0.0, units="length", doc="progress guard: required travel gain")
    cluster_max_steps: int = param(5000, ge=1, doc="cap on steps per cluster")
    snapshot_every: int = param(0, ge=0, doc="record the contour every K steps for the process figure; 0: auto")
    strokes: list[list[float]] | None = param(None, doc="sketch strokes, each [x0, y0, x1, y1, ...] in domain units")
    sketch_svg: str | None = param(None, doc="SVG whose paths are the sketch (absolute, cwd-relative or shipped name)")
    c_t: float = param(1.0, ge=0.0, le=20.0, doc="thickness of the initial growth around the sketch (edge lengths)")
    sketch_speed: float | None = param(None, gt=0.0, units="length/time", doc="engulfing speed; None: v_max")

    def growth_config(self) -> GrowthConfig:
        names = {f.name for f in dataclasses.fields(GrowthConfig)}
        return GrowthConfig(**{k: v for k, v in self.param_values().items() if k in names})

    def validate(self) -> None:
        cfg = self.growth_config()
        cfg.check()
        if self.bounds is not None:
            if len(self.bounds) != 4 or not (self.bounds[2] > self.bounds[0] and self.bounds[3] > self.bounds[1]):
                raise ValueError(f"bounds {self.bounds} must be [x0, y0, x1, y1] with x1 > x0 and y1 > y0")
        if cfg.sketch:
            if self.bounds is None:
                raise ValueError("sketch mode needs bounds = [x0, y0, x1, y1] so the sketch can be checked")
            check_inside(self.sketch_strokes(self.recipe_dir), self.domain_box())
        elif self.source is not None and self.bounds is not None:
            x0, y0, x1, y1 = self.bounds
            m = self.margin
            if not (x0 + m <= self.source[0] <= x1 - m and y0 + m <= self.source[1] <= y1 - m):
                raise ValueError(f"source {self.source} is outside the domain {self.bounds} minus margin {m:g}")

    # -- helpers ---------------------------------------------------------------------------
    def domain_box(self, topo: Topology | None = None) -> tuple[float, float, float, float]:
        """(x0, x1, y0, y1) as the core's domains store bounds."""
        if self.bounds is not None:
            x0, y0, x1, y1 = self.bounds
        else:
            assert topo is not None
            (x0, y0), (x1, y1) = topo.points.min(0), topo.points.max(0)
        return (float(x0), float(x1), float(y0), float(y1))

    def sketch_strokes(self, base_dir: Path | None = None) -> list[np.ndarray]:
        if self.strokes is not None:
            return strokes_from_lists(self.strokes)
        return strokes_from_svg(resolve_sketch(str(self.sketch_svg), base_dir), self.domain_box())

    def make_growth(self, state: State, rng: np.random.Generator, source: list[float] | None = None,
                    topo: Topology | None = None) -> tuple[CloudGrowth, Topology]:
        if topo is None:
            mesh = state.get(self.mesh, TriMesh)
            try:
                topo = build_topology(mesh.vertices[:, :2], mesh.faces)
            except InputError as exc:
                raise InputError(f"{self.name}: mesh {self.mesh!r}: {exc}") from None
        cfg = self.growth_config()
        if source is not None:
            cfg.source = source
        box = self.domain_box(topo)
        if cfg.speed_cap * cfg.dt > topo.min_edge:
            raise InputError(f"{self.name}: dt = {cfg.dt:g} lets a snaxel travel {cfg.speed_cap * cfg.dt:g} per step, "
                             f"more than the shortest edge {topo.min_edge:.3g}; use dt <= {topo.min_edge / cfg.speed_cap:.3g}")
        marked = None
        try:
            if cfg.sketch:
                marked = mark_vertices(topo, self.sketch_strokes(state.base_dir), cfg.c_t)
            growth = CloudGrowth(topo, cfg, rng, bounds=(box[0], box[2], box[1], box[3]), marked=marked)
        except ValueError as exc:
            raise InputError(f"{self.name}: {exc}") from None
        if growth.snapshot_every == 0:
            growth.snapshot_every = max(1, int(round(4.0 * topo.mean_edge / (cfg.v_max * cfg.dt))))
        return growth, topo


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
    src = np.repeat(np.arange(topo.n_vertices), np.diff(topo.ring_ptr))
    e = np.column_stack([src, topo.ring])
    e = e[e[:, 0] < e[:, 1]]
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
class GrowCloud(GrowthParams):
    """Grow one 2-D cumulus outline with snaxels on a tessellation (thesis seed 004).

    One iteration is one Euler step of the whole snake; the run ends (step returns False) once
    n_c clusters have grown. Creates the contour ``{cloud}`` (refreshed before each of the
    runner's frames), and at the end ``{cloud}_history`` (earlier contours, for the process figure and
    animations) and ``{cloud}_view`` (tessellation/snake/snaxel close-up of Figure 1.2).
    Reports N_s, N_v and event counts.
    """

    name: ClassVar[str] = "snaxel.grow"
    default_iterations: ClassVar[int] = 100000
    example: ClassVar[tuple[dict[str, Any], ...]] = _EXAMPLE_MESH + (
        {"rule": "snaxel.grow", "params": _EXAMPLE_GROWTH, "until": "stable"},)
    uses: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    creates: ClassVar[dict[str, str]] = {"{cloud}": "Polylines", "{cloud}_history": "Polylines",
                                         "{cloud}_view": "Polylines"}

    cloud: str = param("cloud", doc="name of the Polylines holding the cloud outline")
    view_window: list[float] | None = param(None, doc="[x0, y0, x1, y1] of the Figure 1.2 close-up; None: auto")

    def setup(self, state: State) -> None:
        self._growth, self._topo = self.make_growth(state, state.rng())
        self._box = self.domain_box(self._topo)
        self.publish(state)

    def publish(self, state: State) -> None:
        """Copy the snake into the {cloud} Polylines (the runner calls it before each frame)."""
        g = self._growth
        c = g.snake.ints[:, 2]
        state.add_domain(self.cloud, contour_domain(g.snake.xy(), c, g.cluster_of[c], self._box))

    def step(self, state: State) -> bool:
        return self._growth.step()

    def finish(self, state: State) -> None:
        g = self._growth
        g.snapshot()
        self.publish(state)
        state.add_domain(f"{self.cloud}_history", history_domain(g.snapshots, self._box))
        state.add_domain(f"{self.cloud}_view", view_domain(self._topo, g.snake.xy(), self.view_window, self._box))
        for k, v in g.report().items():
            state.report(k if k in ("N_s", "N_v") else f"{self.cloud}.{k}", v)
        state.report(f"{self.cloud}.clusters", g.stats.cluster_log)
        state.report(f"{self.cloud}.finished", bool(g.done))


@dataclass(kw_only=True)
class Cloudscape(GrowthParams):
    """Several clouds grown with their own seeds and sources, for back-to-front compositing.

    The thesis's section 1.2 idea (layering separately grown outlines), which it never built:
    cloud i grows on the same tessellation from its own source with its own random stream.
    Creates ``{scape}``: one closed line per cloud, with line field cloud__depth (0 = farthest).
    """

    name: ClassVar[str] = "snaxel.cloudscape"
    example: ClassVar[tuple[dict[str, Any], ...]] = _EXAMPLE_MESH + (
        {"rule": "snaxel.cloudscape", "params": dict(_EXAMPLE_GROWTH, n_clouds=2, margin=20.0)},)
    uses: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    creates: ClassVar[dict[str, str]] = {"{scape}": "Polylines"}

    scape: str = param("cloudscape", doc="name of the Polylines holding every cloud outline")
    n_clouds: int = param(4, ge=1, le=64, doc="number of clouds")
    sources: list[list[float]] | None = param(None, doc="[[x, y], ...] one per cloud; None: random, far ones higher")

    def validate(self) -> None:
        super().validate()
        if self.sources is not None and len(self.sources) != self.n_clouds:
            raise ValueError(f"sources has {len(self.sources)} entries for n_clouds = {self.n_clouds}")
        if self.sketch_svg is not None or self.strokes is not None:
            raise ValueError("snaxel.cloudscape does not take a sketch; use snaxel.grow")

    def step(self, state: State) -> bool:
        rng = state.rng()
        mesh = state.get(self.mesh, TriMesh)
        (x0, y0), (x1, y1) = mesh.vertices[:, :2].min(0), mesh.vertices[:, :2].max(0)
        if self.bounds is not None:
            x0, y0, x1, y1 = self.bounds
        m = self.margin
        if self.sources is not None:
            sources = [list(map(float, s)) for s in self.sources]
        else:    # back (depth 0) clouds sit higher, front ones lower: a receding sky
            depth_y = np.linspace(0.66, 0.34, self.n_clouds)
            xs = (rng.permutation(self.n_clouds) + rng.uniform(0.3, 0.7, self.n_clouds)) / self.n_clouds
            sources = [[x0 + m + (x1 - x0 - 2 * m) * float(xs[i]), y0 + m + (y1 - y0 - 2 * m) * float(depth_y[i])]
                       for i in range(self.n_clouds)]
        lines, stats = [], []
        topo = None
        for i, (child, src) in enumerate(zip(rng.spawn(self.n_clouds), sources)):
            growth, topo = self.make_growth(state, child, source=src, topo=topo)
            growth.snapshot_every = 0
            growth.run()
            lines.append(growth.snake.xy())
            stats.append(growth.report())
        assert topo is not None
        box = self.domain_box(topo)
        dom = Polylines.from_list(lines, closed=True, bounds=box)
        dom.add_field("cloud__depth", np.arange(self.n_clouds), at="line", doc="0 = farthest, drawn first")
        state.add_domain(self.scape, dom)
        state.report("N_v", stats[0]["N_v"])
        state.report("N_s", [s["N_s"] for s in stats])
        state.report(f"{self.scape}.steps", [s["steps"] for s in stats])
        return True
