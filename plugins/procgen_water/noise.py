"""Noise helpers for layer thickness and base surfaces (thesis: midpoint displacement, Hurst H).

The fBm itself is the core's diamond-square (``procgen.noise``); here are the Gaussian
'smoothness' blur and a rank transform used to pick exact area fractions.
"""
from __future__ import annotations

import numpy as np

from procgen import portable
from procgen.errors import InputError
from procgen.noise import fbm_spectral
from procgen.noise import midpoint_displacement as _core_md


def midpoint_displacement(shape: tuple[int, int], hurst: float, rng: np.random.Generator,
                          periodic: bool = False) -> np.ndarray:
    """Zero-mean, unit-std fBm by diamond-square (the core's implementation), with checks.

    ``periodic``: a tileable fBm of the same Hurst exponent instead, by spectral synthesis on
    the torus (diamond-square has no wrapped form: its coarse lattice pins the edges apart).
    """
    if min(shape) < 2:
        raise InputError(f"midpoint_displacement: grid {tuple(shape)} too small (need >= 2x2)")
    if not 0.0 < hurst <= 1.0:
        raise InputError(f"midpoint_displacement: hurst must be in (0, 1], got {hurst}")
    shape = tuple(int(s) for s in shape)
    if periodic:
        return fbm_spectral(rng, shape, min(hurst, 0.999), periodic=True)
    return _core_md(rng, shape, hurst)


def smooth(field: np.ndarray, sigma: float, periodic: bool = False) -> np.ndarray:
    """Gaussian blur of ``sigma`` cells (the thesis's 'smoothness coefficient'); 0 = unchanged.
    ``periodic``: the blur wraps round the edges (a tileable field stays tileable)."""
    if sigma <= 0:
        return np.asarray(field, dtype=float)
    return portable.gaussian_filter(field, sigma, mode="wrap" if periodic else "reflect")


def rank_normalise(field: np.ndarray) -> np.ndarray:
    """Map values to (0, 1) by rank, so thresholds at quantiles select exact fractions."""
    flat = np.asarray(field, dtype=float).ravel()
    order = np.argsort(flat, kind="stable")
    r = np.empty(flat.size)
    r[order] = (np.arange(flat.size) + 0.5) / flat.size
    return r.reshape(np.shape(field))
