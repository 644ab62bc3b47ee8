"""lines.smooth: Chaikin corner cutting of Polylines (rings stay closed, open ends stay put)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..domains import Polylines
from ..params import param
from ..rules import RuleBase
from ..state import State


def chaikin(points: np.ndarray, closed: bool, iterations: int = 1, ratio: float = 0.25) -> np.ndarray:
    """Chaikin's corner cutting: each segment gives two points at ``ratio`` and ``1 - ratio``."""
    p = np.asarray(points, dtype=np.float64)
    for _ in range(iterations):
        if len(p) < 3:
            return p
        a = p if closed else p[:-1]
        b = np.roll(p, -1, axis=0) if closed else p[1:]
        q = (1 - ratio) * a + ratio * b
        r = ratio * a + (1 - ratio) * b
        mid = np.stack([q, r], axis=1).reshape(-1, p.shape[1])
        p = mid if closed else np.concatenate([p[:1], mid, p[-1:]])
    return p


@dataclass(kw_only=True)
class SmoothLines(RuleBase):
    """Chaikin smoothing: each pass doubles the vertices and rounds every corner.

    Converges to a quadratic B-spline; a closed simple contour stays closed (and, for the small
    ratios allowed here, simple).
    """

    example: ClassVar[tuple[dict, ...]] = ({"rule": "points.poisson_disk", "params": {"radius": 0.08}}, {"rule": "mesh.delaunay"},
                                             {"rule": "mesh.boundary"}, {"rule": "lines.smooth"})
    name: ClassVar[str] = "lines.smooth"
    uses: ClassVar[dict[str, str]] = {"{lines}": "Polylines"}
    creates: ClassVar[dict[str, str]] = {"{out}": "Polylines"}

    lines: str = param("outline", doc="Polylines to smooth")
    out: str = param("smooth_outline", doc="name of the smoothed Polylines (may equal 'lines')")
    passes: int = param(3, ge=1, le=8, doc="corner-cutting passes")
    ratio: float = param(0.25, gt=0.0, le=0.5, doc="cut position along each segment")

    def step(self, state: State) -> bool:
        pl = state.get(self.lines, Polylines)
        lines = [chaikin(pl.line(i), bool(pl.closed[i]), self.passes, self.ratio) for i in range(pl.n_lines)]
        out = Polylines.from_list(lines, closed=pl.closed, bounds=pl.bounds)
        for name, arr, info in pl.fields():
            if info.at == "line":
                out.add_field(name, arr.copy(), at="line", units=info.units, doc=info.doc)
        state.add_domain(self.out, out)
        return True
