"""The area-perimeter fractal dimension of an ensemble of cloud outlines (Lovejoy 1982).

Lovejoy ("Area-perimeter relation for rain and cloud areas", Science 216, 185-187, 1982) found
that satellite and radar cloud areas from 1 to 1.2e6 km^2 follow P ~ A^(D/2) with D = 1.35 +-
0.05: a perimeter measured at a fixed resolution grows faster than the sqrt(A) of smooth shapes
(D = 1) but slower than area (D = 2). It is an *ensemble* statistic: one outline gives one
(A, P) point. Measured here as he measured it:

* **Resolution.** Each outline is rasterised at a fixed pixel ``eps`` (the tessellation's
  Poisson radius: the model resolves nothing finer), and A = pixels x eps^2, P = pixel sides on
  the boundary x eps (his perimeter was the count of pixel sides around a cloud). The snake's
  own polyline length would count the zig-zag of snaxels across tessellation edges, a scale
  below the model's resolution that adds the same relative length to every outline and shifts
  small outlines most.
* **Range.** Outlines of at least MIN_PIXELS pixels (below that the pixel count measures the
  raster, not the shape; Lovejoy's fit also starts at a few pixels), every recorded contour of
  every run: a snaxel cloud passes through outlines of every size on its way, each a cloud of
  that size made by the same process.
* **Weights.** Contours are recorded at a fixed step interval, so big, late outlines outnumber
  small ones; the fit gives each 0.1-decade bin of area one point (the mean log A, log P of its
  outlines), as a log-binned satellite census does.
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


MIN_PIXELS = 100
"""Smallest outline in the fit, in pixels of side eps (~40 pixel sides of perimeter)."""

BIN_DECADES = 0.1
"""Width of the area bins that each weigh one point in the fit."""


def raster_area_perimeter(xy: np.ndarray, eps: float) -> tuple[float, float]:
    """Area and perimeter of the closed outline ``xy`` rasterised at pixel side ``eps`` (pixel
    centres inside the polygon; perimeter = pixel sides between inside and outside)."""
    from PIL import Image, ImageDraw

    lo = xy.min(0) - 2.0 * eps
    nx, ny = (np.ceil((xy.max(0) + 2.0 * eps - lo) / eps).astype(int))
    img = Image.new("1", (int(nx), int(ny)), 0)
    ImageDraw.Draw(img).polygon(((xy - lo) / eps - 0.5).ravel().tolist(), fill=1)
    inside = np.asarray(img, bool)
    sides = np.count_nonzero(inside[:, 1:] != inside[:, :-1]) + np.count_nonzero(inside[1:] != inside[:-1])
    return float(inside.sum()) * eps * eps, float(sides) * eps


def ensemble_dimension(area_runs: list[list[float]], perimeter_runs: list[list[float]], eps: float
                       ) -> dict[str, float]:
    """D over the contours of many runs (raster areas and perimeters at pixel ``eps``): outlines
    of at least MIN_PIXELS pixels, one point per BIN_DECADES of area (module docstring)."""
    A = np.concatenate([np.asarray(a, float) for a in area_runs])
    P = np.concatenate([np.asarray(p, float) for p in perimeter_runs])
    keep = A >= MIN_PIXELS * eps * eps
    la, lp = np.log10(A[keep]), np.log10(P[keep])
    if len(la) < 3:
        raise ValueError(f"ensemble_dimension: {len(la)} outlines of >= {MIN_PIXELS} pixels; need >= 3")
    b = np.floor(la / BIN_DECADES).astype(np.int64)
    _, inv, n = np.unique(b, return_inverse=True, return_counts=True)
    D, err = perimeter_dimension(10.0 ** (np.bincount(inv, la) / n), 10.0 ** (np.bincount(inv, lp) / n))
    return {"D": round(D, 4), "D_stderr": round(err, 4), "D_outlines": int(keep.sum()), "D_bins": int(len(n)),
            "D_area_decades": round(float(la.max() - la.min()), 2), "D_pixel": eps}
