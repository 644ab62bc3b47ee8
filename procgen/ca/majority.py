"""Majority vote / regrouping: every cell takes the label most of its neighbours hold.

On a bool state this is the two-sided majority vote of the cellular-network paper's
"regrouping" (Gobron & Chiba, Table 1; a special case of Young's activator/inhibitor CA): alive
when more than half the neighbours are alive, dead when fewer, unchanged on a tie.  On integer
labels (Voronoi regions, materials) it is the plurality vote that smooths ragged borders:
the most frequent neighbour label wins, a tie keeps the cell's own label if it is among the
winners, else the smallest.  Negative labels mean "no cell" and neither vote nor change.
Synchronous updates of a symmetric threshold rule end in a fixed point or a 2-cycle
(Goles & Olivos 1980): on bipartite graphs (the von Neumann square grid) expect 2-cycles.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..fields import FieldSpec
from ..params import param
from ..state import State
from .automaton import StateAutomaton
from .cells import put_cell_values
from .graph import CellGraph


def majority_step(graph: CellGraph, alive: np.ndarray, self_vote: bool = False) -> np.ndarray:
    """Two-sided majority of bool states (ties keep the state); a new array."""
    k = graph.degree + self_vote
    kp = graph.count(alive) + (alive if self_vote else 0)
    return np.where(2 * kp > k, True, np.where(2 * kp < k, False, alive))


def plurality_step(graph: CellGraph, labels: np.ndarray, self_vote: bool = False) -> np.ndarray:
    """Most frequent neighbour label per cell (ties: own label if tied, else the smallest)."""
    rows, src = graph.rows, graph.indices
    if self_vote:
        cells = np.arange(graph.n_cells)
        rows, src = np.concatenate([rows, cells]), np.concatenate([src, cells])
    lab = labels[src]
    ok = (lab >= 0) & (labels[rows] >= 0)
    rows, lab = rows[ok], lab[ok]
    if len(rows) == 0:
        return labels.copy()
    values, code = np.unique(lab, return_inverse=True)
    pair, votes = np.unique(rows * len(values) + code, return_counts=True)
    r, c = np.divmod(pair, len(values))
    own = values[c] == labels[r]
    order = np.lexsort((c, ~own, -votes, r))        # per row: most votes, own label, smallest
    r, c = r[order], c[order]
    first = np.ones(len(r), bool)
    first[1:] = r[1:] != r[:-1]
    out = labels.copy()
    out[r[first]] = values[c[first]]
    return out


@dataclass(kw_only=True)
class Majority(StateAutomaton):
    """Majority vote / regrouping on any cell domain: bool states or integer labels.

    Each step every present cell takes the state most of its neighbours hold (synchronous);
    bool ties and label ties keep the cell's own state.  Starts at random (bool, `density`) or
    from an existing bool or label field, e.g. the Voronoi regions to smooth.
    """

    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "grid.noise", "params": {"nx": 24, "ny": 16, "grid": "cells"}},
        {"rule": "ca.majority", "until": "stable", "max_iterations": 50},)
    name: ClassVar[str] = "ca.majority"
    default_iterations: ClassVar[int] = 100
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("{field}", domain="{cells}", at="cell", intent="out",
                  doc="state (bool) or label (integer) after the vote"),)
    self_vote: bool = param(False, doc="the cell's own state counts as one more vote")

    def setup(self, state: State) -> None:
        dom, self._graph, self._present = self.cell_domain(state)
        s = self.start(dom, self._present, state.rng())
        self._state = s & self._present if s.dtype == bool else s    # absent cells have no votes
        self._write(dom)

    def _write(self, dom) -> None:
        put_cell_values(dom, self.field, self._state, doc="majority vote")

    def step(self, state: State) -> bool:
        if self._state.dtype == bool:
            new = majority_step(self._graph, self._state, self.self_vote) & self._present
        else:
            new = plurality_step(self._graph, self._state, self.self_vote)
        changed = bool(np.any(new != self._state))
        self._state = new
        self._write(state.get(self.cells))
        return changed
