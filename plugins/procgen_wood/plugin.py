"""Hook implementations that register the wood-weathering rules with procgen."""
from procgen import hookimpl


@hookimpl
def procgen_register_rules():
    from .rules import RULES
    return list(RULES)


@hookimpl
def procgen_register_exporters():
    from .diagram import EXPORTERS
    return list(EXPORTERS)
