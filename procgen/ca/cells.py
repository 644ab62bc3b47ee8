"""Cell domains: the one protocol every cellular-automaton rule is written against.

A *cell domain* is any domain with a ``cell`` location that can hand out a :class:`CellGraph`
of its cells: a :class:`~procgen.domains.Grid` (its 8- or 4-neighbour raster graph), the
surface cells of a mesh (their cross-edge graph, 3DSCA thesis 3.3), a cellular network (its
links).  A CA rule reads and writes cell fields as flat ``(n_cells, ...)`` arrays through
:func:`cell_values` / :func:`put_cell_values`, asks :func:`cell_graph` for neighbours, and so
runs unchanged on every such domain.  Cell id order is the domain's own (row-major on a Grid).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import InputError
from .graph import CellGraph

#: neighbourhoods a cell domain can hand out: all 8 Moore slots, or the 4 side slots only
NEIGHBOURHOODS = ("moore", "von_neumann")


def is_cell_domain(domain: Any) -> bool:
    """True if ``domain`` has cells and hands out a neighbour graph of them."""
    return "cell" in getattr(domain, "locations", ()) and callable(getattr(domain, "cell_graph", None))


def _check(domain: Any, where: str) -> None:
    if not is_cell_domain(domain):
        kind = getattr(domain, "kind", type(domain).__name__)
        raise InputError(f"{where}: a {kind} is not a cell domain (a cell automaton needs a Grid, "
                         "surface cells or a cell network)")


def cell_graph(domain: Any, neighbourhood: str = "moore", where: str = "cells") -> CellGraph:
    """The domain's neighbour graph of its cells (``moore`` or ``von_neumann``)."""
    _check(domain, where)
    if neighbourhood not in NEIGHBOURHOODS:
        raise InputError(f"{where}: neighbourhood {neighbourhood!r} is not one of {NEIGHBOURHOODS}")
    return domain.cell_graph(neighbourhood)


def n_cells(domain: Any) -> int:
    return int(np.prod(domain.location_shape("cell")))


def cell_values(domain: Any, name: str) -> np.ndarray:
    """Field ``name`` as a flat ``(n_cells, ...)`` array (a view where the layout allows)."""
    a = domain[name]
    return a.reshape((n_cells(domain),) + a.shape[len(domain.location_shape("cell")):])


def put_cell_values(domain: Any, name: str, values: np.ndarray, *, units: str = "",
                    doc: str = "") -> np.ndarray:
    """Write a flat ``(n_cells, ...)`` array as the cell field ``name`` in the domain's layout."""
    v = np.asarray(values)
    shaped = v.reshape(domain.location_shape("cell") + v.shape[1:])
    return domain.add_field(name, shaped, at="cell", units=units, doc=doc)
