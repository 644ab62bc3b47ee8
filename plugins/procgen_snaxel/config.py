"""The growth model's parameters, named as in the thesis, with cross-parameter checks.

Defaults are the most common row of Table 4.2 (Figure 4.2(e)/4.7(a)/4.9(a)): r = 0.1, w_s = 1,
[v_min, v_max] = [5, 30], c_min = 3, G_max = 10, [t_min, t_max] = [0, 150],
[g_min, g_max] = [240, 250], n_c = 7, Table 4.5. Lengths are in domain units (pixels).
"""
from __future__ import annotations

from dataclasses import dataclass, field

from .tables import THESIS_TABLES, LengthLimits, parse_table


@dataclass(kw_only=True)
class GrowthConfig:
    """Everything the simulation needs besides the tessellation and the random generator."""

    r: float = 0.1
    w_s: float = 1.0
    v_min: float = 5.0
    v_max: float = 30.0
    c_min: float = 3.0
    G_max: float = 10.0
    table: list[list[float]] = field(default_factory=lambda: [list(r) for r in THESIS_TABLES["4.5"]])
    t_min: float = 0.0
    t_max: float = 150.0
    g_min: float = 240.0
    g_max: float = 250.0
    n_c: int = 7
    details: str = "circular"          # circular | linear
    base: str = "blend"                # blend (Eq 3.6) | sum (Fig 3.13) | off (Fig 3.15b)
    seed_from: str = "cluster"         # cluster (thesis) | any (future-work variant: any curve of the snake)
    dt: float = 0.05
    source: list[float] | None = None  # None: the domain centre
    margin: float = 10.0
    init_offset: float = 0.05
    max_steps: int = 20000
    guard_steps: int = 200
    guard_delta: float = 1.0
    cluster_max_steps: int = 5000
    snapshot_every: int = 0            # 0: about 24 snapshots per run
    strokes: list[list[float]] | None = None
    sketch_svg: str | None = None
    c_t: float = 1.0
    sketch_speed: float | None = None  # phase-1 speed; None: v_max

    def check(self) -> LengthLimits:
        """Raise ValueError (one line) on a bad combination; return the parsed table."""
        if not self.v_min > 0:
            raise ValueError(f"v_min = {self.v_min:g} must be > 0 (the circular profile degenerates at 0)")
        if self.v_max < self.v_min:
            raise ValueError(f"v_max = {self.v_max:g} is below v_min = {self.v_min:g}")
        if not 0.0 <= self.w_s <= 1.0:
            raise ValueError(f"w_s = {self.w_s:g} must lie in [0, 1] (else 1 - w_s k can go negative)")
        if self.t_max < self.t_min:
            raise ValueError(f"t_max = {self.t_max:g} is below t_min = {self.t_min:g}")
        if self.g_max < self.g_min:
            raise ValueError(f"g_max = {self.g_max:g} is below g_min = {self.g_min:g}")
        if not self.g_max > self.t_max:
            raise ValueError(f"g_max = {self.g_max:g} must exceed t_max = {self.t_max:g} "
                             "(every cluster reset would start past its allowed growth)")
        if self.details not in ("circular", "linear"):
            raise ValueError(f"details = {self.details!r}: expected 'circular' or 'linear'")
        if self.seed_from not in ("cluster", "any"):
            raise ValueError(f"seed_from = {self.seed_from!r}: expected 'cluster' or 'any'")
        if self.base not in ("blend", "sum", "off"):
            raise ValueError(f"base = {self.base!r}: expected 'blend', 'sum' or 'off'")
        if self.source is not None and len(self.source) != 2:
            raise ValueError(f"source must be [x, y], got {self.source}")
        if self.strokes is not None:
            for i, s in enumerate(self.strokes):
                if len(s) < 4 or len(s) % 2:
                    raise ValueError(f"strokes[{i}]: need [x0, y0, x1, y1, ...] with >= 2 points")
        if self.strokes is not None and self.sketch_svg is not None:
            raise ValueError("give strokes or sketch_svg, not both")
        return parse_table(self.table, "table")

    @property
    def sketch(self) -> bool:
        return self.strokes is not None or self.sketch_svg is not None

    @property
    def speed_cap(self) -> float:
        """Largest speed any snaxel can get under this scheme."""
        cap = 2.0 * self.v_max if self.base == "sum" else self.v_max
        return max(cap, self.sketch_speed or 0.0)
