"""The growth model's parameters, declared once as the snaxel rules' parameters.

Named as in the thesis; defaults are the most common row of Table 4.2 (Figure 4.2(e)/4.7(a)/
4.9(a)): r = 0.1, w_s = 1, [v_min, v_max] = [5, 30], c_min = 3, G_max = 10, [t_min, t_max] =
[0, 150], [g_min, g_max] = [240, 250], n_c = 7, Table 4.5. Lengths are in domain units (the
thesis's pixels). The simulation (:class:`.growth.CloudGrowth`) reads this object directly.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

from procgen import FieldSpec, RuleBase, param

from .tables import THESIS_TABLES, LengthLimits, parse_table

_EXAMPLE_GROWTH: dict[str, Any] = {"bounds": [0.0, 0.0, 100.0, 100.0], "radius": 2.0, "tile": 24.0,
                                   "table": [[0, 5, 40], [5, 8]], "t_max": 5.0, "g_min": 12.0, "g_max": 14.0,
                                   "n_c": 2, "margin": 3.0, "c_min": 0.5}

SEED_POLICIES = ("uniform", "height", "centroid", "spread", "field", "sketch")


@dataclass(kw_only=True)
class GrowthParams(RuleBase):
    """The thesis's parameters (Table 4.2 most common row as defaults) plus the ones it leaves open."""

    mesh: str | None = param(None, doc="TriMesh to grow on (e.g. points.poisson_disk + mesh.delaunay); "
                                       "None: Poisson-disk tiles made lazily where the cloud grows")
    radius: float = param(4.0, gt=0.0, units="length", doc="Poisson-disk radius of the lazy tiles (mesh = None)")
    tile: float | None = param(None, gt=0.0, units="length", doc="side of a lazy tile; None: 16 x radius")
    bounds: list[float] | None = param(None, doc="drawing domain [x0, y0, x1, y1]; snaxels stop at its margin; "
                                                 "None: unbounded (lazy tiles) or the mesh's box")
    r: float = param(0.1, ge=0.0, le=10.0, units="1/length", doc="influence rate: k = exp(-r t) (Eq 3.5)")
    w_s: float = param(1.0, ge=0.0, le=1.0, doc="weight of the base speed (Eq 3.6)")
    v_min: float = param(5.0, gt=0.0, units="length/time", doc="lower end of each curve's random speeds")
    v_max: float = param(30.0, gt=0.0, units="length/time", doc="upper end of each curve's random speeds")
    c_min: float = param(3.0, ge=0.0, units="length", doc="curves shorter than this merge into a neighbour")
    G_max: float = param(10.0, gt=0.0, doc="projection segment of the circular scheme (shape knob with v)")
    table: list[list[float]] = param([list(r) for r in THESIS_TABLES["4.5"]],
                                     doc="length-limits table: rows [from, to, max length], last may be [from, max]")
    limit_jitter: float = param(0.0, ge=0.0, le=1.0,
                                doc="each curve's table limit times exp(u), u uniform in [-limit_jitter, "
                                    "limit_jitter] per curve: bumps and fringes of varied sizes (0: the thesis)")
    curve_distance: str = param("inherit", choices=("inherit", "own"),
                                doc="a curve's travelled distance for the length-limits table (section 3.5.1): "
                                    "inherit (the biggest distance any of its snaxels travelled, never less than "
                                    "that of the curve it broke from: only a cluster reset sets it back) or own "
                                    "(its snaxels' only: the slow piece of a broken curve drops back to an earlier "
                                    "row and stays a long smooth arc)")
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
    seed_policy: str = param("uniform", choices=SEED_POLICIES,
                             doc="weights of the candidate seed curves: uniform (thesis), height (high curves), "
                                 "centroid (curves near the cloud's centroid), spread (curves far out sideways), "
                                 "field (high guide_field values), sketch (curves near the guide strokes)")
    seed_bias: float = param(4.0, ge=0.0, le=50.0, doc="strength of a non-uniform seed_policy (0: uniform)")
    guide_grid: str | None = param(None, doc="seed_policy = field: the Grid holding guide_field")
    guide_field: str = param("image__value", doc="seed_policy = field: Grid cell field, higher = next clusters grow there")
    guide_strokes: list[list[float]] | None = param(None, doc="seed_policy = sketch: strokes [x0, y0, x1, y1, ...] "
                                                              "that draw the next clusters near them")
    guide_svg: str | None = param(None, doc="seed_policy = sketch: SVG whose strokes draw the next clusters near "
                                            "them (its viewBox mapped onto bounds)")
    condensation_level: float | None = param(None, units="length",
                                             doc="flat base: snaxels heading below this height stop; None: no base")
    merge: str = param("immediate", choices=("immediate", "head_on"),
                       doc="immediate: snaxels heading into a vertex just entered die at once (same topology); "
                           "head_on: thesis-literal, they die when they collide with a child sent back at them")
    dt: float = param(0.05, gt=0.0, le=10.0, units="time", doc="Euler time step")
    source: list[float] | None = param(None, doc="[x, y] of the source vertex; None: domain centre (origin if unbounded)")
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

    uses: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}

    def domains_used(self) -> dict[str, str]:
        used = {} if self.mesh is None else super().domains_used()
        if self.guide_grid is not None:
            used[self.guide_grid] = "Grid"
        return used

    def field_specs(self) -> list[FieldSpec]:
        guide = [FieldSpec(self.guide_field, self.guide_grid, "cell", "in", doc="seed-curve guide")] \
            if self.guide_grid is not None else []
        return super().field_specs() + guide

    def validate(self) -> None:
        self.check_growth()

    def check_growth(self) -> LengthLimits:
        """Raise ValueError (one line) on a bad combination; return the parsed table."""
        if self.v_max < self.v_min:
            raise ValueError(f"v_max = {self.v_max:g} is below v_min = {self.v_min:g}")
        if self.t_max < self.t_min:
            raise ValueError(f"t_max = {self.t_max:g} is below t_min = {self.t_min:g}")
        if self.g_max < self.g_min:
            raise ValueError(f"g_max = {self.g_max:g} is below g_min = {self.g_min:g}")
        if not self.g_max > self.t_max:
            raise ValueError(f"g_max = {self.g_max:g} must exceed t_max = {self.t_max:g} "
                             "(every cluster reset would start past its allowed growth)")
        if self.source is not None and len(self.source) != 2:
            raise ValueError(f"source must be [x, y], got {self.source}")
        if self.strokes is not None:
            for i, s in enumerate(self.strokes):
                if len(s) < 4 or len(s) % 2:
                    raise ValueError(f"strokes[{i}]: need [x0, y0, x1, y1, ...] with >= 2 points")
        if self.strokes is not None and self.sketch_svg is not None:
            raise ValueError("give strokes or sketch_svg, not both")
        self._check_guide()
        if self.mesh is None and self.tile_side < 2.0 * self.radius:
            raise ValueError(f"tile = {self.tile_side:g} must be at least 2 x radius = {2 * self.radius:g}")
        if self.bounds is not None:
            if len(self.bounds) != 4 or not (self.bounds[2] > self.bounds[0] and self.bounds[3] > self.bounds[1]):
                raise ValueError(f"bounds {self.bounds} must be [x0, y0, x1, y1] with x1 > x0 and y1 > y0")
        return parse_table(self.table, "table")

    def _check_guide(self) -> None:
        """The guide a seed_policy of field or sketch needs, and no guide another policy would ignore."""
        strokes = self.guide_strokes is not None or self.guide_svg is not None
        if self.seed_policy == "field" and self.guide_grid is None:
            raise ValueError("seed_policy = 'field' needs guide_grid (a Grid whose guide_field scores the seed curves)")
        if self.seed_policy == "sketch" and not strokes:
            raise ValueError("seed_policy = 'sketch' needs guide_strokes or guide_svg")
        if self.guide_strokes is not None and self.guide_svg is not None:
            raise ValueError("give guide_strokes or guide_svg, not both")
        if self.guide_svg is not None and self.bounds is None:
            raise ValueError("guide_svg needs bounds = [x0, y0, x1, y1] to map its viewBox onto")
        for i, s in enumerate(self.guide_strokes or []):
            if len(s) < 4 or len(s) % 2:
                raise ValueError(f"guide_strokes[{i}]: need [x0, y0, x1, y1, ...] with >= 2 points")
        if (self.guide_grid is not None and self.seed_policy != "field") or (strokes and self.seed_policy != "sketch"):
            raise ValueError(f"a guide is given but seed_policy = {self.seed_policy!r} ignores it "
                             "(field uses guide_grid, sketch uses guide_strokes / guide_svg)")

    @property
    def tile_side(self) -> float:
        return self.tile if self.tile is not None else 16.0 * self.radius

    @property
    def sketch(self) -> bool:
        return self.strokes is not None or self.sketch_svg is not None

    @property
    def speed_cap(self) -> float:
        """Largest speed any snaxel can get under this scheme."""
        cap = 2.0 * self.v_max if self.base == "sum" else self.v_max
        return max(cap, self.sketch_speed or 0.0)
