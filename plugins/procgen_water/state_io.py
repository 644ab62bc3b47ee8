"""Glue between procgen State/Grid fields and the numpy model objects (no copies on the hot path).

The material table lives in a small PointSet domain ``<grid>_materials`` (one point per layer,
one ``material__<property>`` field per property), so it is saved, loaded and inspected like
every other piece of state and needs no core support.
"""
from __future__ import annotations

import numpy as np

from procgen import Grid, InputError, PointSet, State
from procgen.materials import MaterialTable

from .particles import Drops, Surface, material_arrays

CELL_MAPS = {
    "water__emitted": ("volume", "cumulative water emitted as drops in this cell"),
    "water__evaporated": ("volume", "cumulative water evaporated from this cell"),
    "water__drained": ("volume", "water of drops that left the grid from this cell"),
    "sediment__drained": ("volume", "sediment carried off the grid from this cell"),
    "surface__solid_source": ("volume", "solid made (+) or destroyed (-) by non-water rules"),
    "water__path": ("visits", "moving-drop visits (the water-path trace)"),
    "sediment__baseline": ("volume", "solid volume per cell when the surface was built"),
}
LAYER_MAPS = {
    "water__held": ("volume", "water held (absorbed) in each layer"),
    "sediment__deposit": ("length", "thickness of each layer laid down by drops"),
}


def materials_domain(grid: str) -> str:
    return f"{grid}_materials"


def store_table(state: State, grid: str, table: MaterialTable) -> None:
    pts = np.column_stack([np.arange(len(table), dtype=float), np.zeros(len(table))])
    ps = PointSet(pts)
    for key, arr in table.to_arrays().items():
        ps.add_field(f"material__{key}", arr, at="point", doc=f"layer material {key}")
    state.add_domain(materials_domain(grid), ps)


def load_table(state: State, grid: str) -> MaterialTable:
    g = state.get(grid, Grid)
    name = materials_domain(grid)
    if name not in state:
        raise InputError(f"grid {grid!r} has no material table (domain {name!r}); build it with "
                         "water.surface")
    ps = state.get(name, PointSet)
    arrays = {f.split("__", 1)[1]: ps[f] for f in ps.field_names()}
    return MaterialTable.from_arrays(g.layers, arrays)


def _contig(g: Grid, name: str) -> np.ndarray:
    """The field as a writeable C-contiguous float64 array (replacing it if needed)."""
    arr = g[name]
    if arr.dtype != np.float64 or not arr.flags.c_contiguous or not arr.flags.writeable:
        info = g.field_info(name)
        arr = g.add_field(name, np.array(arr, dtype=np.float64, order="C"), at="cell",
                          units=info.units, doc=info.doc)
    return arr


def ensure_water_fields(g: Grid) -> None:
    L = len(g.layers)
    for name, (units, doc) in CELL_MAPS.items():
        if name not in g:
            g.add_field(name, np.zeros(g.shape), at="cell", units=units, doc=doc)
    for name, (units, doc) in LAYER_MAPS.items():
        if name not in g:
            g.add_field(name, np.zeros(g.shape + (L,)), at="cell", units=units, doc=doc)


def surface_view(state: State, grid: str) -> tuple[Grid, Surface, MaterialTable]:
    """A Surface whose arrays are views of the grid's fields (edits write through)."""
    g = state.get(grid, Grid)
    table = load_table(state, grid)
    ensure_water_fields(g)
    ncell, L = g.n_cells, len(g.layers)
    v = lambda name: _contig(g, name).reshape(ncell)                           # noqa: E731
    vl = lambda name: _contig(g, name).reshape(ncell, L)                       # noqa: E731
    s = Surface(shape=g.shape, spacing=g.spacing, base=v("surface__base"),
                thickness=vl("surface__thickness"), held=vl("water__held"),
                deposit=vl("sediment__deposit"), emitted=v("water__emitted"),
                evaporated=v("water__evaporated"), drained=v("water__drained"),
                drained_sediment=v("sediment__drained"), source=v("surface__solid_source"),
                path=v("water__path"), **material_arrays(table))
    return g, s, table


def update_derived(g: Grid, s: Surface, table: MaterialTable) -> None:
    """Refresh total height, per-layer top surfaces and exposed-layer saturation."""
    t = s.thickness.reshape(g.shape + (s.n_layers,))
    tops = s.base.reshape(g.shape)[..., None] + np.cumsum(t, axis=-1)
    g.add_field("surface__layer_top", tops, at="cell", units="length",
                doc="top surface of each layer (base + cumulative thickness)")
    g.add_field("surface__height", tops[..., -1].copy(), at="cell", units="length",
                doc="top surface height")
    top = s.top_layer().reshape(g.shape)
    tk = np.maximum(top, 0)
    cap = table.array("capacity")[tk] * np.take_along_axis(t, tk[..., None], -1)[..., 0] * s.cell_area
    held = np.take_along_axis(s.held.reshape(t.shape), tk[..., None], -1)[..., 0]
    with np.errstate(invalid="ignore", divide="ignore"):
        sat = np.where((cap > 0) & (top >= 0), held / np.where(cap > 0, cap, 1.0), 0.0)
    g.add_field("water__saturation", np.clip(sat, 0, 1), at="cell", units="1",
                doc="held water / capacity of the exposed layer")


def drops_from_domain(state: State, name: str, g: Grid) -> Drops:
    if name not in state:
        return Drops.empty()
    ps = state.get(name, PointSet)
    pos = (ps.points[:, :2] - np.asarray(g.origin)) / g.spacing
    return Drops(pos.copy(), np.array(ps["drop__velocity"], float).reshape(-1, 2),
                 np.array(ps["drop__volume"], float), np.array(ps["drop__sediment"], float),
                 np.array(ps["drop__kind"], np.int64), np.array(ps["drop__moving"], bool),
                 np.array(ps["drop__age"], np.int64))


def drops_to_domain(state: State, name: str, g: Grid, d: Drops) -> None:
    pts = np.asarray(g.origin) + d.pos * g.spacing
    ps = PointSet(pts.reshape(-1, 2), bounds=g.extent)
    ps.add_field("drop__velocity", d.vel.reshape(-1, 2), at="point", units="length/step",
                 doc="horizontal velocity")
    ps.add_field("drop__volume", d.volume, at="point", units="volume", doc="water in the drop")
    ps.add_field("drop__sediment", d.sediment, at="point", units="volume", doc="sediment carried")
    ps.add_field("drop__kind", d.kind, at="point", doc="layer index of the sediment (-1 none)")
    ps.add_field("drop__moving", d.moving, at="point", doc="false once stabilised")
    ps.add_field("drop__age", d.age, at="point", units="steps", doc="steps moved")
    state.add_domain(name, ps)
