"""Hook implementations that register this family's rules with procgen."""
from procgen import hookimpl


@hookimpl
def procgen_register_rules():
    from .rules import RULES
    return list(RULES)


@hookimpl
def procgen_register_exporters():
    from .exporters import EXPORTERS
    return list(EXPORTERS)
