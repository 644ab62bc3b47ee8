"""procgen.portable: cbrt within one ulp of the true cube root (checked in exact rational
arithmetic), exact on perfect cubes and powers of eight, and the same bits when numba compiles
it as on numpy's path; exp and log within one ulp of a 50-digit decimal reference, with IEEE's
special values; power, pseudo_angle and gaussian_filter against numpy's and scipy's."""
from __future__ import annotations

from decimal import Context, Decimal
from fractions import Fraction

import numpy as np
import pytest

from scipy import ndimage

from procgen import portable
from procgen.portable import cbrt


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


_DEC = Context(prec=50)


def _ulps(got: np.ndarray, exact: list[Decimal]) -> float:
    """The largest distance of ``got`` from the exact values, in ulps of the exact value."""
    worst = Decimal(0)
    for g, e in zip(got.tolist(), exact):
        ulp = Decimal(float(np.spacing(abs(float(e)))))
        worst = max(worst, abs(Decimal(g) - e) / ulp)
    return float(worst)


def test_exp_within_one_ulp():
    rng = np.random.default_rng(2)
    x = np.concatenate([rng.uniform(-708.0, 709.0, 2000), rng.uniform(-1.0, 1.0, 2000),
                        rng.uniform(-1e-8, 1e-8, 200), [0.0, 1.0, -1.0, 0.5 * np.log(2.0), 709.78]])
    assert _ulps(portable.exp(x), [_DEC.exp(Decimal(v)) for v in x.tolist()]) < 1.0


def test_exp_special_values_and_the_subnormal_range():
    got = portable.exp([np.nan, np.inf, -np.inf, 709.79, -745.2, -745.13, -740.0])
    assert np.isnan(got[0]) and got[1] == np.inf and got[2] == 0.0 and got[3] == np.inf and got[4] == 0.0
    assert got[5] == 5e-324                                  # the smallest subnormal
    assert abs(got[6] - float(_DEC.exp(Decimal(-740)))) <= 5e-324
    assert portable.exp(0.0) == 1.0 and portable.exp(np.zeros((2, 3))).shape == (2, 3)


def test_log_within_one_ulp():
    rng = np.random.default_rng(3)
    x = np.concatenate([np.exp(rng.uniform(np.log(1e-300), np.log(1e300), 2000)), rng.uniform(0.5, 2.0, 2000),
                        1.0 + rng.uniform(-1e-7, 1e-7, 200), [np.sqrt(2.0), np.nextafter(np.sqrt(2.0), 0), 2.0, 0.5,
                                                              3e-320, 5e-324, np.finfo(float).max]])
    x = x[x != 1.0]
    assert _ulps(portable.log(x), [_DEC.ln(Decimal(v)) for v in x.tolist()]) < 1.0


def test_log_special_values():
    got = portable.log([0.0, -1.0, np.nan, np.inf, 1.0])
    assert got[0] == -np.inf and np.isnan(got[1]) and np.isnan(got[2]) and got[3] == np.inf and got[4] == 0.0


def test_power_is_numpys_within_its_stated_bound():
    rng = np.random.default_rng(4)
    x = np.exp(rng.uniform(-20.0, 20.0, 5000))
    y = rng.uniform(-3.0, 3.0, 5000)
    got, ref = portable.power(x, y), np.power(x, y)
    bound = (np.abs(y * np.log(x)) + 2.0) * np.spacing(ref)    # |y ln x| + 1 ulp each side
    assert np.all(np.abs(got - ref) <= bound)
    assert np.array_equal(portable.power([0.0, 0.0, 0.0, 4.0], [2.0, -1.0, 0.0, 0.5]), [0.0, np.inf, 1.0, 2.0])
    assert np.isnan(portable.power(-1.0, 2.0))


def test_pseudo_angle_orders_directions_as_arctan2():
    rng = np.random.default_rng(5)
    d = rng.normal(size=(5000, 2))
    d[:8] = [[1, 0], [1, 1], [0, 1], [-1, 1], [-1, 0], [-1, -1], [0, -1], [1, -1]]
    a = portable.pseudo_angle(d[:, 0], d[:, 1])
    assert np.array_equal(a[:8], np.arange(8) / 2.0)            # the axes and diagonals
    ref = np.arctan2(d[:, 1], d[:, 0]) % (2 * np.pi)
    assert np.array_equal(np.argsort(a), np.argsort(ref))
    assert np.all((a >= 0) & (a < 4))


@pytest.mark.parametrize("mode", ["reflect", "nearest"])
@pytest.mark.parametrize("sigma", [0.7, 2.5, (1.5, 0.0)])
def test_gaussian_filter_is_scipys(mode, sigma):
    a = np.random.default_rng(6).random((40, 50))
    got = portable.gaussian_filter(a, sigma, mode=mode)
    assert np.allclose(got, ndimage.gaussian_filter(a, sigma, mode=mode), rtol=0, atol=1e-14)
