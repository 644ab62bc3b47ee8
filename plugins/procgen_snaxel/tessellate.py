"""A whole-rectangle Poisson-disk + Delaunay tessellation for code that grows clouds outside a
recipe (tests, benchmarks): the same sampler and Qhull triangulation as the core rules
points.poisson_disk + mesh.delaunay, eagerly, as the thesis does (section 3.1)."""
from __future__ import annotations

import numpy as np

from procgen import TriMesh

from .topology import Topology, mesh_topology


def poisson_tessellation(width: float, height: float, radius: float, rng: np.random.Generator,
                         origin: tuple[float, float] = (0.0, 0.0)) -> Topology:
    from scipy.spatial import Delaunay

    from procgen.builtin.poisson import poisson_disk

    pts = poisson_disk(rng, (width, height), radius, origin=origin)
    return mesh_topology(TriMesh(pts, Delaunay(pts).simplices))
