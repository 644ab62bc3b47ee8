"""Exporter descriptor: a named, pure function from a domain to file bytes."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable


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
