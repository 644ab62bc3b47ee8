"""Harmonized cells put back on the source polygons (closest point), seed 002 section 4.4."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from procgen import check_recipe, get_plugin_manager, run
from procgen_cellnet.projection import closest_on_mesh, closest_on_triangles


def test_closest_points_match_every_triangle_and_a_dense_sample():
    rng = np.random.default_rng(0)
    m = trimesh.creation.icosphere(2)
    v, f = np.asarray(m.vertices), np.asarray(m.faces)
    p = rng.normal(size=(200, 3)) * 0.8
    q, face, d = closest_on_mesh(p, v, f)
    tri = v[f]
    allq = closest_on_triangles(np.repeat(p, len(f), 0), *(np.tile(tri[:, k], (len(p), 1)) for k in range(3)))
    alld = np.linalg.norm(allq.reshape(len(p), len(f), 3) - p[:, None], axis=2)
    assert np.allclose(d, alld.min(axis=1), atol=1e-12)
    assert np.allclose(np.linalg.norm(q - p, axis=1), d)
    # one triangle against 100k points sampled on it: never farther, at most the sample spacing
    a, b, c = tri[0]
    uv = rng.random((100_000, 2))
    uv[uv.sum(1) > 1] = 1 - uv[uv.sum(1) > 1]
    sample = a + uv[:, :1] * (b - a) + uv[:, 1:] * (c - a)
    pts = rng.normal(size=(40, 3))
    cq = closest_on_triangles(pts, *(np.tile(x, (40, 1)) for x in (a, b, c)))
    ref = np.linalg.norm(sample[None] - pts[:, None], axis=2).min(axis=1)
    gap = np.linalg.norm(cq - pts, axis=1) - ref
    assert gap.max() <= 1e-12 and gap.min() > -5e-3


def _harmonized(surface):
    host = get_plugin_manager()
    params = {"iterations": 15, "rule": "cellnet.harmonize", "params": {"dt": 0.3}}
    if surface:
        params["params"]["surface"] = "mesh"
    steps = [{"rule": "mesh.primitive", "params": {"shape": "icosphere", "subdivisions": 2}},
             {"rule": "cellnet.seed", "params": {"target_cells": 600, "grid": "random"}},
             {"rule": "cellnet.link"}, params]
    state = run(check_recipe({"steps": steps}, host, "t.toml"), host, seed=2, progress=False).state
    net, mesh = state.domains["cells"], state.domains["mesh"]
    return net, closest_on_mesh(net.positions, mesh.vertices, mesh.faces)[2]


def test_reprojected_cells_stay_on_the_surface():
    net, d = _harmonized(True)
    assert d.max() < 1e-9 * net.cs
    _, lifted = _harmonized(False)
    assert lifted.max() > 1e-3 * net.cs              # tangent moves alone leave the sphere


@pytest.mark.parametrize("mode", ["vertex", "face"])
def test_reprojected_cells_take_the_surface_normal_at_their_new_position(mode):
    """After re-projection a cell's normal is the source surface's at the cell (section 3.3):
    interpolated normals agree with the analytic sphere normal p/|p| to the interpolation
    error, face normals equal the normal of the face the cell now lies on."""
    host = get_plugin_manager()
    steps = [{"rule": "mesh.primitive", "params": {"shape": "icosphere", "subdivisions": 3}},
             {"rule": "cellnet.seed", "params": {"target_cells": 1500, "grid": "random",
                                                 "normals": mode}},
             {"rule": "cellnet.link"}]
    seeded = run(check_recipe({"steps": steps}, host, "t.toml"), host, seed=2,
                 progress=False).state.domains["cells"]
    steps.append({"rule": "cellnet.harmonize", "iterations": 15,
                  "params": {"dt": 0.3, "surface": "mesh"}})
    state = run(check_recipe({"steps": steps}, host, "t.toml"), host, seed=2, progress=False).state
    net, mesh = state.domains["cells"], state.domains["mesh"]
    assert net.normal_mode == mode
    moved = np.linalg.norm(net.positions - seeded.positions, axis=1)
    assert np.median(moved) > 0.05 * net.cs                   # harmonization did move the cells
    n = np.asarray(net["cell__normal"])
    assert np.allclose(np.linalg.norm(n, axis=1), 1.0)
    true = net.positions / np.linalg.norm(net.positions, axis=1, keepdims=True)
    err = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", n, true), -1, 1)))
    stale = np.degrees(np.arccos(np.clip(np.einsum("ij,ij->i", np.asarray(seeded["cell__normal"]),
                                                   true), -1, 1)))
    if mode == "vertex":
        assert err.max() < 1.0                                 # icosphere(3): edges ~ 9 degrees
        assert err.mean() < 0.5 * stale.mean()                 # the seeded normals are stale
    else:
        _, face, _ = closest_on_mesh(net.positions, mesh.vertices, mesh.faces)
        tri = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
        fn = np.asarray(tri.face_normals)[face]
        # the face normal of the face under the cell (on an edge either face: both are close)
        assert np.percentile(np.einsum("ij,ij->i", n, fn), 1) > 1 - 1e-12
        assert err.max() < 8.0
