"""Poisson-disk + Delaunay tessellation for code paths that grow clouds outside a recipe step
(cloudscapes, benchmarks, tests). Recipes use the core rules points.poisson_disk + mesh.delaunay,
which call the same sampler and the same Qhull triangulation."""
from __future__ import annotations

import numpy as np

from .topology import Topology, build_topology


def poisson_tessellation(width: float, height: float, radius: float, rng: np.random.Generator,
                         origin: tuple[float, float] = (0.0, 0.0)) -> Topology:
    from scipy.spatial import Delaunay

    from procgen.builtin.poisson import poisson_disk

    pts = poisson_disk(rng, (width, height), radius, origin=origin)
    return build_topology(pts, Delaunay(pts).simplices)
