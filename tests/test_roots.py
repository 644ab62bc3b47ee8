"""procgen.roots.cbrt: within one ulp of the true cube root (checked in exact rational
arithmetic), exact on perfect cubes and powers of eight, and the same bits when numba compiles
it as on numpy's path."""
from __future__ import annotations

from fractions import Fraction

import numpy as np
import pytest

from procgen.roots import cbrt


def _samples(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    wide = np.exp(rng.uniform(np.log(1e-300), np.log(1e300), n))           # every exponent class
    near = np.ldexp(1.0, rng.integers(-900, 900, n)) * rng.choice([1.0, 1 + 2.0 ** -52, 2 - 2.0 ** -52], n)
    return np.concatenate([wide, rng.uniform(1e-3, 10.0, n), near,
                           [np.finfo(float).tiny, np.finfo(float).max, 1.0, 8.0, 7.999999999999999]])


def test_within_one_ulp_of_the_true_cube_root():
    x = _samples(1500)
    y = cbrt(x)
    for xi, yi in zip(x.tolist(), y.tolist()):
        u = Fraction(float(np.spacing(yi)))
        lo, hi = Fraction(yi) - u, Fraction(yi) + u
        assert lo ** 3 < Fraction(xi) < hi ** 3, xi          # the root lies within one ulp of y


def test_exact_where_the_root_is_a_double():
    k = np.arange(1, 2000, dtype=float)
    assert np.array_equal(cbrt(k ** 3), k)
    e = np.arange(-330, 330)
    assert np.array_equal(cbrt(np.ldexp(1.0, 3 * e)), np.ldexp(1.0, e))


def test_compiled_gives_the_same_bits():
    numba = pytest.importorskip("numba")
    scalar = numba.njit(inline="always")(cbrt)

    @numba.njit
    def each(x, out):
        for i in range(x.size):
            out[i] = scalar(x[i])

    x = _samples(100_000, seed=1)
    out = np.empty_like(x)
    each(x, out)
    assert np.array_equal(out.view(np.int64), cbrt(x).view(np.int64))
