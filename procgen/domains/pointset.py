"""PointSet: scattered points (samples, particles, free cells)."""
from __future__ import annotations

from typing import Any, ClassVar

import numpy as np

from ..errors import InputError
from .base import Domain, frozen


class PointSet(Domain):
    """``n`` points in 2-D or 3-D; fields live on ``point``."""

    kind: ClassVar[str] = "PointSet"
    locations: ClassVar[tuple[str, ...]] = ("point",)

    def __init__(self, points: Any, bounds: tuple[float, ...] | None = None) -> None:
        super().__init__()
        pts = np.asarray(points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] not in (2, 3):
            raise InputError(f"PointSet: points must be (n, 2) or (n, 3), got shape {pts.shape}")
        if not np.all(np.isfinite(pts)):
            raise InputError("PointSet: points contain NaN or inf")
        self.points = frozen(pts)
        self.bounds = tuple(float(b) for b in bounds) if bounds is not None else None

    def location_shape(self, at: str) -> tuple[int, ...]:
        return (len(self.points),)

    @property
    def n_points(self) -> int:
        return len(self.points)

    def topology_arrays(self) -> dict[str, np.ndarray]:
        return {"points": self.points}

    def topology_meta(self) -> dict[str, Any]:
        return {"bounds": list(self.bounds) if self.bounds is not None else None}

    @classmethod
    def from_topology(cls, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> "PointSet":
        b = meta.get("bounds")
        return cls(arrays["points"], tuple(b) if b is not None else None)
