"""Hook implementations that register the layered-materials rules and terrain exporters with procgen."""
from procgen import hookimpl


@hookimpl
def procgen_register_rules():
    from .rules import RULES
    return list(RULES)


@hookimpl
def procgen_register_exporters():
    from .terrain_export import EXPORTERS
    return list(EXPORTERS)
