"""points.poisson_disk: maximal Poisson-disk samples in a rectangle."""
from __future__ import annotations

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
        n = self.expected_points()
        if n > 5e7:
            raise ValueError(f"radius {self.radius:g} gives about {n:.2g} points; use a larger radius")

    def expected_points(self) -> float:
        # maximal sets cover the plane with density about 0.7 / r^2 points per unit area
        return 0.75 * self.width * self.height / self.radius ** 2

    def memory_estimate(self) -> int:
        return int(self.expected_points() * 200)

    def step(self, state: State) -> bool:
        from .poisson import poisson_disk

        pts = poisson_disk(state.rng(), (self.width, self.height), self.radius, origin=(self.x0, self.y0))
        state.add_domain(self.domain, PointSet(pts, bounds=(self.x0, self.x0 + self.width,
                                                             self.y0, self.y0 + self.height)))
        state.report(f"{self.domain}.n_points", int(len(pts)))
        return True
