"""Hook implementations that register this family's rules with procgen."""
from procgen import hookimpl


@hookimpl
def procgen_register_rules():
    return []
