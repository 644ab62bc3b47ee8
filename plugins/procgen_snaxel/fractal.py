"""The area-perimeter fractal dimension of an ensemble of cloud outlines (Lovejoy 1982).

Lovejoy ("Area-perimeter relation for rain and cloud areas", Science 216, 185-187, 1982) found
that satellite and radar cloud areas from 1 to 1.2e6 km^2 follow P ~ A^(D/2) with D = 1.35 +-
0.05: a perimeter measured at a fixed resolution grows faster than the sqrt(A) of smooth shapes
(D = 1) but slower than area (D = 2). It is an *ensemble* statistic: one outline gives one
(A, P) point. Here an ensemble is every recorded contour of every run: a snaxel cloud passes
through outlines of every size on its way (each contour is a cloud of that size made by the
same process), measured at the same resolution, the tessellation's.
"""
from __future__ import annotations

import numpy as np


def perimeter_dimension(areas: np.ndarray, perimeters: np.ndarray) -> tuple[float, float]:
    """D and its standard error from the least-squares slope of log P on log A (D = 2 slope)."""
    la, lp = np.log(np.asarray(areas, float)), np.log(np.asarray(perimeters, float))
    if len(la) < 3 or np.ptp(la) == 0:
        raise ValueError("perimeter_dimension: need >= 3 outlines of different areas")
    x = la - la.mean()
    slope = float((x * (lp - lp.mean())).sum() / (x * x).sum())
    resid = lp - lp.mean() - slope * x
    stderr = float(np.sqrt((resid ** 2).sum() / (len(la) - 2) / (x * x).sum()))
    return 2.0 * slope, 2.0 * stderr


def ensemble_dimension(area_runs: list[list[float]], perimeter_runs: list[list[float]],
                       decades: float = 2.0) -> dict[str, float]:
    """D over the contours of many runs, each run's contours within ``decades`` of its final area
    (the first few contours are rings of a handful of snaxels, below the tessellation's scale)."""
    a, p = [], []
    for ar, pr in zip(area_runs, perimeter_runs):
        ar, pr = np.asarray(ar, float), np.asarray(pr, float)
        keep = ar >= ar.max() * 10.0 ** -decades
        a.append(ar[keep])
        p.append(pr[keep])
    A, P = np.concatenate(a), np.concatenate(p)
    D, err = perimeter_dimension(A, P)
    return {"D": round(D, 4), "D_stderr": round(err, 4), "D_outlines": int(len(A)),
            "D_area_decades": round(float(np.log10(A.max() / A.min())), 2)}
