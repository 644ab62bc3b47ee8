"""Regrouping by local activation and long-range inhibition (Young 1984, end of section 5).

The paper names its "regrouping" rule a special case of the activation/inhibition family:

    p_i <- [ h + J1 * sum_{r_ij < R1} p_j + J2 * sum_{R1 <= r_ij < R2} p_j > 0 ]

(the extracted text lost its sums and threshold; p is boolean so the sum is thresholded).  J1 > 0
activates nearby, J2 < 0 inhibits farther out; R2 reaches beyond the links, so the two rings
are Euclidean neighbourhoods (scipy's cKDTree, which gives the same pairs as a 27-box search
with boxes of side R2 and is faster at such radii), the cell itself included in the R1 disc.  Spots and stripes settle in tens of steps.  The majority
special case (J2 = 0, R1 = the link radius) is the generic ``ca.majority`` rule.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import scipy.sparse as sp

from procgen import FieldSpec, State, param

from .cellrule import EXAMPLE_NET, CellRule, Next
from .states import selection


def ring_matrices(net, r1: float, r2: float,
                  rows: np.ndarray | None = None) -> tuple[sp.csr_matrix, sp.csr_matrix]:
    """(A1, A2): cells closer than r1 (self included) and in [r1, r2), as 0/1 matrices.

    ``rows`` (cell indices, default all) are the cells whose sums are wanted: row k of both
    matrices belongs to cell ``rows[k]``, the columns are every cell.  A rule that updates one
    material only (Figure 1's lichen glyph) keeps the rings of those cells alone: R2 = 6 cs holds
    about a hundred cells, so rings for a whole million-cell network would take gigabytes.
    """
    from scipy.spatial import cKDTree

    p = net.positions
    n = net.n_cells
    rows = np.arange(n) if rows is None else np.asarray(rows, np.int64)
    if len(rows) == 0:
        empty = sp.csr_matrix((0, n))
        return empty, empty
    tree = cKDTree(p, balanced_tree=False, compact_nodes=False)
    sub = cKDTree(p[rows], balanced_tree=False, compact_nodes=False)
    m = sub.sparse_distance_matrix(tree, r2 * (1 + 1e-9), output_type="ndarray")
    i, j = m["i"].astype(np.int64), m["j"].astype(np.int64)
    keep = rows[i] != j                                   # the cell itself: added once below
    i, j = i[keep], j[keep]
    d = np.linalg.norm(p[rows[i]] - p[j], axis=1)         # exact, as the links: ``< r``
    near = d < r2
    i, j, d = i[near], j[near], d[near]
    shape = (len(rows), n)

    def mat(mask, extra=None):
        a, b = i[mask], j[mask]
        if extra is not None:
            a, b = np.concatenate([a, extra[0]]), np.concatenate([b, extra[1]])
        return sp.csr_matrix((np.ones(len(a)), (a, b)), shape=shape)
    inner = d < r1
    return mat(inner, (np.arange(len(rows)), rows)), mat(~inner)


@dataclass(kw_only=True)
class ActivatorInhibitor(CellRule):
    """Young's activator/inhibitor CA on Euclidean rings: spots and stripes (Figure 1(l) lichen)."""

    name: ClassVar[str] = "cellnet.young"
    default_iterations: ClassVar[int] = 60
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("{field}", domain="{cells}", at="cell", intent="out", doc="activated cells"),)
    example: ClassVar[tuple[dict, ...]] = EXAMPLE_NET + (
        {"rule": "cellnet.young", "iterations": 3},)

    field: str = param("ca__alive", doc="bool cell field of activated cells")
    density: float = param(0.5, ge=0.0, le=1.0, doc="initial share of activated cells (if the field is absent)")
    h: float = param(0.0, doc="bias")
    j1: float = param(1.0, doc="activation weight inside R1")
    j2: float = param(-0.2, doc="inhibition weight between R1 and R2")
    r1: float = param(2.3, gt=0.0, units="cs", doc="activation radius")
    r2: float = param(6.0, gt=0.0, units="cs", doc="inhibition radius")

    def validate(self) -> None:
        if self.r2 <= self.r1:
            raise ValueError(f"r2 = {self.r2:g} must exceed r1 = {self.r1:g}")

    def setup(self, state: State) -> None:
        net = self.network(state)
        chosen = selection(net, self.materials, self.labels, self.name)
        self._rows = np.nonzero(chosen)[0] if not chosen.all() else np.arange(net.n_cells)
        self._rings = ring_matrices(net, self.r1 * net.cs, self.r2 * net.cs, self._rows)
        if self.field not in net:
            alive = state.rng().random(net.n_cells) < self.density
            net.add_field(self.field, alive, at="cell", doc="activated cells")

    def advance(self, net, send: np.ndarray, update: np.ndarray) -> Next:
        p = np.asarray(net[self.field], bool)
        if len(self._rows) < net.n_cells and update.any():
            inside = np.zeros(net.n_cells, bool)
            inside[self._rows] = True
            if (update & ~inside).any():             # the selection grew since setup: all rings
                self._rows = np.arange(net.n_cells)
                self._rings = ring_matrices(net, self.r1 * net.cs, self.r2 * net.cs)
        a1, a2 = self._rings
        s = (p & send).astype(float)
        new = p.copy()
        new[self._rows] = (self.h + self.j1 * (a1 @ s) + self.j2 * (a2 @ s)) > 0
        return Next(update, {self.field: np.where(update, new, p)})
