"""Weak/strong ('wet') maps for corrosion (thesis 2.4.1, plate D-1; water paths: 2.7).

The corrosion automaton itself is the layered-materials family's ``layers.corrode``; it reads
the map this module makes (``corrosion__weak``) as its strong-cell mask.

The weak/strong map (plate D-1): a uniform random map regrouped by a radial kernel
(1 - d/R)^p with p = 1, 2, 3, 4 (linear, square, cubic, x^4), mixed with the altitude (lower
cells weaker) and optionally with a water-path trace from a previous water run (thesis 2.7),
then thresholded (the 'binary' function) at the quantile giving exactly the weak fraction.
"""
from __future__ import annotations

import numpy as np
from scipy import ndimage

from procgen import portable
from procgen.errors import InputError

from .noise import rank_normalise

REGROUP_POWERS = {"none": 0, "linear": 1, "square": 2, "cubic": 3, "x4": 4}


def regroup_kernel(power: int, radius: float) -> np.ndarray:
    """Radial kernel (1 - d/R)^p on a (2R+1)^2 window, normalised to sum 1."""
    r = int(np.ceil(radius))
    yy, xx = np.mgrid[-r:r + 1, -r:r + 1]
    d = np.hypot(xx, yy)
    k = np.clip(1.0 - d / radius, 0.0, None) ** power
    return k / k.sum()


def weakness_score(shape: tuple[int, int], rng: np.random.Generator, *, regroup: str = "linear",
                   radius: float = 6.0, height: np.ndarray | None = None,
                   altitude_weight: float = 0.0, trace: np.ndarray | None = None,
                   trace_weight: float = 0.0, periodic: bool = False) -> np.ndarray:
    """Grey weak/strong map in (0, 1) (1 = weakest), ranks so quantiles are exact; on a
    ``periodic`` grid the regrouping wraps round the edges (the map tiles)."""
    if regroup not in REGROUP_POWERS:
        raise InputError(f"weak map: regroup {regroup!r} not one of {', '.join(REGROUP_POWERS)}")
    score = rng.random(shape)
    p = REGROUP_POWERS[regroup]
    if p > 0:
        if radius < 1:
            raise InputError(f"weak map: radius must be >= 1 cell, got {radius}")
        score = ndimage.convolve(score, regroup_kernel(p, radius), mode="wrap" if periodic else "reflect")
    score = rank_normalise(score)
    if height is not None and altitude_weight > 0:
        score = (1 - altitude_weight) * score + altitude_weight * (1.0 - rank_normalise(height))
    if trace is not None and trace_weight > 0:
        tr = portable.log(1.0 + np.maximum(np.asarray(trace, dtype=float), 0.0))
        if tr.max() > 0:
            score = (1 - trace_weight) * score + trace_weight * tr / tr.max()
    return rank_normalise(score)


def weak_cells(score: np.ndarray, weak_fraction: float) -> np.ndarray:
    """The binary map: the weak_fraction of cells with the highest score."""
    if not 0.0 <= weak_fraction <= 1.0:
        raise InputError(f"weak map: weak_fraction must be in [0, 1], got {weak_fraction}")
    n = score.size
    k = int(round(weak_fraction * n))
    out = np.zeros(n, dtype=bool)
    if k:
        out[np.argsort(score.ravel(), kind="stable")[n - k:]] = True
    return out.reshape(score.shape)
