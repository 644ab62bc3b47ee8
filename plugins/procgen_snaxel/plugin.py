"""Hook implementations that register this family's rules and exporters with procgen
and ship its recipes and gallery list, as any outside plugin does."""
from pathlib import Path

from procgen import hookimpl
from procgen.data import plugin_gallery_lists, plugin_recipe_dirs


@hookimpl
def procgen_register_rules():
    from .rules import Cloudscape, GrowCloud

    return [GrowCloud, Cloudscape]


@hookimpl
def procgen_register_exporters():
    from procgen import Exporter

    from .exporters import EXPORTERS

    return [Exporter(name=name, kinds=("Polylines",), suffix=suffix, func=func, doc=doc)
            for name, suffix, func, doc in EXPORTERS]


@hookimpl
def procgen_recipe_dirs():
    return plugin_recipe_dirs(Path(__file__).parent, "clouds")


@hookimpl
def procgen_gallery_lists():
    return plugin_gallery_lists(Path(__file__).parent, "clouds.toml")
