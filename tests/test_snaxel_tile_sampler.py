"""The tile sampler gives the same samples with and without numba (a cloud is the same on every
install): the numpy rounds against the compiled loop and against the loop run as plain Python,
tiles with fixed neighbours included, and a whole tiled cloud on both paths."""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial import cKDTree

from procgen.errors import InputError
from procgen_snaxel.growth import CloudGrowth
from procgen_snaxel.tile_poisson import sample_rounds, sample_tile, tile_sampler
from procgen_snaxel.tiles import TiledTopology

from test_snaxel_engine import small_cfg

numba_mod = pytest.importorskip("procgen_snaxel.tile_poisson_numba")


def _args(seed: int, side: float, r: float, fixed: np.ndarray, origin=(16.0, -8.0)):
    n = math.ceil(side * math.sqrt(2.0) / r)
    x0, y0 = origin
    u = np.random.default_rng(seed).random(24 * n * n)
    return (u, x0, y0, math.nextafter(x0 + side, -math.inf), math.nextafter(y0 + side, -math.inf), side, n, r,
            np.ascontiguousarray(fixed[:, 0]), np.ascontiguousarray(fixed[:, 1]))


def _neighbour(seed: int) -> np.ndarray:
    """Samples of the tile left of (16, -8), side 8, r 1: fixed points for the tile under test."""
    return sample_tile(np.random.default_rng(seed), (8.0, -8.0), 8.0, 1.0, accelerate=False)


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_numpy_rounds_equal_the_loop_run_as_plain_python(seed):
    fixed = _neighbour(seed + 10)
    a = _args(seed, 8.0, 1.0, fixed)
    ref, used = numba_mod.sample_rounds.py_func(*a)
    out, used_np = sample_rounds(*a)
    assert used > 0 and used_np == used                     # the same random numbers consumed
    assert out.tobytes() == ref.tobytes()                   # the same samples, in the same order
    # and they are a maximal Poisson-disk sample of the tile next to its fixed neighbours
    allp = np.vstack([fixed, out])
    d, _ = cKDTree(allp).query(allp, k=2)
    assert d[:, 1].min() >= 1.0
    g = np.linspace(16.0, 24.0, 161)[:-1]
    probe = np.stack(np.meshgrid(g, g - 24.0), axis=-1).reshape(-1, 2)
    assert cKDTree(allp).query(probe)[0].max() < 1.0


@pytest.mark.parametrize("seed", [4, 5])
def test_numpy_rounds_equal_the_compiled_loop(seed):
    for side, r in ((64.0, 4.0), (24.0, 1.5)):
        fixed = sample_tile(np.random.default_rng(seed), (16.0 - side, -8.0), side, r, accelerate=False)
        a = _args(seed, side, r, fixed)
        ref, used = numba_mod.sample_rounds(*a)
        out, used_np = sample_rounds(*a)
        assert used_np == used and out.tobytes() == ref.tobytes()
        assert len(out) > side * side / (2.0 * r * r)       # a tile full of samples, not a handful


def test_a_short_buffer_is_rerun_on_a_longer_prefix_of_the_same_stream():
    a = list(_args(6, 8.0, 1.0, np.zeros((0, 2))))
    full, used = sample_rounds(*a)
    a[0] = a[0][:used - 1]
    assert sample_rounds(*a)[1] == -1 and numba_mod.sample_rounds(*a)[1] == -1


def test_a_tiled_cloud_is_the_same_with_and_without_numba():
    runs = []
    for accelerate in (False, True):
        topo = TiledTopology(1.6, 16.0, np.random.SeedSequence(9))
        topo.accelerate = accelerate
        g = CloudGrowth(topo, small_cfg(max_steps=80, source=[0.0, 0.0]), np.random.default_rng(3))
        while g.step():
            pass
        runs.append((topo.points.tobytes(), g.snake.xy().tobytes(), topo.n_tiles))
    assert runs[0] == runs[1] and runs[0][2] >= 9


def test_the_switch_picks_the_path(monkeypatch):
    monkeypatch.setenv("PROCGEN_ACCELERATE", "0")
    assert tile_sampler() == "numpy"
    monkeypatch.setenv("PROCGEN_ACCELERATE", "1")
    assert tile_sampler() == "numba"
    assert tile_sampler(False) == "numpy"


def test_accelerate_without_numba_names_the_extra(monkeypatch):
    import procgen.accel as accel

    monkeypatch.setattr(accel, "_load", lambda module: None)
    with pytest.raises(InputError, match="fast"):
        sample_tile(np.random.default_rng(0), (0.0, 0.0), 8.0, 1.0, accelerate=True)
    assert len(sample_tile(np.random.default_rng(0), (0.0, 0.0), 8.0, 1.0)) > 20   # None: the numpy path


def test_a_recipe_cloud_is_byte_identical_with_and_without_numba(tmp_path, host, monkeypatch):
    """End to end through snaxel.grow: compiled tiles (and with them compiled events) against
    PROCGEN_ACCELERATE=0 (numpy tiles, numpy events): the same files."""
    import json

    from test_snaxel_rules import grow

    fast = grow(tmp_path, host, {"n_c": 1}, seed=3, out="fast")
    monkeypatch.setenv("PROCGEN_ACCELERATE", "0")
    grow(tmp_path, host, {"n_c": 1}, seed=3, out="slow")
    reports = {k: json.loads((tmp_path / k / "run.json").read_text())["reports"] for k in ("fast", "slow")}
    assert reports["fast"]["cloud.tile_sampler"] == "numba" and reports["slow"]["cloud.tile_sampler"] == "numpy"
    assert fast.state.reports["cloud.births"] > 100
    files = sorted(p.name for p in (tmp_path / "fast").iterdir() if p.name != "run.json")
    assert files and files == sorted(p.name for p in (tmp_path / "slow").iterdir() if p.name != "run.json")
    for name in files:
        assert (tmp_path / "fast" / name).read_bytes() == (tmp_path / "slow" / name).read_bytes(), name
