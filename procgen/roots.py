"""Cube root made of IEEE-754 basic operations: the same bits on every machine, on numpy's path
and inside compiled (numba) kernels.

Why: ``np.cbrt`` is the C library's ``cbrt`` on most machines but Intel's SVML on those with
AVX-512 (numpy picks at run time), and the C libraries' differ between vendors and versions
(glibc 2.36's is up to 3.3 ulp off, and half its results are not the nearest double).  A
compiled kernel that must give numpy's numbers bit for bit (the water drops' radius) can call
neither, and a recipe run on two machines should not drift apart through it.  This root is
made of +, -, *, / and integer operations on the bits, which IEEE-754 fixes to the last bit:
against a long-double reference on four million arguments from 1e-300 to 1e300 it is at most
0.96 ulp off, and the nearest double 89% of the time.  In a kernel it is inline arithmetic, not
a library call (which makes the compiled code save and restore every live floating-point
register around it).

The same source serves both paths: numpy evaluates :func:`cbrt` on arrays, and a kernel module
compiles it for scalars (``njit(inline="always")(roots.cbrt)``).
"""
from __future__ import annotations

import numpy as np

_MANTISSA = (1 << 52) - 1
_EXP = 1 << 52                      # one unit of the exponent field
# t ** (1/3) on [1, 8] within 1.4%: a cubic fitted to the relative error (only the start of
# the iteration: any constants would do that bring two Halley steps to full precision)
_C = (0.00191683, -0.0374981, 0.340029, 0.709121)


def cbrt(x):
    """x ** (1/3) for positive normal (not subnormal) finite x: an array (numpy) or, compiled,
    a float.  x = t 2**(3q) with t in [1, 8) from the bits; a cubic's estimate of t ** (1/3),
    then two of Halley's steps y - y (y^3 - t) / (2 y^3 + t) (cubic convergence: 1e-2, 1e-6,
    then the rounding); y 2**q put back into the bits (exact)."""
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
