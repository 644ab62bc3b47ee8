"""Exporter descriptor: a named, pure function from a domain to file bytes.

``FieldName`` marks an exporter option whose value is the name of a field of the exported
domain, so that ``procgen check`` verifies it against the recipe's fields before any compute
(an option whose name ends in ``field`` is read the same way without the marker).
"""
from __future__ import annotations

import inspect
import typing
from dataclasses import dataclass
from typing import Annotated, Any, Callable

from ..params import ParamInfo


class _NamesField:
    """The ``Annotated`` metadata of :data:`FieldName`."""

    def __repr__(self) -> str:
        return "FieldName"


NAMES_FIELD = _NamesField()
#: annotation of an exporter option that names a field: ``relief: FieldName = ""``
FieldName = Annotated[str, NAMES_FIELD]
#: annotation of an exporter option naming the model's up axis (previews' camera, GLB's +Y),
#: checked at ``procgen check``
UpAxis = Annotated[str, ParamInfo(choices=("x", "y", "z"))]


def field_options(func: Callable[..., Any]) -> dict[str, str]:
    """Exporter options that name a field -> their default ('' = none by default).

    An option names a field when it is annotated :data:`FieldName` or its name ends in ``field``.
    """
    try:
        hints = typing.get_type_hints(func, include_extras=True)
    except (NameError, TypeError):   # unresolvable annotations: fall back to the naming rule
        hints = {}
    out: dict[str, str] = {}
    for name, p in inspect.signature(func).parameters.items():
        marked = NAMES_FIELD in getattr(hints.get(name), "__metadata__", ())
        if marked or name.endswith("field"):
            out[name] = p.default if isinstance(p.default, str) else ""
    return out


@dataclass(frozen=True)
class Exporter:
    """``func(domain, *, stem, provenance, **options) -> bytes | dict[str, bytes]``.

    ``kinds`` lists the domain kinds it accepts (checked by ``procgen check``); ``suffix`` is
    appended to the output stem when the recipe gives no file name.
    """

    name: str
    kinds: tuple[str, ...]
    suffix: str
    func: Callable[..., Any]
    doc: str = ""
    options: tuple[str, ...] = ()

    def accepts(self, kind_cls: type) -> bool:
        from ..domains import is_kind

        return any(is_kind(kind_cls, k) for k in self.kinds)
