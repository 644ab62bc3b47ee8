"""Hook implementations that register this family's rules with procgen."""
from procgen import hookimpl


@hookimpl
def procgen_register_rules():
    from .rules import (BuildCells, CupPrimitive, LatticePrimitive, RevolvePrimitive, ShadeCells,
                        SurfaceCorrosion, SurfaceLayers, SurfaceVoronoi)
    return [CupPrimitive, RevolvePrimitive, LatticePrimitive, BuildCells, SurfaceLayers, SurfaceVoronoi,
            SurfaceCorrosion, ShadeCells]


@hookimpl
def procgen_register_exporters():
    from .exporters import EXPORTERS
    return list(EXPORTERS)
