"""Surface Voronoi diagram by "systematic propagation" (thesis 4.1).

s seeds get labels 1..s.  Each step, a labelled cell passes its label to its side neighbours
always and to each diagonal neighbour with probability P = sqrt(2)/2 - 1/2 (per source/target
pair); an unlabelled cell reached by several labels takes one of them at random.  Labels never
change once set.  Only the frontier (unlabelled cells touching a label) is visited per step.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from procgen.errors import InputError

from procgen.ca.graph import CellGraph, pick_one_per_row

P_DIAGONAL = float(np.sqrt(2.0) / 2.0 - 0.5)   # 0.20711: the thesis's circle-growing value


def place_seeds(n_cells: int, n_seeds: int, rng: np.random.Generator,
                eligible: np.ndarray | None = None) -> np.ndarray:
    """Labels array (int32) with ``n_seeds`` distinct random cells labelled 1..n_seeds."""
    pool = np.arange(n_cells) if eligible is None else np.nonzero(eligible)[0]
    if n_seeds < 1 or n_seeds > len(pool):
        raise InputError(f"voronoi: {n_seeds} seeds requested but {len(pool)} cells available")
    labels = np.zeros(n_cells, np.int32)
    labels[rng.choice(pool, n_seeds, replace=False)] = np.arange(1, n_seeds + 1, dtype=np.int32)
    return labels


@dataclass
class VoronoiGrowth:
    """Synchronous label growth on a CellGraph; ``labels`` 0 = unlabelled, -1 = no cell (hole)."""

    graph: CellGraph
    labels: np.ndarray
    p_diagonal: float = P_DIAGONAL

    def __post_init__(self) -> None:
        self.frontier = self._frontier_of(np.nonzero(self.labels > 0)[0])

    def _frontier_of(self, cells: np.ndarray) -> np.ndarray:
        """Unlabelled cells adjacent to ``cells`` (the graph is symmetric up to edge effects,
        so both directions are included)."""
        e = self.graph.entries_of(cells)
        near = self.graph.indices[e]
        # also cells that list ``cells`` as a neighbour (cross-edge links may be one-way)
        mark = np.zeros(self.graph.n_cells, bool)
        mark[cells] = True
        back = self.graph.rows[mark[self.graph.indices]]
        out = np.union1d(near, back)
        return out[self.labels[out] == 0]

    def step(self, rng: np.random.Generator) -> int:
        """One synchronous step; returns the number of newly labelled cells."""
        rows_cells = self.frontier
        if len(rows_cells) == 0:
            return 0
        g = self.graph
        e = g.entries_of(rows_cells)
        src = g.indices[e]
        lab = self.labels[src]
        diag = g.is_diagonal[e]
        ok = (lab > 0) & (~diag | (rng.random(len(e)) < self.p_diagonal))
        r, pick = pick_one_per_row(g.rows[e], ok, rng, g.n_cells)
        new = self.labels.copy()
        new[r] = lab[pick]
        self.labels = new
        self.frontier = np.union1d(rows_cells[self.labels[rows_cells] == 0], self._frontier_of(r))
        return int(len(r))

    @property
    def coverage(self) -> float:
        valid = self.labels >= 0
        return float(np.mean(self.labels[valid] > 0)) if valid.any() else 1.0
