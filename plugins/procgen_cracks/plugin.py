"""The cracks-and-peeling family's hooks: its rules and exporters, and its gallery list."""
from procgen import hookimpl
from procgen.data import shipping_hooks


@hookimpl
def procgen_register_rules():
    from .imposed import ImposedCracks
    from .peel import Peel
    from .rules import RULES
    return [*RULES, ImposedCracks, Peel]


@hookimpl
def procgen_register_exporters():
    return []


procgen_recipe_dirs, procgen_gallery_lists = shipping_hooks(__file__, (), ("cracks.toml",))
