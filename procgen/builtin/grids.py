"""grid.noise (fractal heightmaps) and grid.to_mesh (a Grid as a height-field TriMesh)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar, Mapping

import numpy as np

from ..domains import Grid, TriMesh
from ..fields import FieldSpec
from ..noise import fbm_spectral, midpoint_displacement
from ..params import param
from ..rules import RuleBase
from ..state import State


@dataclass(kw_only=True)
class FractalNoise(RuleBase):
    """A fractal (fBm) heightmap on a new Grid: spectral synthesis or midpoint displacement.

    ``periodic``: the heightmap tiles (spectral synthesis on the grid's own torus, so opposite
    edges meet like any two neighbouring cells) and the Grid is made periodic, so later rules
    wrap their neighbourhoods too.  Midpoint displacement and the dome do not tile: refused.
    """

    example: ClassVar[tuple[dict, ...]] = ({"rule": "grid.noise", "params": {"nx": 32, "ny": 24}},)
    name: ClassVar[str] = "grid.noise"
    creates: ClassVar[dict[str, str]] = {"{grid}": "Grid"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("surface__height", "{grid}", "cell", "out", units="length", doc="fractal height"),)

    grid: str = param("terrain", doc="name of the Grid to create")
    nx: int = param(256, ge=2, le=16384, units="cells", doc="cells across")
    ny: int = param(256, ge=2, le=16384, units="cells", doc="cells down")
    spacing: float = param(1.0, gt=0.0, units="length", doc="cell size")
    method: str = param("spectral", choices=("spectral", "midpoint"), doc="fBm synthesis method")
    hurst: float = param(0.8, gt=0.0, lt=1.0, doc="Hurst exponent: higher is smoother")
    amplitude: float = param(1.0, ge=0.0, units="length", doc="standard deviation of the height")
    offset: float = param(0.0, units="length", doc="mean height")
    dome: float = param(0.0, ge=0.0, units="length", doc="add a radial dome of this height (mountains)")
    periodic: bool = param(False, doc="a tileable (torus) grid: spectral fBm wrapped at the edges")

    def validate(self) -> None:
        if self.periodic and self.method != "spectral":
            raise ValueError("periodic = true needs method = 'spectral' (midpoint displacement does not tile)")
        if self.periodic and self.dome > 0:
            raise ValueError("periodic = true cannot have a dome (a dome does not tile)")

    def memory_estimate(self) -> int:
        return int(self.nx * self.ny * 8 * 24)

    def domain_sizes(self, sizes: Mapping[str, int]) -> dict[str, int]:
        return {self.grid: self.nx * self.ny}

    def step(self, state: State) -> bool:
        rng = state.rng()
        shape = (self.ny, self.nx)
        base = fbm_spectral(rng, shape, self.hurst, periodic=self.periodic) if self.method == "spectral" \
            else midpoint_displacement(rng, shape, self.hurst)
        h = self.offset + self.amplitude * base
        if self.dome > 0:
            yy, xx = np.meshgrid(np.linspace(-1, 1, self.ny), np.linspace(-1, 1, self.nx), indexing="ij")
            c = np.clip(1.0 - np.sqrt(xx ** 2 + yy ** 2), 0.0, None)
            h = h + self.dome * c * np.sqrt(c)       # c ** 1.5 (np.power's bits vary by CPU)
        g = Grid(shape, self.spacing, periodic=self.periodic)
        g.add_field("surface__height", h, at="cell", units="length", doc="fractal height")
        state.add_domain(self.grid, g)
        return True


def grid_faces(ny: int, nx: int) -> np.ndarray:
    """Two counter-clockwise triangles per grid square, vertices numbered row-major."""
    idx = np.arange(ny * nx).reshape(ny, nx)
    a, b = idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel()
    c, d = idx[1:, :-1].ravel(), idx[1:, 1:].ravel()
    return np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)])


@dataclass(kw_only=True)
class GridToMesh(RuleBase):
    """Converter: a Grid's height field as a 3-D TriMesh (one vertex per cell centre).

    Every cell field is carried over as a vertex field, so colours computed on the grid
    become vertex colours and a later surface rule can read the grid's quantities.
    """

    example: ClassVar[tuple[dict, ...]] = ({"rule": "grid.noise", "params": {"nx": 24, "ny": 16}}, {"rule": "grid.to_mesh"})
    name: ClassVar[str] = "grid.to_mesh"
    uses: ClassVar[dict[str, str]] = {"{grid}": "Grid"}
    creates: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    passes_fields: ClassVar[dict[str, str]] = {"{mesh}": "{grid}"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("{height_field}", "{grid}", "cell", "in", units="length", doc="height to lift"),)

    grid: str = param("terrain", doc="Grid to convert")
    mesh: str = param("terrain_mesh", doc="name of the TriMesh to create")
    height_field: str = param("surface__height", doc="cell field used as z")
    z_scale: float = param(1.0, gt=0.0, doc="vertical exaggeration")

    def step(self, state: State) -> bool:
        g = state.get(self.grid, Grid)
        z = np.asarray(g[self.height_field], dtype=np.float64)
        if z.ndim == 3:
            z = z[:, :, -1]
        xx, yy = np.meshgrid(g.x, g.y)
        verts = np.column_stack([xx.ravel(), yy.ravel(), self.z_scale * z.ravel()])
        mesh = TriMesh(verts, grid_faces(*g.shape))
        for name, arr, info in g.fields():
            if info.at == "cell":
                mesh.add_field(name, arr.reshape((g.n_cells,) + arr.shape[2:]), at="vertex",
                               units=info.units, doc=info.doc)
        state.add_domain(self.mesh, mesh)
        return True
