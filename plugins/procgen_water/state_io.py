"""Glue between procgen State/Grid fields and the numpy model objects (no copies on the hot path).

The layer stack (``layers__thickness`` and the ``material__*`` table) is the layered-materials
family's (:mod:`procgen_layers.stack`); this module adds the water maps beside it.
"""
from __future__ import annotations

from typing import Iterable

import numpy as np

from procgen import FieldSpec, Grid, PointSet, State, arena
from procgen_layers.materials import MaterialTable
from procgen_layers.stack import THICKNESS, load_table

from .particles import Drops, Surface, material_arrays

CELL_MAPS = {
    "water__emitted": ("volume", "cumulative water emitted as drops in this cell"),
    "water__evaporated": ("volume", "cumulative water evaporated from this cell"),
    "water__drained": ("volume", "water of drops that left the grid from this cell"),
    "sediment__drained": ("volume", "sediment carried off the grid from this cell"),
    "layers__source": ("volume", "solid made (+) or destroyed (-) in place, cumulative"),
    "water__path": ("visits", "moving-drop visits (the water-path trace)"),
    "sediment__baseline": ("volume", "solid volume per cell when the surface was built"),
}
LAYER_MAPS = {
    "water__held": ("volume", "water held (absorbed) in each layer"),
    "sediment__deposit": ("length", "thickness of each layer laid down by drops"),
}
DROP_FIELDS = {
    "drop__velocity": ("length/step", "horizontal velocity"),
    "drop__volume": ("volume", "water in the drop"),
    "drop__sediment": ("volume", "sediment carried"),
    "drop__kind": ("", "layer index of the sediment (-1 none)"),
    "drop__moving": ("", "false once stabilised"),
    "drop__age": ("steps", "steps moved"),
}


def map_specs(domain: str, intent: str, names: Iterable[str] | None = None) -> tuple[FieldSpec, ...]:
    """FieldSpecs of the water maps (all, or ``names``) on ``domain``: one declaration of each."""
    maps = {**CELL_MAPS, **LAYER_MAPS}
    return tuple(FieldSpec(n, domain, "cell", intent, units=maps[n][0], doc=maps[n][1])
                 for n in (names or maps))


def drop_specs(domain: str) -> tuple[FieldSpec, ...]:
    return tuple(FieldSpec(n, domain, "point", "out", units=u, doc=d) for n, (u, d) in DROP_FIELDS.items())


def _contig(g: Grid, name: str) -> np.ndarray:
    """The field as a writeable C-contiguous float64 array (replacing it if needed)."""
    arr = g[name]
    if arr.dtype != np.float64 or not arr.flags.c_contiguous or not arr.flags.writeable:
        info = g.field_info(name)
        arr = g.add_field(name, np.array(arr, dtype=np.float64, order="C"), at="cell",
                          units=info.units, doc=info.doc)
    return arr


def ensure_water_fields(g: Grid, L: int) -> None:
    """The water maps the grid lacks, at zero; the drops write them sparsely, so they share one
    allocation (:mod:`procgen.arena`: huge pages)."""
    maps = {**CELL_MAPS, **LAYER_MAPS}
    new = [name for name in maps if name not in g]
    shapes = [(g.shape + ((L,) if name in LAYER_MAPS else ()), np.float64) for name in new]
    for name, arr in zip(new, arena.zeros(shapes)):
        g.add_field(name, arr, at="cell", units=maps[name][0], doc=maps[name][1])


def surface_view(state: State, grid: str) -> tuple[Grid, Surface, MaterialTable]:
    """A Surface whose arrays are views of the grid's fields (edits write through)."""
    g = state.get(grid, Grid)
    table = load_table(g, grid)
    ensure_water_fields(g, len(table))
    ncell, L = g.n_cells, len(table)
    v = lambda name: _contig(g, name).reshape(ncell)                           # noqa: E731
    vl = lambda name: _contig(g, name).reshape(ncell, L)                       # noqa: E731
    s = Surface(shape=g.shape, spacing=g.spacing, base=v("surface__base"),
                thickness=vl(THICKNESS), held=vl("water__held"),
                deposit=vl("sediment__deposit"), emitted=v("water__emitted"),
                evaporated=v("water__evaporated"), drained=v("water__drained"),
                drained_sediment=v("sediment__drained"), source=v("layers__source"),
                path=v("water__path"), periodic=g.periodic, **material_arrays(table))
    return g, s, table


def update_derived(g: Grid, s: Surface, table: MaterialTable) -> None:
    """Refresh total height, per-layer top surfaces and exposed-layer saturation.

    In place where it can: at 512 x 512 a grid-sized temporary is often fresh memory, whose page
    faults cost about as much as the arithmetic.  After 100 compiled steps (which leave the
    allocator no large freed blocks to reuse) this took 37-45 ms, after numpy steps 16-18 ms;
    with half the temporaries, 11-13 ms once the allocator has blocks to reuse."""
    n, L = s.ncell, s.n_layers
    tops = np.cumsum(s.thickness.reshape(g.shape + (L,)), axis=-1)
    tops += s.base.reshape(g.shape)[..., None]
    g.add_field("layers__top", tops, at="cell", units="length",
                doc="top surface of each layer (base + cumulative thickness)")
    g.add_field("surface__height", tops[..., -1].copy(), at="cell", units="length",
                doc="top surface height")
    top = s.top_layer()
    at = np.maximum(top, 0)
    cap = table.array("capacity")[at]
    at += np.arange(0, n * L, L)                      # the exposed (cell, layer) entries
    cap *= s.thickness.reshape(-1)[at]
    cap *= s.cell_area
    sat = np.zeros(n)
    np.divide(s.held.reshape(-1)[at], cap, out=sat, where=(cap > 0) & (top >= 0))
    np.clip(sat, 0, 1, out=sat)
    g.add_field("water__saturation", sat.reshape(g.shape), at="cell", units="1",
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
    values = {"drop__velocity": d.vel.reshape(-1, 2), "drop__volume": d.volume, "drop__sediment": d.sediment,
              "drop__kind": d.kind, "drop__moving": d.moving, "drop__age": d.age}
    for field, (units, doc) in DROP_FIELDS.items():
        ps.add_field(field, values[field], at="point", units=units, doc=doc)
    state.add_domain(name, ps)
