"""Coverage curves of a cellular automaton: how much of the domain it has reached, per step.

Kept as a Polylines domain so a recipe can plot or export it like any other output: line 0 is
the cumulative % of cells changed, line 1 the % of cells changed in that step (the 3DSCA
thesis's Figures 4.4 and 4.9).
"""
from __future__ import annotations

import numpy as np

from ..domains import Polylines
from ..state import State


class CoverageLog:
    """Per-step coverage history of one CA run."""

    def __init__(self) -> None:
        self.cumulative: list[float] = [0.0]
        self.per_step: list[float] = [0.0]

    def add(self, cumulative: float, changed: float) -> None:
        self.cumulative.append(100.0 * cumulative)
        self.per_step.append(100.0 * changed)

    def domain(self) -> Polylines:
        t = np.arange(len(self.cumulative), dtype=float)
        return Polylines.from_list([np.column_stack([t, self.cumulative]),
                                    np.column_stack([t, self.per_step])], closed=False)

    def report(self, state: State, prefix: str) -> None:
        c = np.asarray(self.cumulative)
        for q in (50, 95, 100):
            hit = np.nonzero(c >= q - 1e-9)[0]
            state.report(f"{prefix}.steps_to_{q}pct", int(hit[0]) if len(hit) else None)
        state.report(f"{prefix}.final_coverage_pct", float(c[-1]))
