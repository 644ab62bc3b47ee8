"""Hook implementations that register this family's rules with procgen.

Importing the domain module here registers the ``SurfaceCells`` kind as soon as the plugin is
loaded, so ``State.load`` can read saved states before any rule is looked up.
"""
from procgen import hookimpl

from . import domain as _domain  # noqa: F401  (registers the SurfaceCells domain kind)


@hookimpl
def procgen_register_rules():
    from .rules import (BuildCells, CupPrimitive, LatticePrimitive, RevolvePrimitive, ShadeCells,
                        SurfaceCorrosion, SurfaceLayers)
    return [CupPrimitive, RevolvePrimitive, LatticePrimitive, BuildCells, SurfaceLayers,
            SurfaceCorrosion, ShadeCells]


@hookimpl
def procgen_register_exporters():
    from .exporters import EXPORTERS
    return list(EXPORTERS)
