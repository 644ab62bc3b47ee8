"""Hook implementations that register this family's rules with procgen and ship its
recipes and gallery list, as any outside plugin does.

Importing the domain module here registers the ``SurfaceCells`` kind as soon as the plugin is
loaded, so ``State.load`` can read saved states before any rule is looked up.
"""
from procgen import hookimpl
from procgen.data import shipping_hooks

from . import domain as _domain  # noqa: F401  (registers the SurfaceCells domain kind)


@hookimpl
def procgen_register_rules():
    from .bake import BakeAtlas
    from .cell_mesh_rule import CellMeshRule
    from .image import SurfaceImageField
    from .rules import BuildCells, CupPrimitive, LatticePrimitive
    return [CupPrimitive, LatticePrimitive, BuildCells, SurfaceImageField, BakeAtlas, CellMeshRule]


@hookimpl
def procgen_register_exporters():
    from .exporters import EXPORTERS
    return list(EXPORTERS)


procgen_recipe_dirs, procgen_gallery_lists = shipping_hooks(__file__, ("meshes",), ("meshes.toml",))
