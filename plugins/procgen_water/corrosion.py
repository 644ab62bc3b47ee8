"""Corrosion cellular automaton on the 2.5D surface (thesis 2.4.1, Fig. 2.7; formalised in ch. 4).

The attack/defence kernel is the one the mesh plugin runs too (procgen.ca.corrosion), here on
the raster's 8-neighbour graph. Per step, synchronously (double-buffered, digest 16):
  (b) new seeds among weak, valid cells: floor(seed_rate * cells) per step, at most max_seeds
      in total;
  (c) each corroded cell attacks n_a = clamp(1 + age // age_step, 1, min(n_valid, 7)) of its
      valid 8-neighbours, drawn without replacement with weights from a 3x3 Gaussian tilted
      downhill (w = exp(-|o|^2 / 2 sigma^2) exp(downhill * slope towards the neighbour));
      an attack succeeds when a0 + a1 age + a2 (corroded neighbours of the attacker) + noise
      > b0 + b1 (strong neighbours of the defender) + strong_bonus [defender is strong];
  (d) every corroded cell loses k1 of metal and gains k2 of oxide (capped at k3); metal <= 0
      makes a hole (the thesis's NO_MORE_CELL).
A cell is *valid* when it is not corroded, not a hole, has metal, and no layer other than the
oxide covers the metal (the thesis corrodes only uncovered metal).

The weak/strong map (plate D-1): a uniform random map regrouped by a radial kernel
(1 - d/R)^p with p = 1, 2, 3, 4 (linear, square, cubic, x^4), mixed with the altitude (lower
cells weaker) and optionally with a water-path trace from a previous water run (thesis 2.7),
then thresholded (the 'binary' function) at the quantile giving exactly the weak fraction.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy import ndimage

from procgen.ca import corrosion as ca
from procgen.ca.graph import MOORE, CellGraph, grid_graph
from procgen.errors import InputError

from .noise import rank_normalise

REGROUP_POWERS = {"none": 0, "linear": 1, "square": 2, "cubic": 3, "x4": 4}
MAX_ATTACKS = 7          # the thesis: 1 to 7 attempts, never 8


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
                   trace_weight: float = 0.0) -> np.ndarray:
    """Grey weak/strong map in (0, 1) (1 = weakest), ranks so quantiles are exact."""
    if regroup not in REGROUP_POWERS:
        raise InputError(f"weak map: regroup {regroup!r} not one of {', '.join(REGROUP_POWERS)}")
    score = rng.random(shape)
    p = REGROUP_POWERS[regroup]
    if p > 0:
        if radius < 1:
            raise InputError(f"weak map: radius must be >= 1 cell, got {radius}")
        score = ndimage.convolve(score, regroup_kernel(p, radius), mode="reflect")
    score = rank_normalise(score)
    if height is not None and altitude_weight > 0:
        score = (1 - altitude_weight) * score + altitude_weight * (1.0 - rank_normalise(height))
    if trace is not None and trace_weight > 0:
        tr = np.log1p(np.maximum(np.asarray(trace, dtype=float), 0.0))
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


@dataclass
class CorrosionParams:
    seed_rate: float = 0.0005
    max_seeds: int = 10
    age_step: int = 5
    a0: float = 0.3
    a1: float = 0.02
    a2: float = 0.1
    b0: float = 1.0
    b1: float = 0.08
    strong_bonus: float = 0.4
    noise: float = 0.5
    sigma: float = 1.0
    downhill: float = 2.0
    k1: float = 0.01
    k2: float = 0.02
    k3: float = 0.2


@lru_cache(maxsize=8)
def _graph(shape: tuple[int, int]) -> CellGraph:
    """The raster's 8-neighbour cell graph (cached: the grid never changes shape)."""
    return grid_graph(*shape)


def corrosion_step(*, corroded: np.ndarray, age: np.ndarray, hole: np.ndarray, weak: np.ndarray,
                   metal: np.ndarray, oxide: np.ndarray, covered: np.ndarray, height: np.ndarray,
                   spacing: float, p: CorrosionParams, rng: np.random.Generator,
                   seeds_used: int) -> ca.StepStats:
    """One synchronous step on the raster: the shared kernel (procgen.ca.corrosion) on the grid's
    graph, attacks tilted downhill; every (ny, nx) array is updated in place."""
    shape = corroded.shape
    graph = _graph(tuple(shape))
    status = np.where(hole, ca.HOLE, np.where(corroded, ca.CORRODED, ca.NORMAL)).astype(np.int8).ravel()
    st = ca.CorrosionState(status=status, consumable=np.array(metal, float).reshape(-1, 1),
                           product=np.array(oxide, float).ravel(), age=np.array(age, np.int64).ravel(),
                           strong=~np.asarray(weak, bool).ravel(), seeds_used=int(seeds_used))
    h = np.asarray(height, dtype=float).ravel()
    offset = MOORE[graph.direction]
    slope = (h[graph.rows] - h[graph.indices]) / (np.hypot(offset[:, 0], offset[:, 1]) * spacing)
    prm = ca.CorrosionParams(k1=p.k1, k2=p.k2, k3=p.k3, seed_rate=p.seed_rate, max_seeds=p.max_seeds,
                             max_attacks=MAX_ATTACKS, age_step=float(max(p.age_step, 1)), a0=p.a0, a1=p.a1,
                             a2=p.a2, b0=p.b0, b1=p.b1, strong_bonus=p.strong_bonus, noise=p.noise,
                             gaussian=tuple(map(tuple, ca.gaussian_matrix(p.sigma))), seeding="fixed")
    out = ca.corrosion_step(graph, st, prm, rng, edge_logw=p.downhill * slope,
                            blocked=np.asarray(covered, bool).ravel())
    metal[...] = st.consumable[:, 0].reshape(shape)
    oxide[...] = st.product.reshape(shape)
    age[...] = st.age.reshape(shape)
    corroded |= (st.status != ca.NORMAL).reshape(shape)
    hole |= (st.status == ca.HOLE).reshape(shape)
    return out
