"""The layer stack of a cell domain: thickness per cell and layer, plus the material table.

One representation on every cell domain (a Grid, the surface cells of a mesh, ...), so that
corrosion, shading, water and cracks read and write the same fields:

* ``layers__thickness`` on ``cell``: (cells..., L) thickness of each layer, bottom first;
* ``material__<property>`` on ``domain``: the material table, one entry per layer, bottom
  first (``material__name`` holds the layer names).  Stored as fields, the table is saved,
  loaded and carried like every other piece of state and needs no core support.

Generating a stack on cells (thesis 2.1 / App. A): each layer has a nominal thickness, a
thickness noise ("classical fractal functions") and a smoothness.  On a mesh the noise must
agree across triangle edges, so it is a 3-D fractal value noise sampled at the cell centres
(seamless by construction), and the smoothing is Jacobi averaging over the cell graph (the
cell-graph analogue of a Gaussian blur).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from procgen.ca.cells import cell_values, n_cells
from procgen.ca.graph import CellGraph
from procgen.domains import Grid
from procgen.errors import InputError
from procgen.fields import FieldSpec
from procgen.noise import value_noise_3d

from .materials import MATERIAL_KEYS, MaterialTable

THICKNESS = "layers__thickness"
NAME_FIELD = "material__name"


def table_field_specs(domain: str) -> tuple[FieldSpec, ...]:
    """The ``material__*`` fields a stack builder writes (one per material property)."""
    return tuple(FieldSpec(f"material__{k}", domain, "domain", "out",
                           doc="layer names, bottom first" if k == "name" else f"layer material {k}")
                 for k in MATERIAL_KEYS)


def store_table(domain: Any, table: MaterialTable) -> None:
    """Write the material table as ``material__*`` domain fields (replacing any earlier one)."""
    for name in [n for n in domain.field_names("domain") if n.startswith("material__")]:
        domain.remove_field(name)
    domain.add_field(NAME_FIELD, np.array(table.names, dtype=str), at="domain",
                     doc="layer names, bottom first")
    for key, arr in table.to_arrays().items():
        domain.add_field(f"material__{key}", arr, at="domain", doc=f"layer material {key}")


def has_stack(domain: Any) -> bool:
    return NAME_FIELD in domain and THICKNESS in domain


def load_table(domain: Any, where: str = "layers") -> MaterialTable:
    """The material table stored on ``domain``; InputError if no stack was built on it."""
    if not has_stack(domain):
        raise InputError(f"{where}: the {domain.kind} has no layer stack (build one first with "
                         "layers.stack or water.surface)")
    arrays = {k: domain[f"material__{k}"] for k in MATERIAL_KEYS
              if k != "name" and f"material__{k}" in domain}
    return MaterialTable.from_arrays([str(n) for n in domain[NAME_FIELD]], arrays)


def put_thickness(domain: Any, thickness: np.ndarray, table: MaterialTable) -> np.ndarray:
    """Set ``layers__thickness`` from a flat (n_cells, L) array (the caller re-bakes the stack's
    look with procgen_layers.bake.bake_stack when it declares the baked fields)."""
    from procgen.ca.cells import put_cell_values

    return put_cell_values(domain, THICKNESS, thickness, units="length",
                           doc="thickness per layer, bottom first: " + ", ".join(table.names))


def thickness(domain: Any) -> np.ndarray:
    """``layers__thickness`` as a flat (n_cells, L) view."""
    return cell_values(domain, THICKNESS)


def cell_centres(domain: Any) -> np.ndarray:
    """(n_cells, 3) cell centres: a Grid's raster (z = 0) or the domain's ``center3d``."""
    if isinstance(domain, Grid):
        xx, yy = np.meshgrid(domain.x, domain.y)
        return np.column_stack([xx.ravel(), yy.ravel(), np.zeros(domain.n_cells)])
    c = getattr(domain, "center3d", None)
    if c is None or len(c) != n_cells(domain):
        raise InputError(f"a {domain.kind} does not give cell centres (a Grid or surface cells do)")
    return np.asarray(c, dtype=float)


def smooth_on_graph(values: np.ndarray, graph: CellGraph, iterations: int) -> np.ndarray:
    """Jacobi smoothing: x <- (x + mean of neighbours) / 2, ``iterations`` times."""
    x = np.asarray(values, dtype=float).copy()
    for _ in range(int(iterations)):                 # iterations of a sparse product, not cells
        x = 0.5 * (x + graph.mean(x))
    return x


def noisy_layer(points: np.ndarray, graph: CellGraph, rng: np.random.Generator, *, nominal: float,
                noise: float, smoothing: int, scale: float, hurst: float = 0.7) -> np.ndarray:
    """(n,) thickness of one layer: nominal * (1 + noise * smoothed fBm), clipped at 0.

    ``noise`` is relative to ``nominal``; the fBm is 3-D value noise at ``points``.
    """
    t = np.full(len(points), float(nominal))
    if noise > 0:
        nz = value_noise_3d(points, rng, scale=scale, hurst=hurst)
        t = t * (1.0 + noise * smooth_on_graph(nz, graph, smoothing))
    return np.clip(t, 0.0, None)


def stacked_heights(thickness: np.ndarray) -> np.ndarray:
    """Top surface of each layer above the base surface: cumulative sums (non-decreasing)."""
    return np.cumsum(np.clip(thickness, 0.0, None), axis=-1)


def cell_areas(domain: Any) -> np.ndarray:
    """(n_cells,) area of each cell (a Grid's spacing squared, the surface cells' clipped areas)."""
    if isinstance(domain, Grid):
        return np.full(domain.n_cells, domain.spacing ** 2)
    area = getattr(domain, "area", None)
    if area is None or len(area) != n_cells(domain):
        raise InputError(f"a {domain.kind} does not give cell areas (a Grid or surface cells do)")
    return np.asarray(area, dtype=float)
