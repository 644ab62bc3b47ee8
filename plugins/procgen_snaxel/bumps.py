"""Where the bumps of an outline are: concave notches between bumps, and the smooth stretches.

The thesis's length-limits table (section 3.5.1) "first allow[s] for some simple structure to be
formed. Then allow[s] the structure to grow for some distance and finally, apply texture by
reducing the curves' lengths"; its results have "small bumps on large bulges" (Figure 4.10(a)),
appear "round in large scale but ha[ve] details in the small scale" (Figure 4.10(e)). Every
curve's joints have detail speed 0 (section 3.4.2), so once the last row has cut a curve into
pieces of at most its limit L, the joints lag behind their pieces and become concave notches
about L apart. An outline textured all over has notches all along it; a large smooth lobe is a
long stretch without one.

Measured here on the outline resampled at a fixed arc step and smoothed along its arc by a
Gaussian of one tessellation spacing (the zig-zag of snaxels across edges is below the model's
resolution and is not a bump): a *notch* is a maximal run of clockwise turning (the outline is
counter-clockwise) whose total turning is at least ``min_turn``; a *smooth stretch* is the arc
between two successive notches when it is longer than ``smooth_len``.
"""
from __future__ import annotations

import numpy as np

from procgen import portable


def resample_closed(xy: np.ndarray, step: float) -> np.ndarray:
    """The closed polyline ``xy`` as points ``step`` apart along its arc (its length rounded)."""
    p = np.vstack([xy, xy[:1]])
    s = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(p, axis=0).T))])
    n = max(int(round(s[-1] / step)), 8)
    at = np.linspace(0.0, s[-1], n, endpoint=False)
    return np.column_stack([np.interp(at, s, p[:, 0]), np.interp(at, s, p[:, 1])])


def smooth_closed(p: np.ndarray, sigma: float) -> np.ndarray:
    """Circular Gaussian smoothing of a closed sequence, ``sigma`` in samples (via the FFT)."""
    n = len(p)
    f = np.fft.rfftfreq(n)
    gain = portable.exp(-2.0 * (np.pi * f * sigma) ** 2)
    return np.fft.irfft(np.fft.rfft(p, axis=0) * gain[:, None], n=n, axis=0)


def turning(p: np.ndarray) -> np.ndarray:
    """Signed turning angle at each vertex of a closed polyline (left turns positive)."""
    d = np.diff(np.vstack([p[-1:], p, p[:1]]), axis=0)
    a, b = d[:-1], d[1:]
    return np.arctan2(a[:, 0] * b[:, 1] - a[:, 1] * b[:, 0], (a * b).sum(1))


def notches(xy: np.ndarray, spacing: float, min_turn: float = np.pi / 4) -> tuple[np.ndarray, float]:
    """Arc positions of the outline's notches and its length (see the module docstring).

    ``spacing``: the tessellation's spacing (the Poisson radius); the outline is resampled every
    spacing / 2 and smoothed with sigma = spacing. ``min_turn``: least clockwise turning (radians)
    of a notch (default 45 degrees)."""
    if np.sum(xy[:-1, 0] * xy[1:, 1] - xy[1:, 0] * xy[:-1, 1]) + xy[-1, 0] * xy[0, 1] - xy[0, 0] * xy[-1, 1] < 0:
        xy = xy[::-1]                                   # counter-clockwise: bumps turn left
    h = 0.5 * spacing
    p = smooth_closed(resample_closed(xy, h), 2.0)
    turn = turning(p)
    n = len(p)
    neg = turn < 0.0
    if neg.all() or not neg.any():
        return np.zeros(0), n * h
    k = int(np.flatnonzero(~neg)[0])                    # start the walk on a left turn
    order = np.roll(np.arange(n), -k)
    negr = neg[order]
    starts = np.flatnonzero(negr & ~np.roll(negr, 1))
    ends = np.flatnonzero(negr & ~np.roll(negr, -1)) + 1
    cum = np.concatenate([[0.0], np.cumsum(turn[order])])
    total = cum[ends] - cum[starts]                     # each run's clockwise turning (no run wraps)
    keep = total <= -min_turn
    centre = (0.5 * (starts + ends - 1)[keep] + k) % n
    return np.sort(centre * h), n * h


def bump_statistics(xy: np.ndarray, spacing: float, smooth_len: float, min_turn: float = np.pi / 4
                    ) -> dict[str, float]:
    """The mean outline length per notch (``notch_spacing``, the whole length when there is none),
    the largest notch-free arc, and the share of the outline in notch-free stretches longer than
    ``smooth_len`` (0: bumps all along; 1: one smooth loop)."""
    at, length = notches(xy, spacing, min_turn)
    if len(at) == 0:
        return {"notch_spacing": round(length, 3), "longest_smooth": round(length, 3), "smooth_share": 1.0}
    gaps = np.diff(np.append(at, at[0] + length))
    return {"notch_spacing": round(length / len(at), 3), "longest_smooth": round(float(gaps.max()), 3),
            "smooth_share": round(float(gaps[gaps > smooth_len].sum() / length), 4)}
