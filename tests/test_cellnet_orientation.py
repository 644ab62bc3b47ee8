"""Polygon orientation at scale (seed 002 section 3.3, Figure 8): shared boundary runs found by
sorting edges by supporting line, checked against every pair and against known normals."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from procgen_cellnet.orientation import collinear_runs, loop_normal, orient_polygons, shared_runs, wound


def _wound(polys):
    return [wound([np.asarray(lp, float) for lp in loops], loop_normal(np.asarray(loops[0], float)))
            for loops in polys]


def _flipped_at_random(polys, rng):
    return _wound([[lp[::-1] for lp in loops] if rng.random() < 0.5 else loops
                   for loops in polys])


def tiled_cube(k: int, split: float, rng) -> tuple[np.ndarray, np.ndarray]:
    """A cube whose faces are k x k squares, a share ``split`` of them cut into four (their
    edges meet the whole edges of uncut neighbours at T-junctions): (m, 4, 3) quads, each
    wound at random, and each quad's outward normal."""
    i, j = np.meshgrid(np.arange(k), np.arange(k), indexing="ij")
    cut = rng.random(k * k) < split
    corners = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    whole = np.stack([i.ravel()[~cut], j.ravel()[~cut]], 1)[:, None] + corners       # (., 4, 2)
    halves = np.array([[0, 0], [0.5, 0], [0, 0.5], [0.5, 0.5]])
    quarter = (np.stack([i.ravel()[cut], j.ravel()[cut]], 1)[:, None, None] + halves[:, None]
               + corners / 2).reshape(-1, 4, 2)
    flat = np.concatenate([whole, quarter]) * (2.0 / k) - 1.0
    quads, normals = [], []
    for axis in range(3):
        for side in (-1.0, 1.0):
            q = np.empty(flat.shape[:2] + (3,))
            q[..., axis] = side
            q[..., (axis + 1) % 3], q[..., (axis + 2) % 3] = flat[..., 0], flat[..., 1]
            quads.append(q)
            normals.append(np.tile(np.eye(3)[axis] * side, (len(flat), 1)))
    quads = np.concatenate(quads)
    back = rng.random(len(quads)) < 0.5
    quads[back] = quads[back][:, ::-1]
    return quads, np.concatenate(normals)


def _oriented_normals(loops: np.ndarray, flips: list[bool]) -> np.ndarray:
    """Newell normals of (m, k, 3) single-loop polygons after the flips."""
    return np.cross(loops, np.roll(loops, -1, axis=1)).sum(axis=1) * np.where(flips, -1, 1)[:, None]


def test_a_big_soup_with_t_junctions_faces_out_everywhere():
    rng = np.random.default_rng(12)
    quads, outward = tiled_cube(52, 0.15, rng)
    polys = [[q] for q in quads]            # one loop each: already wound about its normal
    assert len(polys) > 20_000
    normals = _oriented_normals(quads, orient_polygons(polys))
    assert np.all(np.einsum("ij,ij->i", normals, outward) > 0)


def test_a_big_triangle_soup_far_from_the_origin_faces_out_everywhere():
    rng = np.random.default_rng(13)
    m = trimesh.creation.icosphere(subdivisions=5)          # 20,480 triangles, every direction
    centre = np.array([3e4, -2e4, 1e4])
    tri = m.vertices[m.faces] * 10 + centre
    back = rng.random(len(tri)) < 0.5
    tri[back] = tri[back][:, ::-1]
    polys = [[t] for t in tri]
    normals = _oriented_normals(tri, orient_polygons(polys))
    assert len(polys) == 20_480
    assert np.all(np.einsum("ij,ij->i", normals, m.triangles_center) > 0)


def _all_pairs(a, b, owner, tol):
    """The shared runs by the exact test of every pair of edges (the quadratic reference)."""
    i, j = np.triu_indices(len(a), 1)
    return set(zip(*(x.tolist() for x in collinear_runs(a, b, owner, tol, i, j))))


@pytest.mark.parametrize("shape", ["cube", "sphere"])
def test_shared_runs_are_exactly_the_all_pairs_runs(shape):
    rng = np.random.default_rng(14)
    if shape == "cube":                 # axis-aligned runs, whole and partial (T-junctions)
        polys = [[q] for q in tiled_cube(6, 0.4, rng)[0]]
    else:                               # runs along every direction, rotated, off the origin
        m = trimesh.creation.icosphere(subdivisions=2)
        rot = trimesh.transformations.random_rotation_matrix(rng.random(3))[:3, :3]
        polys = _flipped_at_random([[m.vertices[f] @ rot.T + [7.0, -3.0, 2.0]] for f in m.faces], rng)
    a = np.concatenate([lp for loops in polys for lp in loops])
    b = np.concatenate([np.roll(lp, -1, axis=0) for loops in polys for lp in loops])
    owner = np.concatenate([np.full(sum(map(len, loops)), k) for k, loops in enumerate(polys)])
    tol = 1e-9 * float(np.ptp(a, axis=0).max())
    p, q, same = shared_runs(a, b, owner, tol)
    found = list(zip(p.tolist(), q.tolist(), same.tolist()))
    assert len(found) == len(set(found))                 # every run once
    ref = _all_pairs(a, b, owner, tol)
    assert len(ref) > 100 and set(found) == ref
    assert any(same) and not all(same)   # randomly flipped: runs walked both ways
