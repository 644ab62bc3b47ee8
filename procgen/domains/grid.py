"""Grid: a regular raster of cells (2.5D surfaces, heightmaps, colour maps)."""
from __future__ import annotations

from functools import cached_property
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from ..errors import InputError
from .base import Domain

if TYPE_CHECKING:
    from ..ca.graph import CellGraph


class Grid(Domain):
    """A (ny, nx) raster of square cells of side ``spacing``; cell fields are (ny, nx, ...) arrays.

    Fields keep the raster shape (not flattened) because every raster tool, image writer and
    numpy stencil expects it. Several layers are trailing dims of a field, named by ``layers``.
    ``periodic``: the raster is a torus (the last column touches the first, the last row the
    first), so what is made on it tiles; its cell graph wraps.  Rules that look at neighbours
    read it from here (one flag for both axes: a texture tiles in both directions or not at all).
    """

    kind: ClassVar[str] = "Grid"
    locations: ClassVar[tuple[str, ...]] = ("cell",)

    def __init__(self, shape: tuple[int, int], spacing: float = 1.0,
                 origin: tuple[float, float] = (0.0, 0.0), layers: tuple[str, ...] = (),
                 periodic: bool = False) -> None:
        super().__init__()
        try:
            ny, nx = (int(v) for v in shape)
        except (TypeError, ValueError):
            raise InputError(f"Grid: shape must be (ny, nx), got {shape!r}") from None
        if ny < 1 or nx < 1:
            raise InputError(f"Grid: shape must be positive, got {(ny, nx)}")
        if not (np.isfinite(spacing) and spacing > 0):
            raise InputError(f"Grid: spacing must be a positive number, got {spacing!r}")
        self.shape = (ny, nx)
        self.spacing = float(spacing)
        self.origin = (float(origin[0]), float(origin[1]))
        self.layers = tuple(str(n) for n in layers)
        self.periodic = bool(periodic)
        self._graphs: dict[str, CellGraph] = {}

    def location_shape(self, at: str) -> tuple[int, ...]:
        return self.shape

    @property
    def n_cells(self) -> int:
        return self.shape[0] * self.shape[1]

    @cached_property
    def x(self) -> np.ndarray:
        """Cell-centre x coordinates (nx,)."""
        return self.origin[0] + (np.arange(self.shape[1]) + 0.5) * self.spacing

    @cached_property
    def y(self) -> np.ndarray:
        """Cell-centre y coordinates (ny,)."""
        return self.origin[1] + (np.arange(self.shape[0]) + 0.5) * self.spacing

    def cell_graph(self, neighbourhood: str = "moore") -> "CellGraph":
        """The raster's cell graph (cell id = row * nx + column), 8 or 4 neighbours; on a
        periodic grid the neighbours wrap across the edges (every cell has all of them)."""
        from ..ca.graph import grid_graph
        if neighbourhood not in self._graphs:
            self._graphs[neighbourhood] = grid_graph(*self.shape, wrap=self.periodic).neighbourhood(neighbourhood)
        return self._graphs[neighbourhood]

    @property
    def extent(self) -> tuple[float, float, float, float]:
        """(xmin, xmax, ymin, ymax) of the raster's outer boundary."""
        return (self.origin[0], self.origin[0] + self.shape[1] * self.spacing,
                self.origin[1], self.origin[1] + self.shape[0] * self.spacing)

    def topology_arrays(self) -> dict[str, np.ndarray]:
        return {}

    def topology_meta(self) -> dict[str, Any]:
        meta = {"shape": list(self.shape), "spacing": self.spacing, "origin": list(self.origin),
                "layers": list(self.layers)}
        if self.periodic:                 # only when set: saved non-periodic grids stay as they were
            meta["periodic"] = True
        return meta

    @classmethod
    def from_topology(cls, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> "Grid":
        return cls(tuple(meta["shape"]), meta["spacing"], tuple(meta["origin"]), tuple(meta.get("layers", ())),
                   periodic=bool(meta.get("periodic", False)))
