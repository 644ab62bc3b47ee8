"""points.poisson_disk: maximal Poisson-disk samples in a rectangle."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import ClassVar

from ..domains import PointSet
from ..fields import FieldSpec
from ..params import param
from ..rules import RuleBase
from ..state import State


@dataclass(kw_only=True)
class PoissonDiskSampling(RuleBase):
    """Maximal Poisson-disk points: no two closer than radius, no gap where another would fit.

    The blue-noise point set that snaxel tessellations and scattered seeds start from.
    """

    name: ClassVar[str] = "points.poisson_disk"
    creates: ClassVar[dict[str, str]] = {"{domain}": "PointSet"}
    fields: ClassVar[tuple[FieldSpec, ...]] = ()

    domain: str = param("points", doc="name of the PointSet to create")
    width: float = param(1.0, gt=0.0, units="length", doc="domain width")
    height: float = param(1.0, gt=0.0, units="length", doc="domain height")
    x0: float = param(0.0, units="length", doc="left edge")
    y0: float = param(0.0, units="length", doc="bottom edge")
    radius: float = param(0.02, gt=0.0, units="length", doc="minimum distance between points")

    def validate(self) -> None:
        from .poisson import MAX_GRID_CELLS

        cells = self.grid_cells()
        if cells > MAX_GRID_CELLS:
            raise ValueError(f"radius {self.radius:g} on {self.width:g} x {self.height:g} needs {cells:.3g} "
                             f"background cells (about {self.expected_points():.2g} points), more than "
                             f"{MAX_GRID_CELLS:.3g}; use a larger radius or a smaller domain")

    def grid_cells(self) -> int:
        """Background cells of side r/sqrt(2) the sampler allocates."""
        side = self.radius / math.sqrt(2.0)
        return math.ceil(self.width / side) * math.ceil(self.height / side)

    def expected_points(self) -> float:
        # random-dart maximal sets: about 0.70 / r^2 points per unit area (measured, edges included)
        return 0.70 * self.width * self.height / self.radius ** 2

    def memory_estimate(self) -> int:
        return 550 * self.grid_cells()   # measured peak bytes per background cell

    def step(self, state: State) -> bool:
        from .poisson import poisson_disk

        pts = poisson_disk(state.rng(), (self.width, self.height), self.radius, origin=(self.x0, self.y0))
        state.add_domain(self.domain, PointSet(pts, bounds=(self.x0, self.x0 + self.width,
                                                             self.y0, self.y0 + self.height)))
        state.report(f"{self.domain}.n_points", int(len(pts)))
        return True
