"""Corrosion cellular automaton on the 2.5D surface (thesis 2.4.1, Fig. 2.7; formalised in ch. 4).

Per step, synchronously (double-buffered, digest 16):
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

from dataclasses import dataclass, field

import numpy as np
from scipy import ndimage

from procgen.errors import InputError

from .noise import rank_normalise

REGROUP_POWERS = {"none": 0, "linear": 1, "square": 2, "cubic": 3, "x4": 4}
OFFSETS = np.array([(-1, -1), (-1, 0), (-1, 1), (0, -1), (0, 1), (1, -1), (1, 0), (1, 1)])  # (dy, dx)
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


@dataclass
class CorrosionStats:
    new_seeds: int = 0
    attacks: int = 0
    max_attacks_per_cell: int = 0
    max_allowed_violation: int = 0
    newly_corroded: int = 0
    new_holes: int = 0
    seed_cells: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))


def _neighbours(shape: tuple[int, int], cells: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n, 8) neighbour cell ids and in-grid mask."""
    ny, nx = shape
    iy, ix = cells // nx, cells % nx
    ny_ = iy[:, None] + OFFSETS[None, :, 0]
    nx_ = ix[:, None] + OFFSETS[None, :, 1]
    inside = (ny_ >= 0) & (ny_ < ny) & (nx_ >= 0) & (nx_ < nx)
    return np.where(inside, ny_ * nx + nx_, 0), inside


def _count8(mask: np.ndarray) -> np.ndarray:
    """Number of True 8-neighbours of every cell (zero padding at the border)."""
    k = np.ones((3, 3), dtype=np.int64)
    k[1, 1] = 0
    return ndimage.convolve(mask.astype(np.int64), k, mode="constant", cval=0)


def corrosion_step(*, corroded: np.ndarray, age: np.ndarray, hole: np.ndarray, weak: np.ndarray,
                   metal: np.ndarray, oxide: np.ndarray, covered: np.ndarray, height: np.ndarray,
                   spacing: float, p: CorrosionParams, rng: np.random.Generator,
                   seeds_used: int) -> CorrosionStats:
    """One synchronous CA step; every (ny, nx) array is updated in place."""
    shape = corroded.shape
    ncell = corroded.size
    st = CorrosionStats()
    valid = ~corroded & ~hole & (metal > 0) & ~covered
    # (c) attacks from the corroded cells of the previous state
    att = np.flatnonzero((corroded & ~hole).ravel())
    newly = np.zeros(ncell, dtype=bool)
    if att.size:
        nb, inside = _neighbours(shape, att)
        ok = inside & valid.ravel()[nb]
        n_vc = ok.sum(axis=1)
        a_age = age.ravel()[att]
        n_a = np.clip(1 + a_age // max(p.age_step, 1), 1, np.minimum(n_vc, MAX_ATTACKS))
        n_a = np.where(n_vc > 0, n_a, 0)
        h = height.ravel()
        dist = np.hypot(OFFSETS[:, 0], OFFSETS[:, 1])[None, :]
        slope = (h[att][:, None] - h[nb]) / (dist * spacing)
        logw = -(dist ** 2) / (2 * p.sigma ** 2) + p.downhill * slope
        keys = np.where(ok, logw - np.log(-np.log(rng.random(ok.shape))), -np.inf)   # Gumbel top-k
        rank = np.argsort(np.argsort(-keys, axis=1, kind="stable"), axis=1, kind="stable")
        chosen = (rank < n_a[:, None]) & ok
        st.attacks = int(chosen.sum())
        per = chosen.sum(axis=1)
        st.max_attacks_per_cell = int(per.max(initial=0))
        st.max_allowed_violation = int(np.sum(per > np.minimum(n_vc, MAX_ATTACKS)))
        helpers = _count8(corroded & ~hole).ravel()
        strong = ~weak
        strong_nb = _count8(strong).ravel()
        attack = p.a0 + p.a1 * a_age + p.a2 * helpers[att]
        ai, di = np.nonzero(chosen)
        target = nb[ai, di]
        defence = p.b0 + p.b1 * strong_nb[target] + p.strong_bonus * strong.ravel()[target]
        win = attack[ai] + p.noise * rng.random(ai.size) > defence
        newly[target[win]] = True
    # (b) new seeds among weak valid cells, capped per step and in total
    want = min(int(np.floor(p.seed_rate * ncell)), max(p.max_seeds - seeds_used, 0))
    if want > 0:
        cand = np.flatnonzero((valid & weak).ravel() & ~newly)
        k = min(want, cand.size)
        if k:
            st.seed_cells = rng.choice(cand, size=k, replace=False)
            newly[st.seed_cells] = True
            st.new_seeds = k
    # (d) corroded cells eat metal and grow oxide (the previously corroded ones)
    old = (corroded & ~hole)
    metal[old] = np.maximum(metal[old] - p.k1, 0.0)
    oxide[old] = np.minimum(oxide[old] + p.k2, np.maximum(oxide[old], p.k3))
    new_hole = old & (metal <= 0)
    hole |= new_hole
    st.new_holes = int(new_hole.sum())
    nmask = newly.reshape(shape)
    corroded |= nmask
    age[old] += 1
    age[nmask] = 0
    st.newly_corroded = int(nmask.sum())
    return st
