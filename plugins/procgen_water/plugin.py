"""Hook implementations that register this family's rules with procgen and ship its
recipes and gallery list, as any outside plugin does."""
from procgen import hookimpl
from procgen.data import shipping_hooks


@hookimpl
def procgen_register_rules():
    from .rules import RULES
    return list(RULES)


@hookimpl
def procgen_register_exporters():
    from .exporters import EXPORTERS
    return list(EXPORTERS)


procgen_recipe_dirs, procgen_gallery_lists = shipping_hooks(__file__, ("terrain",), ("terrain.toml",))
