"""The angle at which crack ends meet other cracks, from output polylines alone.

An independent recomputation of ``cracks.meeting_angle_deg`` (thesis 5.2.4.c and plate 5.5:
a head entering another crack's released band turns across it and meets it at about a right
angle).  Lines touching end to end (facet crossings, forks, the heads of one birth) are one
crack; a line's last point that no other line shares is a crack end; where it lies within 1.5
cells of another crack's path (exact point-to-segment distance, in 3-D) the end met that
crack, and the angle is the one between the end's direction, taken over its last cell of
path, and the nearest segment of the other crack.
"""
from __future__ import annotations

import dataclasses

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from procgen.recipes import load_recipe
from procgen.runner import run


def meeting_angles(points: np.ndarray, offsets: np.ndarray, size: float) -> np.ndarray:
    """Angles (degrees, 0-90) of the crack ends that meet another crack."""
    n = len(offsets) - 1
    first, last = offsets[:-1], offsets[1:] - 1
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
    for li in np.nonzero(~shared[n:] & (np.diff(offsets) >= 2))[0]:      # per crack end
        end = points[last[li]]
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


def plate_angles(host, recipe: str, overrides: list[str], seed: int | None = None,
                 step: str = "cracks") -> tuple[np.ndarray, dict]:
    """Run a recipe up to its crack step ``step`` and measure its crack ends' meeting angles;
    also returns the run's reports."""
    rec = load_recipe(recipe, host, overrides)
    cut = next(i for i, s in enumerate(rec.steps) if s.id == step)
    rec = dataclasses.replace(rec, steps=rec.steps[:cut + 1], outputs=[])
    state = run(rec, host, seed=rec.seed if seed is None else seed, progress=False).state
    rule = rec.steps[cut].rule
    pl, cells = state.domains[rule.lines], state.domains[rule.cells]
    ang = meeting_angles(np.asarray(pl.points), np.asarray(pl.offsets), float(cells.size))
    return ang, dict(state.reports)
