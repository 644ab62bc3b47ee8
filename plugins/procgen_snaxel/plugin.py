"""Hook implementations that register this family's rules and exporters with procgen."""
from procgen import hookimpl


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
