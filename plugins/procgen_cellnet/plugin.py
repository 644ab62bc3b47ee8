"""Hook implementations that register the cellular-network family and ship its recipes and
gallery list, as any outside plugin does.

Importing the network module registers the ``CellNetwork`` domain kind as soon as the plugin is
loaded, so ``State.load`` and the recipe checker know it before any rule runs.
"""
from procgen import hookimpl
from procgen.data import shipping_hooks

from . import network as _network  # noqa: F401  (registers the CellNetwork domain kind)


@hookimpl
def procgen_register_rules():
    from .activation import ActivatorInhibitor
    from .build import CellLinking, CellSeeding, PolygonMesh
    from .colour import (ColorFromField, ColorSpreading, LabelColors, RandomColorSeeds,
                         StateSetting)
    from .corrosion import CorrosionCountdown
    from .cracks import CrackDerivative
    from .harmonize import LinkPruning, NetworkHarmonization
    from .melting import MeltingAverage
    from .parallel import ParallelBehaviours, Regrouping
    from .parts import MeshParts
    from .views import BoxCubes, BoxSearchRoles, CellRaster, ForceCurve, NetworkLines
    from .watercolour import WatercolorBrush, WatercolorFlow
    return [PolygonMesh, CellSeeding, CellLinking, NetworkHarmonization, LinkPruning, StateSetting,
            RandomColorSeeds, LabelColors, ColorFromField, ColorSpreading, CrackDerivative, CorrosionCountdown,
            MeltingAverage, WatercolorBrush, WatercolorFlow, ActivatorInhibitor, NetworkLines,
            BoxCubes, BoxSearchRoles, ForceCurve, CellRaster, Regrouping, ParallelBehaviours, MeshParts]


@hookimpl
def procgen_register_exporters():
    from .exporters import EXPORTERS
    return list(EXPORTERS)


procgen_recipe_dirs, procgen_gallery_lists = shipping_hooks(__file__, ("cellnet",), ("cellnet.toml",))
