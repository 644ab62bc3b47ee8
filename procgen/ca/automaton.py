"""What every cellular-automaton rule shares: a cell domain, its neighbour graph, a start state.

A CA rule is written once against the cell-domain protocol (:mod:`.cells`) and so runs on a
Grid, on the surface cells of a mesh and on a cell network alike.  Stepping is synchronous and
double-buffered: a step computes the whole next state from the previous one (never from cells
already updated in the same step) and then replaces it, as in every CA the theses cite
(Gobron's 3DSCA thesis 4.3; the wood-weathering thesis 3.2 reads its rule tables this way).
Cells marked absent by ``cell__alive`` (holes cut by an earlier rule) take no part.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from ..errors import InputError
from ..fields import FieldSpec, check_field_name
from ..params import param
from ..rules import RuleBase
from ..state import State
from .cells import CELL_DOMAIN, NEIGHBOURHOODS, cell_graph, cell_values, present_cells
from .graph import CellGraph


@dataclass(kw_only=True)
class CellAutomaton(RuleBase):
    """Base of the CA rules: the cell domain and neighbourhood every one of them takes."""

    uses: ClassVar[dict[str, str]] = {"{cells}": CELL_DOMAIN}
    cells: str = param("cells", doc="cell domain to run on: a Grid, surface cells or a cell network")
    neighbourhood: str = param("moore", choices=NEIGHBOURHOODS,
                               doc="all 8 Moore neighbours, or the 4 side ones (von Neumann)")

    def cell_domain(self, state: State) -> tuple[Any, CellGraph, np.ndarray]:
        """(domain, graph among present cells, present mask) of ``self.cells``."""
        dom = state.get(self.cells)
        graph = cell_graph(dom, self.neighbourhood, where=f"{self.name}: domain {self.cells!r}")
        present = present_cells(dom)
        if not present.all():
            graph = graph.restrict(present[graph.rows] & present[graph.indices])
        return dom, graph, present


@dataclass(kw_only=True)
class StateAutomaton(CellAutomaton):
    """A CA over one per-cell state field: started at random (a live density) or from the field."""

    field: str = param("ca__alive", doc="cell field holding the automaton's state")
    initial: str = param("random", choices=("random", "field"),
                         doc="start from random live cells at `density`, or from the existing `field`")
    density: float = param(0.5, ge=0.0, le=1.0, doc="fraction of live cells in a random start")

    def validate(self) -> None:
        check_field_name(self.field)

    def field_specs(self) -> list[FieldSpec]:
        """The state field is read as well as written when the run starts from it."""
        specs = super().field_specs()
        if self.initial == "field":
            specs = [dataclasses.replace(s, intent="inout") if s.name == self.field else s for s in specs]
        return specs

    def start(self, dom: Any, present: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """The initial state, a flat (n,) array: random bool cells, or a copy of ``field``."""
        if self.initial == "random":
            return (rng.random(len(present)) < self.density) & present
        if self.field not in dom or dom.field_info(self.field).at != "cell":
            raise InputError(f"{self.name}: {self.cells!r} has no cell field {self.field!r} to start from")
        a = np.array(cell_values(dom, self.field))
        if a.ndim != 1 or not (a.dtype == bool or np.issubdtype(a.dtype, np.integer)):
            raise InputError(f"{self.name}: start field {self.field!r} must be one bool or integer "
                             f"value per cell, got {a.dtype} {a.shape}")
        return a
