"""Polylines: ragged lines as one flat point array plus offsets (shapely 2's layout)."""
from __future__ import annotations

from typing import Any, ClassVar, Sequence

import numpy as np

from ..errors import InputError
from .base import Domain, frozen


class Polylines(Domain):
    """``k`` lines; line i is ``points[offsets[i]:offsets[i+1]]``; ``closed[i]`` marks rings.

    Fields live on ``point`` (every vertex of every line) or ``line``.
    """

    kind: ClassVar[str] = "Polylines"
    locations: ClassVar[tuple[str, ...]] = ("point", "line")

    def __init__(self, points: Any, offsets: Any, closed: Any = None,
                 bounds: tuple[float, float, float, float] | None = None) -> None:
        super().__init__()
        pts = np.asarray(points, dtype=np.float64).reshape(-1, np.shape(points)[-1] if np.ndim(points) == 2 else 2)
        off = np.asarray(offsets, dtype=np.int64)
        if pts.shape[1] not in (2, 3):
            raise InputError(f"Polylines: points must be (N, 2) or (N, 3), got {pts.shape}")
        if not np.all(np.isfinite(pts)):
            raise InputError("Polylines: points contain NaN or inf")
        if off.ndim != 1 or len(off) < 1 or off[0] != 0 or off[-1] != len(pts) or np.any(np.diff(off) < 0):
            raise InputError("Polylines: offsets must rise from 0 to len(points)")
        k = len(off) - 1
        cl = np.zeros(k, bool) if closed is None else np.broadcast_to(np.asarray(closed, bool), (k,))
        self.points = frozen(pts)
        self.offsets = frozen(off)
        self.closed = frozen(cl)
        self.bounds = tuple(float(b) for b in bounds) if bounds is not None else None

    @classmethod
    def from_list(cls, lines: Sequence[Any], closed: Any = False,
                  bounds: tuple[float, float, float, float] | None = None) -> "Polylines":
        arrs = [np.asarray(line, dtype=np.float64) for line in lines]
        dim = arrs[0].shape[1] if arrs else 2
        pts = np.concatenate(arrs) if arrs else np.zeros((0, dim))
        off = np.concatenate([[0], np.cumsum([len(a) for a in arrs])]).astype(np.int64)
        return cls(pts, off, closed, bounds)

    def location_shape(self, at: str) -> tuple[int, ...]:
        return (len(self.points),) if at == "point" else (self.n_lines,)

    @property
    def n_lines(self) -> int:
        return len(self.offsets) - 1

    def line(self, i: int) -> np.ndarray:
        return self.points[self.offsets[i]:self.offsets[i + 1]]

    def lines(self) -> list[np.ndarray]:
        return [self.line(i) for i in range(self.n_lines)]

    def lengths(self) -> np.ndarray:
        """Arc length of each line (closing segment included for rings)."""
        seg = np.linalg.norm(np.diff(self.points, axis=0), axis=1)
        line_of = np.repeat(np.arange(self.n_lines), np.diff(self.offsets))
        same = line_of[:-1] == line_of[1:] if len(line_of) > 1 else np.zeros(0, bool)
        total = np.bincount(line_of[:-1][same], weights=seg[same], minlength=self.n_lines)
        for i in np.flatnonzero(self.closed):
            a, b = self.offsets[i], self.offsets[i + 1]
            if b - a > 1:
                total[i] += np.linalg.norm(self.points[b - 1] - self.points[a])
        return total

    def topology_arrays(self) -> dict[str, np.ndarray]:
        return {"points": self.points, "offsets": self.offsets, "closed": self.closed}

    def topology_meta(self) -> dict[str, Any]:
        return {"bounds": list(self.bounds) if self.bounds is not None else None}

    @classmethod
    def from_topology(cls, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> "Polylines":
        b = meta.get("bounds")
        return cls(arrays["points"], arrays["offsets"], arrays["closed"], tuple(b) if b else None)
