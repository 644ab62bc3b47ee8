"""Registers the built-in rules and exporters through the same hooks as any outside plugin."""
from __future__ import annotations

from pathlib import Path

from ..data import plugin_gallery_lists, plugin_recipe_dirs
from ..hookspecs import hookimpl


@hookimpl
def procgen_register_rules():
    from ..ca.lifelike import LifeLike
    from ..ca.majority import Majority
    from ..ca.propagation import VoronoiPropagation
    from .grids import FractalNoise, GridToMesh
    from .lines import LoadLines, SmoothLines
    from .loaders import GridImageField, LoadGrid, MeshImageField
    from .meshes import DelaunayTessellation, LoadMesh, MeshBoundary, MeshPrimitive
    from .points import PoissonDiskSampling
    from .solids import Extrude, Lathe

    return [PoissonDiskSampling, DelaunayTessellation, LoadMesh, MeshPrimitive, MeshBoundary,
            FractalNoise, GridToMesh, SmoothLines, Extrude, Lathe, LifeLike, VoronoiPropagation,
            Majority, LoadGrid, GridImageField, MeshImageField, LoadLines]


@hookimpl
def procgen_register_exporters():
    from ..exchange import BUILTIN_EXPORTERS
    from ..exchange.geotiff import GEOTIFF_EXPORTER

    return [*BUILTIN_EXPORTERS, GEOTIFF_EXPORTER]


@hookimpl
def procgen_recipe_dirs():
    # demo: the core's own rules; chains and data (users' own files): recipes crossing families
    # (an entry needing a disabled family is left out of the gallery with a note; its recipe
    # fails `procgen check` by name)
    return plugin_recipe_dirs(Path(__file__).parent, "demo", "chains", "data")


@hookimpl
def procgen_gallery_lists():
    return plugin_gallery_lists(Path(__file__).parent, "gallery.toml", "chains.toml", "data.toml")
