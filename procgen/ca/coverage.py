"""Coverage curves of a growing CA: how much of the surface has changed, step by step.

Gobron's 3DSCA thesis plots these for every propagation (Figures 4.4 and 4.9): the cumulative
percentage of cells reached and the percentage reached in each step; the step counts to 50 %,
95 % and 100 % are the numbers the thesis quotes (plate 4.1: full coverage in about 110 steps).
"""
from __future__ import annotations

import numpy as np

from ..domains import Polylines
from ..state import State


class CoverageLog:
    """Per-step coverage history kept as a Polylines domain: line 0 = cumulative % of cells
    changed, line 1 = % of cells changed in that step (the thesis's Figures 4.4 and 4.9)."""

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
