"""The cracks-and-peeling family's hooks: its rules and exporters, and its gallery list."""
from procgen import hookimpl
from procgen.data import shipping_hooks


@hookimpl
def procgen_register_rules():
    from .bake import CrackBake
    from .imposed import ImposedCracks
    from .peel import Peel
    from .render_rules import RULES as RENDER_RULES
    from .rules import RULES
    from .flowers3d import RULES as FLOWER_RULES
    from .series import RULES as SERIES_RULES
    return [*RULES, *RENDER_RULES, *SERIES_RULES, *FLOWER_RULES, ImposedCracks, Peel, CrackBake]


@hookimpl
def procgen_register_exporters():
    from .exporters import EXPORTERS as RENDER_EXPORTERS
    from .series import EXPORTERS as SERIES_EXPORTERS
    return [*RENDER_EXPORTERS, *SERIES_EXPORTERS]


procgen_recipe_dirs, procgen_gallery_lists = shipping_hooks(__file__, (), ("cracks.toml",))
