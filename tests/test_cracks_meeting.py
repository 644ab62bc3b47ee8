"""Plate 5.10 (3DSCA thesis 5.2.6.e, mud): crack ends meet other cracks at about a right angle.

Drying mud's cracks meet in T junctions; the model's way to them is the stress release across
a crack's path (thesis 5.2.4.c), which leaves only the stress along the crack, so that a head
entering the released band turns across it.  The angle is recomputed here from the output
polylines alone, independently of ``cracks.meeting_angle_deg``: each free crack end within 1.5
cells of another crack's path (exact point-to-segment distance), the end's direction taken over
its last cell of path, against the direction of the nearest segment of that other crack.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from procgen.recipes import load_recipe
from procgen.runner import run


def _mud(host, steer: str):
    recipe = load_recipe("meshes/plate-5-10", host, ["steps.cells.params.target_cells=15000",
                                                     f"steps.cracks.params.steer={steer}"])
    cut = next(i for i, s in enumerate(recipe.steps) if s.id == "cracks")
    recipe = dataclasses.replace(recipe, steps=recipe.steps[:cut + 1], outputs=[])
    state = run(recipe, host, seed=1, progress=False).state
    return state.domains["cracks"], float(state.domains["cells"].size)


def _meeting_angles(points: np.ndarray, offsets: np.ndarray, size: float) -> np.ndarray:
    n = len(offsets) - 1
    first, last = offsets[:-1], offsets[1:] - 1
    # lines touching end to end (facet crossings, forks, the heads of one birth) are one crack
    tips = np.concatenate([first, last])
    key = np.unique(np.round(points[tips] / (1e-6 * size)).astype(np.int64), axis=0,
                    return_inverse=True)[1].ravel()
    line = np.concatenate([np.arange(n), np.arange(n)])
    graph = coo_matrix((np.ones(2 * n), (line, n + key)), shape=(n + key.max() + 1,) * 2)
    crack = connected_components(graph, directed=False)[1][:n]
    shared = np.bincount(key)[key] > 1
    line_of = np.repeat(np.arange(n), np.diff(offsets))
    seg = np.nonzero(line_of[:-1] == line_of[1:])[0]
    a, ab = points[seg], points[seg + 1] - points[seg]
    angles = []
    for li in np.nonzero(~shared[n:] & (np.diff(offsets) >= 2))[0]:
        end = points[last[li]]
        # the end's direction over its last cell of path
        path = points[first[li]:last[li] + 1][::-1]
        back = np.cumsum(np.r_[0.0, np.linalg.norm(np.diff(path, axis=0), axis=1)])
        j = min(int(np.searchsorted(back, size)), len(path) - 1)
        u = end - path[j]
        other = crack[line_of[seg]] != crack[li]
        t = np.clip(np.einsum("md,md->m", end - a, ab) / np.maximum(np.einsum("md,md->m", ab, ab), 1e-300), 0, 1)
        dist = np.where(other, np.linalg.norm(a + t[:, None] * ab - end, axis=1), np.inf)
        k = int(np.argmin(dist))
        if dist[k] < 1.5 * size:
            c = abs(u @ ab[k]) / (np.linalg.norm(u) * np.linalg.norm(ab[k]))
            angles.append(np.degrees(np.arccos(min(c, 1.0))))
    return np.asarray(angles)


@pytest.fixture(scope="module")
def meetings(host):
    out = {}
    for steer in ("any", "unstable"):
        pl, size = _mud(host, steer)
        out[steer] = _meeting_angles(np.asarray(pl.points), np.asarray(pl.offsets), size)
    return out


def test_mud_cracks_meet_at_about_a_right_angle(meetings):
    """The plate-5.10 recipe (15,000 cells here): the median meeting angle within 60-90 degrees
    (64 at this size; the run's own report: 72.5 at the gallery's 60,000 cells), and the largest decile of angles
    (80-90) the most populated."""
    ang = meetings["any"]
    assert len(ang) > 100
    assert 60.0 <= np.median(ang) <= 90.0
    hist = np.histogram(ang, bins=np.arange(0, 91, 10))[0]
    assert hist.argmax() == 8


def test_steering_only_above_mr_meets_at_shallower_angles(meetings):
    """The cause: with CMs turned only by stress above mR (steer = "unstable"), heads coast on
    K straight through the released band along a crack and meet it at whatever angle they
    had: the median falls by more than 10 degrees (46 against 64 at this size)."""
    assert np.median(meetings["unstable"]) < np.median(meetings["any"]) - 10.0
