"""Registers the built-in rules and exporters through the same hooks as any outside plugin."""
from __future__ import annotations

from ..hookspecs import hookimpl


@hookimpl
def procgen_register_rules():
    from .grids import FractalNoise, GridToMesh
    from .lines import LoadLines, SmoothLines
    from .loaders import GridImageField, LoadGrid, MeshImageField
    from .meshes import DelaunayTessellation, LoadMesh, MeshBoundary, MeshPrimitive
    from .points import PoissonDiskSampling
    from .solids import Extrude, Lathe

    return [PoissonDiskSampling, DelaunayTessellation, LoadMesh, MeshPrimitive, MeshBoundary,
            FractalNoise, GridToMesh, SmoothLines, Extrude, Lathe,
            LoadGrid, GridImageField, MeshImageField, LoadLines]


@hookimpl
def procgen_register_exporters():
    from ..exchange import BUILTIN_EXPORTERS
    from ..exchange.geotiff import GEOTIFF_EXPORTER

    return [*BUILTIN_EXPORTERS, GEOTIFF_EXPORTER]


@hookimpl
def procgen_recipe_dirs():
    return []
