"""Hook implementations that register this family's rules and exporters with procgen
and ship its recipes and gallery list, as any outside plugin does."""
from procgen import hookimpl
from procgen.data import shipping_hooks


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


procgen_recipe_dirs, procgen_gallery_lists = shipping_hooks(__file__, ("clouds",), ("clouds.toml",))
