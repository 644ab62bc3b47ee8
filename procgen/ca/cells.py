"""Cell domains: the one protocol every cellular-automaton rule is written against.

A *cell domain* is any domain with a ``cell`` location that can hand out a :class:`CellGraph`
of its cells: a :class:`~procgen.domains.Grid` (its 8- or 4-neighbour raster graph), the
surface cells of a mesh (their cross-edge graph, 3DSCA thesis 3.3), a cellular network (its
links).  A CA rule reads and writes cell fields as flat ``(n_cells, ...)`` arrays through
:func:`cell_values` / :func:`put_cell_values`, asks :func:`cell_graph` for neighbours, and so
runs unchanged on every such domain.  Cell id order is the domain's own (row-major on a Grid).

A rule declares ``uses = {"{cells}": CELL_DOMAIN}`` to accept any cell domain: the recipe check
then refuses a PointSet or TriMesh in one line, and ``procgen rules show`` lists the kinds.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ..errors import InputError
from .graph import CellGraph

#: neighbourhoods a cell domain can hand out: all 8 Moore slots, or the 4 side slots only
NEIGHBOURHOODS = ("moore", "von_neumann")

#: the kind a rule names in ``uses`` to accept any cell domain (not a class: a protocol)
CELL_DOMAIN = "CellDomain"

#: optional bool cell field: False where a cell no longer exists (a hole); CA rules skip those
PRESENT_FIELD = "cell__alive"


def is_cell_domain(domain: Any) -> bool:
    """True if ``domain`` (an instance or a domain class) has cells and hands out their graph."""
    return "cell" in getattr(domain, "locations", ()) and callable(getattr(domain, "cell_graph", None))


def cell_domain_kinds() -> list[str]:
    """Registered domain kinds that are cell domains (for ``procgen rules show`` and errors)."""
    from ..domains import DOMAIN_KINDS
    return sorted(k for k, c in DOMAIN_KINDS.items() if is_cell_domain(c))


def kind_accepts(domain_cls: type, wanted: str) -> bool:
    """Does a domain of class ``domain_cls`` satisfy a ``uses`` kind (a kind or CELL_DOMAIN)?"""
    from ..domains import is_kind
    return is_cell_domain(domain_cls) if wanted == CELL_DOMAIN else is_kind(domain_cls, wanted)


def kind_text(wanted: str, noun: str = "") -> str:
    """How a ``uses`` kind reads in messages: 'Grid' + noun, or 'cell domain (Grid, SurfaceCells)'."""
    return f"cell domain ({', '.join(cell_domain_kinds())})" if wanted == CELL_DOMAIN else wanted + noun


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


def present_cells(domain: Any) -> np.ndarray:
    """(n,) bool: cells that exist (``cell__alive`` where a rule cut holes, else all)."""
    if PRESENT_FIELD in domain:
        return np.asarray(cell_values(domain, PRESENT_FIELD), bool)
    return np.ones(n_cells(domain), bool)


def cell_centres(domain: Any) -> np.ndarray:
    """(n, d) cell centres in the domain's own coordinates, in cell id order.

    A Grid gives (x, y); another cell domain provides ``cell_centres()`` (surface cells: 3-D).
    """
    from ..domains import Grid
    if isinstance(domain, Grid):
        yy, xx = np.meshgrid(domain.y, domain.x, indexing="ij")
        return np.column_stack([xx.ravel(), yy.ravel()])
    fn = getattr(domain, "cell_centres", None)
    if not callable(fn):
        raise InputError(f"a {getattr(domain, 'kind', type(domain).__name__)} has no cell centres")
    return np.asarray(fn(), dtype=float)


def cell_size(domain: Any) -> float:
    """Side of one cell (a Grid's spacing, the surface cells' size)."""
    size = getattr(domain, "spacing", None) or getattr(domain, "size", None)
    if not size:
        raise InputError(f"a {getattr(domain, 'kind', type(domain).__name__)} has no cell size")
    return float(size)


def cell_distances(domain: Any, cell: int) -> np.ndarray:
    """(n,) distance from cell ``cell``'s centre to every cell centre, over the surface.

    A domain that lies on a folded surface provides ``surface_distances(cell)`` (the surface
    cells unfold the triangles; NaN where it does not measure); otherwise the straight-line
    distance between centres, exact on a flat raster.
    """
    fn = getattr(domain, "surface_distances", None)
    if callable(fn):
        return np.asarray(fn(int(cell)), dtype=float)
    c = cell_centres(domain)
    return np.linalg.norm(c - c[int(cell)], axis=1)


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
