"""The wood-weathering family's hooks: its rules (grain, texture mapping, age colour, exposure,
the table stand-in, the link points of Fig. 4.7), the cell-diagram exporters, and its recipes
and gallery list."""
from procgen import hookimpl
from procgen.data import shipping_hooks


@hookimpl
def procgen_register_rules():
    from .links import LinkPoints
    from .rules import AgeColour, Exposure, WoodGrain, WoodMap, WoodTable
    return [WoodGrain, WoodMap, AgeColour, Exposure, WoodTable, LinkPoints]


@hookimpl
def procgen_register_exporters():
    from .diagram import EXPORTERS
    return list(EXPORTERS)


procgen_recipe_dirs, procgen_gallery_lists = shipping_hooks(__file__, ("weathering",), ("weathering.toml",))
