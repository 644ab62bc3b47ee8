"""Coverage curves of a growing CA: how much of the surface has changed, step by step.

Gobron's 3DSCA thesis plots these for every propagation (Figures 4.4 and 4.9): the cumulative
percentage of cells reached and the percentage reached in each step; the step counts to 50 %,
95 % and 100 % are the numbers the thesis quotes (plate 4.1: full coverage in about 110 steps),
and a single seed's disc is judged by its completion against the ideal circle (plate 3.2).
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
        self._rows = np.zeros((64, 3))        # (step, cumulative, per step): grown by doubling

    def add(self, cumulative: float, changed: float) -> None:
        self.cumulative.append(100.0 * cumulative)
        self.per_step.append(100.0 * changed)
        k = len(self.cumulative)
        if k > len(self._rows):
            self._rows = np.concatenate([self._rows, np.zeros_like(self._rows)])
        self._rows[k - 1] = (k - 1, self.cumulative[-1], self.per_step[-1])

    def domain(self) -> Polylines:
        """The two curves, built from the kept rows: a copy of the whole history, so a rule
        builds it when it publishes (frames, the end) rather than after every step."""
        k = len(self.cumulative)
        rows = self._rows[:k]
        return Polylines(np.concatenate([rows[:, :2], rows[:, ::2]]), [0, k, 2 * k], closed=False)

    def steps_to(self, percent: float) -> int | None:
        """First step at which the cumulative coverage reaches ``percent`` (None: never)."""
        hit = np.nonzero(np.asarray(self.cumulative) >= percent - 1e-9)[0]
        return int(hit[0]) if len(hit) else None

    def report(self, state: State, prefix: str) -> None:
        """``{prefix}.steps_to_5`` / ``_50`` / ``_95`` / ``_full``, the final % and the
        ``start_share``: steps to 5 % over steps to 95 %, how long the seeds struggle before the
        curve takes off (thesis 4.2.4: corrosion "very strong propagation difficulties at the
        beginning", where the Voronoi curve starts at once)."""
        steps = {name: self.steps_to(q) for name, q in (("5", 5), ("50", 50), ("95", 95), ("full", 100))}
        for name, n in steps.items():
            state.report(f"{prefix}.steps_to_{name}", n)
        state.report(f"{prefix}.final_coverage_pct", float(self.cumulative[-1]))
        if steps["5"] is not None and steps["95"]:
            state.report(f"{prefix}.start_share", steps["5"] / steps["95"])


def disc_completion(reached: np.ndarray, distance: np.ndarray, radius: float) -> float:
    """Completion of a disc grown from one seed: the fraction of the cells inside the ideal
    circle (``distance`` from the seed <= ``radius``, NaN = not measured) that are reached.

    Thesis plate 3.2: after r steps the disc has radius r cells and is "completed at 87 %"
    (r = 10) and "99.9 %" (r = 70); 100 % means no hole or notch inside the ideal circle.
    """
    inside = np.nan_to_num(distance, nan=np.inf) <= radius
    return float(np.mean(reached[inside])) if inside.any() else float("nan")
