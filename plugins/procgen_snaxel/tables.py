"""Length-limits tables (thesis section 3.5.1): travelled distance -> maximum curve length.

A table is written as rows ``[lo, hi, limit]`` (the half-open range [lo, hi)) with an optional
open last row ``[lo, limit]`` meaning "> lo". Rows must start at 0, be sorted and touch
(no gap, no overlap). Past the last row the last row's limit applies (ambiguity A20).
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# The thesis's tables, verbatim (Tables 3.3-3.7, 4.1, 4.3-4.9); 1e5 means "never split".
THESIS_TABLES: dict[str, list[list[float]]] = {
    "3.3": [[0, 50, 200], [50, 300, 100000], [300, 25]],
    "3.4": [[0, 50, 200], [50, 200, 100000], [200, 300, 500], [300, 25]],
    "3.7": [[0, 50, 500], [50, 100, 50], [100, 50]],
    "4.1": [[0, 50, 400], [50, 150, 1000], [150, 200, 1500], [200, 250, 50]],
    "4.3": [[0, 50, 400], [50, 100, 100000], [100, 200, 400], [200, 250, 30], [250, 25]],
    "4.4": [[0, 50, 400], [50, 100, 100000], [100, 200, 400], [200, 260, 50], [260, 25]],
    "4.5": [[0, 50, 400], [50, 150, 1000], [150, 200, 1500], [200, 25]],
    "4.6": [[0, 50, 400], [50, 100, 1000], [100, 200, 400], [200, 250, 75], [250, 270, 50], [270, 25]],
    "4.7": [[0, 50, 200], [50, 100, 100000], [100, 150, 200], [150, 30]],
    "4.8": [[0, 50, 200], [50, 100, 100000], [100, 150, 200], [150, 25]],
    "4.9": [[0, 50, 400], [50, 150, 1000], [150, 200, 1500], [200, 220, 500], [220, 25]],
}


@dataclass(frozen=True)
class LengthLimits:
    """A validated table; ``limit(t)`` is vectorised."""

    lower: np.ndarray     # row lower bounds, sorted, lower[0] == 0
    limits: np.ndarray    # row limits

    def limit(self, t: np.ndarray) -> np.ndarray:
        # lower[0] == 0, so only t < 0 falls before the first row; searchsorted never passes the last
        return self.limits[np.maximum(np.searchsorted(self.lower, t, side="right") - 1, 0)]


def parse_table(rows: list[list[float]], where: str = "table") -> LengthLimits:
    """Check the rows and build the lookup; ValueError with a one-line message if malformed."""
    if not rows:
        raise ValueError(f"{where}: the length-limits table is empty")
    lower, upper, limits = [], [], []
    for i, row in enumerate(rows):
        last = i == len(rows) - 1
        if len(row) == 3:
            lo, hi, lim = (float(x) for x in row)
        elif len(row) == 2 and last:
            (lo, lim), hi = (float(x) for x in row), np.inf
        else:
            raise ValueError(f"{where} row {i}: expected [from, to, limit]"
                             + (" or [from, limit] for the open last row" if last else ""))
        if not hi > lo:
            raise ValueError(f"{where} row {i}: range [{lo:g}, {hi:g}) is empty or reversed")
        if lim <= 0:
            raise ValueError(f"{where} row {i}: limit {lim:g} must be > 0")
        if i == 0 and lo != 0:
            raise ValueError(f"{where} row 0: must start at travelled distance 0, starts at {lo:g}")
        if i > 0 and lo < upper[-1]:
            raise ValueError(f"{where} row {i}: starts at {lo:g}, overlapping row {i - 1} "
                             f"which ends at {upper[-1]:g} (rows must be sorted and not overlap)")
        if i > 0 and lo > upper[-1]:
            raise ValueError(f"{where} row {i}: gap between {upper[-1]:g} and {lo:g}")
        lower.append(lo)
        upper.append(hi)
        limits.append(lim)
    return LengthLimits(np.asarray(lower), np.asarray(limits))
