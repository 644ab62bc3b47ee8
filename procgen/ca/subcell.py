"""Sub-cell positions and per-direction cell fields, shared by every lattice cell family.

A square-lattice cell domain (a Grid, the per-triangle grids of mesh surface cells) stores a
value per cell, but processes that move *between* cell centres (a crack head, a particle) need
the value at any point: :func:`bilinear_stencil` gives the four surrounding lattice cells and
their weights (3DSCA thesis 5.2.3.b, Figure 5.9), exact at a cell centre.

A *direction field* holds one value per lattice axis 0, pi/4, pi/2, 3pi/4 (the thesis's "stress
spectrum", 5.2.3.a, Figure 5.6: central symmetry halves the 8 Moore directions to 4 axes).  The
helpers below map those axes to the Moore slots of :data:`procgen.ca.graph.MOORE`, combine them
into one dominant axis (angles doubled, so that opposite directions add up) and weight them by
how far each axis is across a given heading.
"""
from __future__ import annotations

import numpy as np

from .graph import CellGraph

#: the 4 lattice axes of a direction field, radians (the stress spectrum's 0, pi/4, pi/2, 3pi/4)
AXIS_ANGLES = np.arange(4) * (np.pi / 4)
#: Moore slot of the forward (+) and backward (-) neighbour along each axis
AXIS_PLUS_SLOT = np.array([4, 7, 6, 5])
AXIS_MINUS_SLOT = np.array([3, 0, 1, 2])
#: length of each axis's lattice step in cells (1 or sqrt 2)
AXIS_STEP = np.array([1.0, np.sqrt(2.0), 1.0, np.sqrt(2.0)])

#: the four cells around a point, as (di, dj) offsets from the lower-left one
STENCIL = np.array([(0, 0), (1, 0), (0, 1), (1, 1)], np.int64)


def slot_table(graph: CellGraph) -> np.ndarray:
    """(n, 8) neighbour cell per Moore slot (-1 where the slot is empty)."""
    if graph.direction is None:
        raise ValueError("slot_table needs a lattice graph (Moore direction codes)")
    slots = np.full((graph.n_cells, 8), -1, np.int64)
    slots[graph.rows, graph.direction.astype(np.int64)] = graph.indices
    return slots


def bilinear_stencil(xy: np.ndarray, size: float) -> tuple[np.ndarray, np.ndarray]:
    """Lower-left lattice index (m, 2) and the 4 weights (m, 4) of points ``xy`` (m, 2).

    Cell (i, j) covers [i*size, (i+1)*size) x [j*size, (j+1)*size); the four cells are
    ``ij0 + STENCIL[q]``.  At a cell centre the whole weight is on that cell.
    """
    u = np.asarray(xy, float) / size - 0.5
    ij0 = np.floor(u).astype(np.int64)
    f = u - ij0
    fx, fy = f[:, 0], f[:, 1]
    w = np.column_stack([(1 - fx) * (1 - fy), fx * (1 - fy), (1 - fx) * fy, fx * fy])
    return ij0, w


def interpolate(values: np.ndarray, cells: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Weighted mean of ``values[cells]`` over the stencil (cells (m, 4), -1 = missing).

    Missing cells drop out and the remaining weights are renormalised; a point with no cell at
    all gets zeros.
    """
    ok = cells >= 0
    w = np.where(ok, weights, 0.0)
    tot = w.sum(axis=1, keepdims=True)
    w = w / np.where(tot > 0, tot, 1.0)
    v = values[np.where(ok, cells, 0)]                       # (m, 4, ...)
    return np.einsum("mq,mq...->m...", w, v)


def dominant_axis(field: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Axis angle in [0, pi) and strength of the resultant of a direction field (m, 4).

    Each axis value is a vector at twice its angle (so theta and theta + pi coincide); the
    angle of the sum, halved, is the dominant axis.  Strength 0: the axes cancel (isotropic).
    """
    c = field @ np.cos(2 * AXIS_ANGLES)
    s = field @ np.sin(2 * AXIS_ANGLES)
    return np.mod(0.5 * np.arctan2(s, c), np.pi), np.hypot(c, s)


def across_share(heading: np.ndarray) -> np.ndarray:
    """(m, 4) |sin(axis - heading)|: how much of each axis lies across a heading angle (m,)."""
    return np.abs(np.sin(AXIS_ANGLES[None, :] - np.asarray(heading, float)[:, None]))


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Angles wrapped to (-pi, pi]."""
    return np.pi - np.mod(np.pi - np.asarray(a, float), 2 * np.pi)
