"""The compiled-kernel helpers of the core: numpy's pairwise sum order, the prefetch hint, and
how the kernels' threads wait between parallel regions."""
from __future__ import annotations

import ast
import os
import subprocess
import sys

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


_WAIT_VARS = ("OMP_WAIT_POLICY", "GOMP_SPINCOUNT", "KMP_BLOCKTIME")


def _wait_env(**env):
    """The wait variables a fresh process has after loading a kernel module, given ``env``."""
    base = {k: v for k, v in os.environ.items() if k not in _WAIT_VARS}
    code = ("import os; from procgen import accel; accel.kernels('procgen.ca.kernels', True); "
            f"print(repr([os.environ.get(k) for k in {_WAIT_VARS!r}]))")
    out = subprocess.run([sys.executable, "-c", code], env={**base, **env}, check=True,
                         capture_output=True, text=True).stdout
    return dict(zip(_WAIT_VARS, ast.literal_eval(out.strip())))


def test_loading_a_kernel_module_bounds_the_threads_spin_unless_the_user_chose():
    """Idle OpenMP threads spin a bounded while (GNU: SPIN_COUNT spins; Intel: 1 ms) once a
    kernel module loads; a user's OMP_WAIT_POLICY or spin setting is left as it is."""
    from procgen.accel import SPIN_COUNT
    assert _wait_env() == {"OMP_WAIT_POLICY": None, "GOMP_SPINCOUNT": str(SPIN_COUNT),
                           "KMP_BLOCKTIME": "1"}
    assert _wait_env(OMP_WAIT_POLICY="PASSIVE") == {
        "OMP_WAIT_POLICY": "PASSIVE", "GOMP_SPINCOUNT": None, "KMP_BLOCKTIME": None}
    assert _wait_env(GOMP_SPINCOUNT="7")["GOMP_SPINCOUNT"] == "7"
