"""Crack birth (3DSCA thesis 5.2.4.a and Table 5.3 of its appendix D): where, what type, which way.

Unstable cells (some axis above the material resistance mR) form the Pot-Crack list, sorted by
their strongest axis; cracks are born in series, the strongest first, lowering the threshold by
Sii.  The type (I, T, Y, X) comes from coding the 4 axes M (above mR), S (weaker but present)
or 0 and reading Table 5.3; the direction runs across the dominant stress axis.
"""
from __future__ import annotations

import numpy as np

from procgen.ca.subcell import AXIS_ANGLES, dominant_axis

I, T, Y, X = 0, 1, 2, 3
TYPE_NAMES = ("I", "T", "Y", "X")

# Table 5.3: the code of the 4 axes read from the strongest one on; its "I or T" rows are "I|T"
_TABLE = {
    "M000": "I", "MS00": "I", "M0S0": "I|T", "M00S": "I", "MM00": "I", "M0M0": "X", "M00M": "I",
    "MSS0": "I|T", "MS0S": "I", "M0SS": "I|T", "MMS0": "I|T", "MM0S": "I|T", "MSM0": "I",
    "M0MS": "I", "MMM0": "I", "MM0M": "I", "M0MM": "I", "MSSS": "I", "MMSS": "I", "MSMS": "X",
    "MSSM": "I", "MMMS": "I", "MSMM": "I", "MMSM": "I", "MMMM": "Y",
}


def pot_crack(imax: np.ndarray, resistance: float, eligible: np.ndarray) -> np.ndarray:
    """The Pot-Crack list: eligible cells with imax > mR, strongest first (ties: lower id)."""
    idx = np.nonzero(eligible & (imax > resistance))[0]
    return idx[np.lexsort((idx, -imax[idx]))]


def codes(spec: np.ndarray, resistance: float, floor: float) -> list[str]:
    """Table 5.3 codes of spectra (m, 4): M > mR, S > floor * mR, else 0; read from the max."""
    m = len(spec)
    start = np.argmax(spec, axis=1)
    rolled = spec[np.arange(m)[:, None], (start[:, None] + np.arange(4)) % 4]
    ch = np.where(rolled > resistance, "M", np.where(rolled > floor * resistance, "S", "0"))
    return ["".join(row) for row in ch]


def crack_types(spec: np.ndarray, resistance: float, floor: float, t_share: float,
                allowed: set[int], rng: np.random.Generator) -> np.ndarray:
    """Type per cell from Table 5.3; "I or T" rows are T with probability ``t_share``.

    A type not in ``allowed`` (plate 5.10 seeds I only) falls back to I.
    """
    u = rng.uniform(size=len(spec))
    out = np.empty(len(spec), np.int64)
    for q, code in enumerate(codes(spec, resistance, floor)):   # births only: a handful per series
        entry = _TABLE.get(code, "I")
        out[q] = T if entry == "I|T" and u[q] < t_share else TYPE_NAMES.index(entry[0])
    out[~np.isin(out, list(allowed))] = I
    return out


def crack_axis(spec: np.ndarray, floor: float, resistance: float) -> np.ndarray:
    """Direction of a new crack (radians, in [0, pi)): across the dominant stress axis.

    Table 5.3's direction column is garbled; we read it as: the axes coded M or S, as vectors at
    twice their angle weighted by their intensity, sum to the dominant axis, and the crack runs
    perpendicular to it.  Where they cancel (X, Y rows) the strongest axis is used instead.
    """
    w = np.where(spec > floor * resistance, spec, 0.0)
    axis, strength = dominant_axis(w)
    weak = strength < 1e-9 * np.maximum(w.max(axis=1), 1e-300)
    axis = np.where(weak, AXIS_ANGLES[np.argmax(spec, axis=1)], axis)
    return np.mod(axis + np.pi / 2, np.pi)


#: initial CM headings relative to the crack direction, per type (thesis 5.2.4.a)
HEADS = {I: (0.0, np.pi), T: (0.0, np.pi, np.pi / 2), Y: (0.0, 2 * np.pi / 3, 4 * np.pi / 3),
         X: (0.0, np.pi / 2, np.pi, 3 * np.pi / 2)}


def initial_heads(types: np.ndarray, direction: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(birth index, heading) of every crack module of each new crack."""
    who, ang = [], []
    for t, offsets in HEADS.items():                     # 4 types, each vectorised
        sel = np.nonzero(types == t)[0]
        for off in offsets:
            who.append(sel)
            ang.append(direction[sel] + off)
    who_a, ang_a = np.concatenate(who), np.concatenate(ang)
    order = np.argsort(who_a, kind="stable")
    return who_a[order], ang_a[order]


def spaced(candidates: np.ndarray, slots: np.ndarray, hops: int) -> np.ndarray:
    """The candidates (strongest first) that are the strongest within ``hops`` graph steps.

    Not in the thesis, which births every cell of a series: on a smooth or uniform field that
    would start neighbouring cells as parallel cracks; we keep one per neighbourhood, and the
    others stay in Pot-Crack (the first crack's release usually stabilises them).

    The best rank is dilated ``hops`` times over the Moore slots (each cell takes the lowest
    rank among itself and its neighbours), but only over the cells ``hops`` slot steps from a
    candidate, all that a candidate's result depends on: a few candidates born at one CM step
    cost their neighbourhoods, not the lattice.
    """
    if hops <= 0 or len(candidates) == 0:
        return candidates
    big = np.iinfo(np.int64).max
    cand = np.asarray(candidates, np.int64)
    region = np.unique(cand)
    for _ in range(hops):                                 # the cells within hops of a candidate
        nb = slots[region]
        region = np.union1d(region, nb[nb >= 0])
    best = np.full(len(region), big)
    best[np.searchsorted(region, cand)] = np.arange(len(cand))
    nb = slots[region]
    at = np.minimum(np.searchsorted(region, nb), len(region) - 1)
    hit = (nb >= 0) & (region[at] == nb)                  # slots leading out of the region: none
    for _ in range(hops):                                 # pull over each cell's slots
        best = np.minimum(best, np.where(hit, best[at], big).min(axis=1))
    return candidates[best[np.searchsorted(region, cand)] == np.arange(len(cand))]