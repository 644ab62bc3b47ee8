"""procgen.arena.zeros: zeroed, independent, aligned arrays carved from one buffer."""
from __future__ import annotations

import copy
import pickle

import numpy as np

from procgen import arena

SPECS = [((300, 7), np.float64), (1001, np.int32), ((5, 3, 2), np.uint8), (0, np.float64),
         ((64, 4), np.int64)]


def _check(arrays, specs):
    for a, (shape, dtype) in zip(arrays, specs):
        assert a.shape == ((shape,) if isinstance(shape, int) else shape) and a.dtype == dtype
        assert a.flags.c_contiguous and a.flags.writeable and not a.any()
        assert a.size == 0 or a.ctypes.data % 64 == 0       # each on its own cache line
    for k, a in enumerate(arrays):                          # writing one changes no other
        a[...] = 1
        assert all(not b.any() for b in arrays[k + 1:])
    return arrays


def test_small_groups():
    _check(arena.zeros(SPECS), SPECS)


def test_groups_large_enough_for_huge_pages_start_on_one():
    specs = [((1 << 18,), np.float64)] * 3 + SPECS          # 6 MiB and more
    arrays = _check(arena.zeros(specs), specs)
    assert arrays[0].ctypes.data % (2 << 20) == 0


def test_copies_and_pickles_are_ordinary_arrays():
    a = arena.zeros(SPECS)[0]
    a[3, 4] = 2.5
    for b in (copy.deepcopy(a), pickle.loads(pickle.dumps(a)), a.copy()):
        assert np.array_equal(a, b)
        b[3, 4] = 0.0
        assert a[3, 4] == 2.5
