"""Hook implementations that register the cellular-network family.

Importing the network module registers the ``CellNetwork`` domain kind as soon as the plugin is
loaded, so ``State.load`` and the recipe checker know it before any rule runs.
"""
from procgen import hookimpl

from . import network as _network  # noqa: F401  (registers the CellNetwork domain kind)


@hookimpl
def procgen_register_rules():
    from .build import CellLinking, CellSeeding, PolygonMesh
    return [PolygonMesh, CellSeeding, CellLinking]
