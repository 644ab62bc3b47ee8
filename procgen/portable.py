"""Elementary functions made of IEEE-754 basic operations: the same bits on every machine.

Why: numpy picks its ``exp``, ``log``, ``power``, ``cbrt``, ``arctan2`` ... at run time: on a CPU
with AVX-512 they are Intel's SVML or numpy's own AVX-512 code, elsewhere the C library's, and
the two differ in the last bits (as the C libraries do between vendors and versions).  A chaotic
process turns one last bit into a different picture: a snaxel cloud's births and merges are
decided by thresholds, and the same recipe and seed grew two different clouds on an AVX-512 and
on another x86 machine.  The functions here are made of +, -, *, /, comparisons and integer
operations on the bits, which IEEE-754 fixes to the last bit, so a process that uses them gives
the same bytes on every machine.  They cost 15-30 ns an element and 30 us a call (numpy's SIMD
versions: about 1 ns an element): use them where a value decides something or reaches a file,
numpy's where it only shades a picture.

The methods are the classic table-free ones (Cody & Waite's argument reduction; the series of
exp and of log(1 + f) = 2 atanh(f / (2 + f)) after it), with Taylor coefficients (exact
rationals rounded once), not fitted ones: longer series, no machine-specific constants.

:func:`cbrt` also serves the compiled path: numba compiles the same source for scalars
(``njit(inline="always")(portable.cbrt)``) and gets numpy's bits.  :func:`exp`, :func:`log` and
:func:`power` take arrays or scalars and return float64 arrays.
"""
from __future__ import annotations

from decimal import Context, Decimal
from fractions import Fraction
from math import factorial

import numpy as np
from scipy import ndimage

_MANTISSA = (1 << 52) - 1
_EXP = 1 << 52                      # one unit of the exponent field
# t ** (1/3) on [1, 8] within 1.4%: a cubic fitted to the relative error (only the start of
# the iteration: any constants would do that bring two Halley steps to full precision)
_C = (0.00191683, -0.0374981, 0.340029, 0.709121)


def cbrt(x):
    """x ** (1/3) for positive normal (not subnormal) finite x: an array (numpy) or, compiled,
    a float.  x = t 2**(3q) with t in [1, 8) from the bits; a cubic's estimate of t ** (1/3),
    then two of Halley's steps y - y (y^3 - t) / (2 y^3 + t) (cubic convergence: 1e-2, 1e-6,
    then the rounding); y 2**q put back into the bits (exact).  Within 0.96 ulp of the true root
    on four million arguments from 1e-300 to 1e300, the nearest double 89% of the time (glibc
    2.36's ``cbrt`` is up to 3.3 ulp off).  Inline in a kernel, it is arithmetic, not a library
    call (which makes compiled code save and restore every live floating-point register)."""
    b = np.float64(x).view(np.int64)
    e = (b >> 52) - 1023                    # x = f 2**e, f in [1, 2)
    q = e // 3                              # (floor: e - 3 q in 0..2)
    t = np.int64((b & _MANTISSA) + (e - 3 * q + 1023) * _EXP).view(np.float64)
    y = ((_C[0] * t + _C[1]) * t + _C[2]) * t + _C[3]
    y3 = y * y * y
    y = y - y * (y3 - t) / (2.0 * y3 + t)
    y3 = y * y * y
    y = y - y * (y3 - t) / (2.0 * y3 + t)
    return np.int64(np.float64(y).view(np.int64) + q * _EXP).view(np.float64)


# ln 2 = _LN2_HI + _LN2_LO: the high part keeps 32 significant bits, so k * _LN2_HI is exact for
# every |k| < 2**21 (exp's and log's k stay within 1100); the low part is the rest, rounded once
_LN2 = Context(prec=60).ln(Decimal(2))
_LN2_HI = float(np.int64(np.float64(float(_LN2)).view(np.int64) & ~np.int64((1 << 21) - 1)).view(np.float64))
_LN2_LO = float(_LN2 - Decimal(_LN2_HI))
_INV_LN2 = float(1 / _LN2)
# exp(r) = 1 + r + r^2 (1/2! + r/3! + ... + r^11/13!): on |r| <= ln2/2 the first term left out,
# r^14/14!, is below 5e-18 (0.04 ulp of 1)
_EXP_Q = tuple(float(Fraction(1, factorial(n))) for n in range(2, 14))
# log(1 + f) = f - f^2/2 + s (f^2/2 + R), s = f / (2 + f), R = sum 2 s^2k / (2k + 1), k = 1..11:
# with sqrt(1/2) <= 1 + f < sqrt(2), |s| < 0.1716 and the first term left out is below 2e-19
_LOG_R = tuple(float(Fraction(2, 2 * k + 1)) for k in range(1, 12))
_SQRT2 = float(Context(prec=40).sqrt(Decimal(2)))
_TINY = float(np.finfo(np.float64).tiny)


def _horner(c: tuple[float, ...], x: np.ndarray) -> np.ndarray:
    acc = x * c[-1]
    acc += c[-2]
    for a in c[-3::-1]:
        acc *= x
        acc += a
    return acc


def _two_to(k: np.ndarray) -> np.ndarray:
    """2**k for integer k in [-1022, 1023], made from the bits (exact)."""
    return ((k + 1023) << 52).view(np.float64)


_BLOCK = 8192       # elements per pass: the dozens of passes run on data in the L2 cache


def _blockwise(kernel, x) -> np.ndarray:
    """``kernel`` on a float64 array, a cache-sized block at a time (small ones in one go)."""
    x = np.asarray(x, dtype=np.float64)
    flat = x.reshape(-1)
    if flat.size <= _BLOCK:
        return kernel(flat).reshape(x.shape)
    out = np.empty(flat.size)
    for i in range(0, out.size, _BLOCK):
        out[i:i + _BLOCK] = kernel(flat[i:i + _BLOCK])
    return out.reshape(x.shape)


def exp(x) -> np.ndarray:
    """e**x, within one ulp (measured: at most 0.94 ulp on 65,000 arguments against a
    50-digit reference); inf above 709.78, 0 below -745.13, NaN stays NaN.  x = k ln2 + r with
    |r| <= ln2/2 (Cody & Waite: k ln2 in two parts, so r keeps its digits), the series of e**r,
    then 2**k in two exact factors (so results down to the smallest subnormal come out)."""
    return _blockwise(_exp, x)


def _exp(x: np.ndarray) -> np.ndarray:
    xc = np.clip(x, -746.0, 710.0)                           # NaN stays NaN, and so does p
    k = np.rint(xc * _INV_LN2)
    r = xc - k * _LN2_HI
    r -= k * _LN2_LO
    p = _horner(_EXP_Q, r)
    p *= r
    p *= r
    p += r
    p += 1.0
    with np.errstate(invalid="ignore", over="ignore"):       # (a NaN's k is any integer)
        k = k.astype(np.int64)
        half = k >> 1
        k -= half
        p *= _two_to(half)
        p *= _two_to(k)
    return p


def log(x) -> np.ndarray:
    """Natural logarithm, within one ulp (measured: at most 0.77 ulp on 65,000 arguments against
    a 50-digit reference); -inf at 0, NaN below 0 and for NaN, inf at inf.  x = (1 + f) 2**e with
    sqrt(1/2) <= 1 + f < sqrt(2) from the bits, then e ln2 + log(1 + f) summed from the small
    parts up (f itself is exact, and only the small correction carries rounding)."""
    return _blockwise(_log, x)


def _log(x: np.ndarray) -> np.ndarray:
    ok = (x > 0) & (x < np.inf)
    xs = np.where(ok, x, 1.0)
    sub = xs < _TINY
    xs[sub] *= 2.0 ** 54                                     # subnormals: normal first (exact)
    b = xs.view(np.int64)
    e = (b >> 52) - 1023 - np.where(sub, 54, 0)
    m = ((b & _MANTISSA) | (np.int64(1023) << 52)).view(np.float64)     # in [1, 2)
    big = m >= _SQRT2
    m = np.where(big, 0.5 * m, m)
    e = (e + big).astype(np.float64)
    f = m - 1.0                                              # exact (Sterbenz)
    s = f / (2.0 + f)
    z = s * s
    hfsq = 0.5 * f * f
    R = z * _horner(_LOG_R, z)
    out = e * _LN2_HI - ((hfsq - (s * (hfsq + R) + e * _LN2_LO)) - f)
    out = np.where(ok, out, np.where(x == 0, -np.inf, np.where(x == np.inf, np.inf, np.nan)))
    return out


def power(x, y) -> np.ndarray:
    """x**y for x >= 0 as exp(y log x): within |y ln x| + 1 ulp (the log's last bit, scaled);
    0**y is 0 for y > 0, inf for y < 0, 1 for y == 0; NaN for x < 0."""
    x = np.asarray(x, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    pos = x > 0
    with np.errstate(invalid="ignore"):
        out = exp(y * log(np.where(pos, x, 1.0)))
    zero = np.where(y > 0, 0.0, np.where(y < 0, np.inf, 1.0))
    return np.where(pos, out, np.where(x == 0, zero, np.nan))


def pseudo_angle(dx, dy) -> np.ndarray:
    """A stand-in for the angle of (dx, dy) that orders directions as ``arctan2`` does, from
    basic operations only: in [0, 4), counter-clockwise from +x, one unit per quadrant
    (dy / (|dx| + |dy|) within each), exact on the axes and diagonals.  For sorting around a
    vertex, where ``arctan2``'s last bits differ between machines."""
    dx = np.asarray(dx, dtype=np.float64)
    dy = np.asarray(dy, dtype=np.float64)
    with np.errstate(invalid="ignore", divide="ignore"):
        t = dy / (np.abs(dx) + np.abs(dy))                   # in [-1, 1]; NaN at (0, 0)
    t = np.where(np.isnan(t), 0.0, t)
    return np.where(dx >= 0, np.where(dy >= 0, t, 4.0 + t), 2.0 - t)


def gaussian_filter(a, sigma, mode: str = "reflect", truncate: float = 4.0) -> np.ndarray:
    """``scipy.ndimage.gaussian_filter`` (order 0) with its kernel made by :func:`exp` (scipy
    makes it with ``np.exp``, whose last bits vary by CPU): one 1-D correlation per axis whose
    sigma (a number, or one per axis) is above 0, the kernel cut at ``truncate`` sigma."""
    a = np.asarray(a, dtype=np.float64)
    sigmas = np.broadcast_to(np.asarray(sigma, dtype=np.float64), (a.ndim,))
    for axis, s in enumerate(sigmas):
        if s > 0:
            r = int(truncate * float(s) + 0.5)
            x = np.arange(-r, r + 1, dtype=np.float64)
            w = exp(-0.5 / (s * s) * x * x)
            a = ndimage.correlate1d(a, w / w.sum(), axis=axis, mode=mode)
    return a
