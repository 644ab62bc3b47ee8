"""The compiled-kernel helpers of the core: numpy's pairwise sum order and the prefetch hint."""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("numba")

from numba import njit  # noqa: E402

from procgen.pairwise import pairwise_sum  # noqa: E402
from procgen.prefetch import prefetch  # noqa: E402


@njit(cache=False)
def _sums(a, start):
    out = np.empty(129)
    for n in range(129):
        out[n] = pairwise_sum(a, start, n)
    return out


def test_pairwise_sum_is_numpys_sum_bit_for_bit():
    """Every length up to numpy's block size, at an offset, on terms whose order matters (a
    left-to-right sum differs from numpy's in most of these)."""
    rng = np.random.default_rng(3)
    a = rng.standard_normal(200) * 10.0 ** rng.integers(-8, 9, 200)
    got = _sums(a, 5)
    want = np.array([a[5:5 + n].sum() for n in range(129)])
    assert np.array_equal(got.view(np.uint64), want.view(np.uint64))
    naive = np.array([sum(a[5:5 + n].tolist(), 0.0) for n in range(129)])
    assert not np.array_equal(naive, want)          # the test can tell the orders apart


@njit(cache=False)
def _gather(a, idx, ahead):
    s = 0.0
    for k in range(idx.size):
        if k + ahead < idx.size:
            prefetch(a, idx[k + ahead])
        s += a[idx[k]]
    return s


def test_prefetch_compiles_and_changes_nothing():
    rng = np.random.default_rng(4)
    a = rng.random(1 << 16)
    idx = rng.integers(0, a.size, 5000)
    assert _gather(a, idx, 8) == _gather(a, idx, 0)
    assert _gather(a, idx, 8) == sum(a[idx].tolist(), 0.0)
