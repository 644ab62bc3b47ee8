"""The numpy 27-box search (seed 002 section 4.2-4.3, Figure 3): links identical to cKDTree's
and brute force whatever the sweep axis, and exactly the stencil's links when boxes are small."""
from __future__ import annotations

import math

import numpy as np
import pytest

from procgen_cellnet.boxes import BoxIndex, pairs_brute, pairs_kdtree, pairs_within


def _layout(name: str, rng) -> np.ndarray:
    if name == "sphere":                 # a closed surface: every sweep direction mixed
        p = rng.normal(size=(3000, 3))
        return p / np.linalg.norm(p, axis=1)[:, None] * 9.0
    if name == "tall":                   # longest along z: the sweep runs along the z columns
        t = rng.random(3000) * 2 * np.pi
        return np.column_stack([3 * np.cos(t), 3 * np.sin(t), rng.random(3000) * 60])
    if name == "wall":                   # a plane x = const, negative box indices
        return np.column_stack([np.full(3000, -3.3), rng.random((3000, 2)) * [-40, 30]])
    # a lattice with exact ties: repeated points, pairs at exactly the radius, box faces
    g = np.stack(np.meshgrid(*[np.arange(12.0)] * 2, [0.0, 1.0], indexing="ij"), -1).reshape(-1, 3)
    return np.concatenate([g, g[:40]]) * 0.5


@pytest.mark.parametrize("layout", ["sphere", "tall", "wall", "ties"])
def test_numpy_search_links_equal_cKDTree_and_brute_force(layout):
    p = _layout(layout, np.random.default_rng(21))
    r = 1.0 if layout == "ties" else math.sqrt(3) - 0.01
    links = pairs_within(p, r, BoxIndex.build(p, 2.0), accelerate=False)
    assert len(links) > 1000
    assert np.array_equal(links, pairs_kdtree(p, r))
    assert np.array_equal(links, pairs_brute(p, r))


@pytest.mark.parametrize("layout", ["sphere", "tall", "wall", "ties"])
def test_small_boxes_give_exactly_the_27_box_links(layout):
    """kb = 1 with guard off: the links of the 27 boxes, no more (brute force cut to partners
    at most one box away on every axis) - the numpy and compiled searches alike."""
    p = _layout(layout, np.random.default_rng(22))
    r, size = 1.7, 1.0
    keys = np.floor(p / size).astype(np.int64)
    ref = pairs_brute(p, r)
    ref = ref[np.all(np.abs(keys[ref[:, 0]] - keys[ref[:, 1]]) <= 1, axis=1)]
    idx = BoxIndex.build(p, size)
    got = pairs_within(p, r, idx, guard=False, accelerate=False)
    assert len(got) < len(pairs_brute(p, r)) and np.array_equal(got, ref)
    pytest.importorskip("numba")
    assert np.array_equal(pairs_within(p, r, idx, guard=False, accelerate=True), ref)
