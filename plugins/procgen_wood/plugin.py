"""Hook implementations that register the wood-weathering rules with procgen and ship its
recipes and gallery list, as any outside plugin does."""
from pathlib import Path

from procgen import hookimpl
from procgen.data import plugin_gallery_lists, plugin_recipe_dirs


@hookimpl
def procgen_register_rules():
    from .rules import RULES
    return list(RULES)


@hookimpl
def procgen_register_exporters():
    from .diagram import EXPORTERS
    return list(EXPORTERS)


@hookimpl
def procgen_recipe_dirs():
    return plugin_recipe_dirs(Path(__file__).parent, "weathering")


@hookimpl
def procgen_gallery_lists():
    return plugin_gallery_lists(Path(__file__).parent, "weathering.toml")
