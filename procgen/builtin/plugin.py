"""Registers the built-in rules and exporters through the same hooks as any outside plugin."""
from __future__ import annotations

from ..hookspecs import hookimpl


@hookimpl
def procgen_register_rules():
    from ..ca.lifelike import LifeLike
    from ..ca.majority import Majority
    from ..ca.propagation import VoronoiPropagation
    from .grids import FractalNoise, GridToMesh
    from .lines import SmoothLines
    from .meshes import DelaunayTessellation, LoadMesh, MeshBoundary, MeshPrimitive
    from .points import PoissonDiskSampling
    from .solids import Extrude, Lathe

    return [PoissonDiskSampling, DelaunayTessellation, LoadMesh, MeshPrimitive, MeshBoundary,
            FractalNoise, GridToMesh, SmoothLines, Extrude, Lathe, LifeLike, VoronoiPropagation, Majority]


@hookimpl
def procgen_register_exporters():
    from ..exchange import BUILTIN_EXPORTERS

    return list(BUILTIN_EXPORTERS)


@hookimpl
def procgen_recipe_dirs():
    return []
