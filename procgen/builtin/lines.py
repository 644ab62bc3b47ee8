"""lines.smooth (Chaikin corner cutting: rings stay closed, open ends stay put) and lines.load (SVG)."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from ..domains import Polylines
from ..errors import InputError
from ..exchange.svg_read import read_svg
from ..params import param
from ..rules import RuleBase
from ..state import State
from .loaders import resolve_data_path


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


@dataclass(kw_only=True)
class LoadLines(RuleBase):
    """Closed and open paths of an SVG file (Inkscape, Illustrator) as Polylines, y up.

    Every shape the drawing shows is flattened within ``tolerance`` (procgen.exchange.svg_read:
    layer transforms, arcs, Beziers, units, viewBox). The viewBox's bottom-left corner becomes
    (0, 0) and y is flipped so the outline reads as on paper; ``units = 'mm'`` measures in
    millimetres on paper (from the root width/height), 'user' in the drawing's own units.
    """

    name: ClassVar[str] = "lines.load"
    example: ClassVar[tuple[dict, ...]] = ({"rule": "lines.load", "params": {"file": "data/leaf-logo.svg"}},)
    creates: ClassVar[dict[str, str]] = {"{lines}": "Polylines"}

    file: str = param(doc="SVG file: absolute, relative to the recipe, or shipped (data/leaf-logo.svg)")
    lines: str = param("outline", doc="name of the Polylines to create")
    tolerance: float | None = param(None, gt=0.0, doc="largest curve-to-chord distance in user units "
                                    "(None = 1/1000 of the larger viewBox side)")
    units: str = param("user", choices=("user", "mm"), doc="output in the drawing's user units or paper mm")
    scale: float = param(1.0, gt=0.0, doc="multiply every coordinate by this")
    closed_only: bool = param(False, doc="keep only closed paths; fail at check time if there is none")

    def validate(self) -> None:
        try:
            self.read(self.recipe_dir)
        except InputError as exc:
            raise ValueError(str(exc)) from None

    def read(self, base_dir: Path | None) -> Polylines:
        path = resolve_data_path(self.file, base_dir)
        d = read_svg(path, self.tolerance)
        if self.units == "mm" and d.mm_per_unit is None:
            raise InputError(f"{path.name}: units = 'mm' but the <svg> has no absolute "
                             "width/height; use units = 'user'")
        k = self.scale * (d.mm_per_unit if self.units == "mm" else 1.0)
        keep = [(p, c) for p, c in d.polylines if c or not self.closed_only]
        if not keep:
            what = "closed path (an outline ending in Z, or a rect/circle/polygon)" if self.closed_only else "path"
            raise InputError(f"{path.name}: no {what} in the drawing")
        x0, y0, w, h = d.viewbox
        lines = [np.column_stack([(p[:, 0] - x0) * k, (y0 + h - p[:, 1]) * k]) for p, _ in keep]
        return Polylines.from_list(lines, closed=[c for _, c in keep], bounds=(0.0, w * k, 0.0, h * k))

    def step(self, state: State) -> bool:
        pl = self.read(state.base_dir)
        state.add_domain(self.lines, pl)
        state.report(f"{self.lines}.n_lines", {"closed": int(pl.closed.sum()), "open": int((~pl.closed).sum())})
        return True
