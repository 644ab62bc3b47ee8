"""Harmonized cells put back on the source polygons (closest point), seed 002 section 4.4."""
from __future__ import annotations

import numpy as np
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
