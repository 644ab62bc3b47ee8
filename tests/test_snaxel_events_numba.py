"""The compiled snaxel events (procgen_snaxel.events_numba) against the numpy ones: whole clouds."""
from __future__ import annotations

import numpy as np
import pytest

from procgen_snaxel.growth import CloudGrowth
from procgen_snaxel.tessellate import poisson_tessellation

from test_snaxel_engine import check_snake, small_cfg


def _grow(topo, accelerate: bool, seed: int, steps: int):
    g = CloudGrowth(topo, small_cfg(max_steps=steps), np.random.default_rng(seed))
    g.snake.accelerate = accelerate
    while g.step():
        pass
    return g


@pytest.mark.parametrize("seed,room", [(1, 8), (2, 0)])
def test_compiled_events_grow_the_same_cloud(seed, room, monkeypatch):
    """One compiled call per step (room 0: the chain buffer must grow during most steps)."""
    import procgen_snaxel.events_numba as ev
    monkeypatch.setattr(ev, "ROOM", room)
    topo = poisson_tessellation(160.0, 160.0, 1.6, np.random.default_rng(5))
    a, b = _grow(topo, False, seed, 400), _grow(topo, True, seed, 400)
    sa, sb = a.snake, b.snake
    np.testing.assert_array_equal(sb.ints, sa.ints)
    np.testing.assert_array_equal(sb.flts, sa.flts)
    np.testing.assert_array_equal(sb.state, sa.state)
    assert (sb.births, sb.merges, sb.holes, sb.filled) == (sa.births, sa.merges, sa.holes, sa.filled)
    assert sa.births > 300 and sa.merges > 0 and sa.holes > 0   # many events, merges and holes
    check_snake(b, None)                              # and the compiled chain is a valid snake
