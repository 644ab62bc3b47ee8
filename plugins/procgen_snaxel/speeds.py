"""Snaxel speeds (thesis section 3.4): base speed, details profiles and their blend.

All functions are vectorised over snaxels in chain order; curves are contiguous runs of it.
"""
from __future__ import annotations

import numpy as np

from procgen import portable


def base_speed(s: np.ndarray, run_start_s: np.ndarray, run_len: np.ndarray, run_vb: np.ndarray,
               perimeter: float) -> np.ndarray:
    """Eqs 3.1-3.4: b_v interpolates the curves' base values along arc length between mid-points.

    ``s``: arc position of each snaxel along the whole closed chain; ``run_start_s``: arc position
    of each curve's first snaxel; ``run_len``: each curve's own length; ``run_vb``: base values.
    On B's half towards A the weights are w_b = d(s,p_a)/d(p_b,p_a), w_a = d(s,p_b)/d(p_b,p_a),
    which is exactly linear interpolation between the knots p_a and p_b (periodic in the loop).
    """
    if len(run_vb) == 1 or perimeter <= 0.0:
        return np.full(s.shape, float(run_vb[0]))
    knots = run_start_s + 0.5 * run_len
    return np.interp(s, knots, run_vb, period=perimeter)


def circular_profile(x: np.ndarray, g_max: float, h: np.ndarray) -> np.ndarray:
    """Section 3.4.2 ray construction in closed form: l_v = x(G-x) / sqrt((x-G/2)^2 + (G^2/4h)^2).

    ``x`` in [0, G] is the snaxel projected onto the segment OP1; ``h`` the curve's shape speed.
    Zero at both joints, ``h`` at the middle; the ratio h/G alone sets the bulge shape.
    """
    x = np.minimum(np.maximum(x, 0.0), g_max)     # np.clip's wrapper costs more than the math here
    c = g_max * g_max / (4.0 * h)
    return x * (g_max - x) / np.sqrt((x - 0.5 * g_max) ** 2 + c * c)


def circular_profile_by_rays(x: float, g_max: float, h: float) -> float:
    """The thesis's geometric construction step by step (reference for tests of the closed form).

    Circle through O=(0,0), P1=(G,0), P2=(G/2,h); P3 its bottom point; shoot a ray from P3
    through (x, 0) and return the distance from (x, 0) to where the ray leaves the circle.
    """
    cy = (h * h - g_max * g_max / 4.0) / (2.0 * h)
    rad = h - cy
    p3 = np.array([g_max / 2.0, cy - rad])
    d = np.array([x, 0.0]) - p3
    d /= np.linalg.norm(d)
    # |p3 + t d - c|^2 = rad^2 ; p3 is on the circle so one root is t = 0
    oc = p3 - np.array([g_max / 2.0, cy])
    t_far = -2.0 * float(oc @ d)
    hit = p3 + t_far * d
    return float(np.linalg.norm(hit - np.array([x, 0.0])))


def linear_profile(u: np.ndarray, vmax: np.ndarray) -> np.ndarray:
    """Naive scheme of Fig 3.11/3.13/3.15(b): 0 at the joints, the curve's maximum at its middle."""
    return vmax * (1.0 - np.abs(2.0 * np.minimum(np.maximum(u, 0.0), 1.0) - 1.0))


def effect_coefficient(t: np.ndarray, r: float) -> np.ndarray:
    """Eq 3.5: k = exp(-r t) fades the base speed as a snaxel travels."""
    return portable.exp(-r * t)


def blend(bv: np.ndarray, lv: np.ndarray, k: np.ndarray, w_s: float) -> np.ndarray:
    """Eq 3.6: v_s = w_s k b_v + (1 - w_s k) l_v (a convex blend for w_s, k in [0, 1])."""
    wk = w_s * k
    return wk * bv + (1.0 - wk) * lv
