"""Seeded multi-label propagation: Voronoi regions grown cell by cell (Gobron's 3DSCA thesis 4.1).

s seeds get labels 1..s.  Each step, a labelled cell passes its label to its side neighbours
always and to each diagonal neighbour with probability P = sqrt(2)/2 - 1/2 (per source/target
pair), which grows a disc rather than a square or a lozenge (thesis plates 3.2 and 4.1); an
unlabelled cell reached by several labels takes one of them at random.  Labels never change
once set.  Only the frontier (unlabelled cells touching a label) is visited per step.  On a
graph without diagonal entries (von Neumann, a cell network) every neighbour passes its label.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy.spatial import cKDTree

from ..accel import MIN_CELLS, kernels
from ..errors import InputError
from ..fields import FieldSpec, check_field_name
from ..params import param
from ..state import State
from .automaton import CellAutomaton
from .cells import cell_centres, cell_distances, cell_size, put_cell_values
from .coverage import CoverageLog, disc_completion
from .graph import CellGraph, pick_one_per_row

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
    """Synchronous label growth on a CellGraph; ``labels`` 0 = unlabelled, -1 = no cell (hole).
    The growth owns a copy of the labels it is given (both paths update that copy in place)."""

    graph: CellGraph
    labels: np.ndarray
    p_diagonal: float = P_DIAGONAL
    accelerate: bool | None = None     # numba kernel of procgen.ca.kernels (same labels), see procgen.accel

    def __post_init__(self) -> None:
        self.labels = np.array(self.labels, np.int32)
        self.frontier = self._frontier_of(np.nonzero(self.labels > 0)[0])

    def _frontier_of(self, cells: np.ndarray) -> np.ndarray:
        """Unlabelled cells adjacent to ``cells`` (the graph is symmetric up to edge effects,
        so both directions are included)."""
        g, back = self.graph, self.graph.incoming
        near = g.indices[g.entries_of(cells)]
        # also cells that list ``cells`` as a neighbour (cross-edge links may be one-way)
        out = np.union1d(near, back.indices[back.entries_of(cells)])
        return out[self.labels[out] == 0]

    def step(self, rng: np.random.Generator) -> int:
        """One synchronous step; returns the number of newly labelled cells."""
        kern = kernels("procgen.ca.kernels", self.accelerate, self.graph.n_cells, MIN_CELLS)
        if kern is not None:
            return kern.voronoi_step(self, rng)
        rows_cells = self.frontier
        if len(rows_cells) == 0:
            return 0
        g = self.graph
        e = g.entries_of(rows_cells)
        src = g.indices[e]
        lab = self.labels[src]
        diag = g.is_diagonal[e] if g.direction is not None else np.zeros(len(e), bool)
        ok = (lab > 0) & (~diag | (rng.random(len(e)) < self.p_diagonal))
        r, pick = pick_one_per_row(g.rows[e], ok, rng, g.n_cells)
        self.labels[r] = lab[pick]                # (lab was read before: a synchronous step)
        self.frontier = np.union1d(rows_cells[self.labels[rows_cells] == 0], self._frontier_of(r))
        return int(len(r))


@dataclass(kw_only=True)
class VoronoiPropagation(CellAutomaton):
    """Voronoi regions by systematic propagation from seeds (3DSCA thesis 4.1), on any cell domain.

    Seeds get labels 1..s; labels spread to side neighbours always and to diagonal ones with
    probability P = sqrt(2)/2 - 1/2, until every cell is labelled (run with until = "stable").
    The coverage curve (thesis Figure 4.4) goes to a Polylines domain; the steps to 50/95/100 %
    are reported as ``{cells}.voronoi.steps_to_50`` / ``steps_to_95`` / ``steps_to_full``.
    With one seed, ``completion_radii`` reports the disc's completion after r steps against
    the ideal circle of radius r cells (thesis plate 3.2: 87 % at r = 10, 99.9 % at r = 70) as
    ``{cells}.voronoi.completion_r{r}``: the fraction of the cells within r cell sizes of the
    seed, measured over the surface (:func:`procgen.ca.cells.cell_distances`), that carry a label.

    A step touches only the frontier: the coverage is a running count of labelled cells (labels
    only grow and the step returns how many it set), and the label field and the curve, which
    only later rules, exporters and frames read, are written by :meth:`publish`.
    """

    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "grid.noise", "params": {"nx": 24, "ny": 16, "grid": "cells"}},
        {"rule": "ca.voronoi", "params": {"seeds": 3}, "until": "stable", "max_iterations": 500},)
    name: ClassVar[str] = "ca.voronoi"
    default_iterations: ClassVar[int] = 2000
    creates: ClassVar[dict[str, str]] = {"{coverage}": "Polylines"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("{field}", domain="{cells}", at="cell", intent="out", dtype="int32",
                  doc="region label 1..seeds, 0 = not reached yet"),)
    field: str = param("voronoi__label", doc="cell field receiving the region labels")
    seeds: int = param(12, ge=1, doc="number of random seeds")
    seed_points: list[list[float]] | None = param(
        None, doc="explicit seed positions in the domain's coordinates (nearest cell each) instead of random seeds")
    p_diagonal: float = param(P_DIAGONAL, ge=0.0, le=1.0, doc="diagonal propagation probability")
    coverage: str = param("coverage", doc="Polylines domain receiving the coverage curve")
    completion_radii: list[int] = param([], ge=1, units="cells",
                                        doc="one seed: report the disc completion after these many steps")

    def validate(self) -> None:
        check_field_name(self.field)
        n_seeds = len(self.seed_points) if self.seed_points else self.seeds
        if self.completion_radii and n_seeds != 1:
            raise ValueError("completion_radii measures one seed's disc: give exactly one seed")
        if self.seed_points is not None and (not self.seed_points or
                                             len({len(p) for p in self.seed_points}) != 1):
            raise ValueError("seed_points must be a non-empty list of points of one dimension")

    def setup(self, state: State) -> None:
        dom, graph, present = self.cell_domain(state)
        if self.seed_points:
            pts = np.asarray(self.seed_points, dtype=float)
            centres = cell_centres(dom)
            if pts.shape[1] != centres.shape[1]:
                raise InputError(f"{self.name}: seed_points need {centres.shape[1]} coordinates on a "
                                 f"{dom.kind}, got {pts.shape[1]}")
            _, near = cKDTree(centres).query(pts)
            labels = np.zeros(len(present), np.int32)
            labels[near] = np.arange(1, len(pts) + 1, dtype=np.int32)
        else:
            labels = place_seeds(len(present), self.seeds, state.rng(), present)
        labels[~present] = -1
        self._grow = VoronoiGrowth(graph, labels, self.p_diagonal)
        self._cells = int(np.sum(labels >= 0))
        self._labelled = int(np.sum(labels > 0))
        self._log = CoverageLog()
        self._log.add(self._coverage(), self._labelled / len(labels))
        self._published = False
        self.publish(state)
        self._radius_cells = None
        if self.completion_radii:
            self._radius_cells = cell_distances(dom, int(np.argmax(labels > 0))) / cell_size(dom)

    def step(self, state: State) -> bool:
        n_new = self._grow.step(state.rng())
        r = state.iteration + 1                  # steps done: the disc has grown r cells
        if self._radius_cells is not None and r in self.completion_radii:
            state.report(f"{self.cells}.voronoi.completion_r{r}",
                         disc_completion(self._grow.labels > 0, self._radius_cells, r))
        if n_new == 0 and len(self._grow.frontier) == 0:
            return False                  # finished: keep the log as it is (cheap idle steps)
        self._labelled += n_new
        self._log.add(self._coverage(), n_new / len(self._grow.labels))
        self._published = False
        return n_new > 0

    def _coverage(self) -> float:
        """Share of the present cells labelled: the same double as ``np.mean(labels[valid] > 0)``
        (numpy sums the bools in float64, exact below 2**53, then divides once by the count)."""
        return self._labelled / self._cells if self._cells else 1.0

    def publish(self, state: State) -> None:
        """Write the labels into ``{field}`` and the curve into ``{coverage}`` if a step changed
        them since the last time (the runner calls this before each frame; finish at the end)."""
        if self._published:
            return
        put_cell_values(state.get(self.cells), self.field, np.maximum(self._grow.labels, 0),
                        doc="Voronoi region")
        state.add_domain(self.coverage, self._log.domain())
        self._published = True

    def finish(self, state: State) -> None:
        self.publish(state)
        self._log.report(state, self.cells + ".voronoi")
