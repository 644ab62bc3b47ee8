"""Field declarations: what a rule reads and writes, on which domain and location.

Fields couple rules the way landlab couples components: by name (``thing__quantity``), never
by object references, so the recipe checker can follow the data flow before anything runs.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Literal

Location = Literal["cell", "point", "vertex", "edge", "face", "line", "domain"]
Intent = Literal["in", "out", "inout"]

LOCATIONS: tuple[str, ...] = ("cell", "point", "vertex", "edge", "face", "line", "domain")
INTENTS: tuple[str, ...] = ("in", "out", "inout")
_NAME = re.compile(r"^[a-z][a-z0-9_]*__[a-z0-9_]+$")


def check_field_name(name: str) -> None:
    """Raise ValueError unless ``name`` follows the ``thing__quantity`` convention."""
    if not _NAME.match(name):
        raise ValueError(f"field name {name!r} must look like 'thing__quantity' (lower case, one '__')")


@dataclass(frozen=True)
class FieldSpec:
    """One field a rule touches.

    ``domain`` (and ``name``) may contain ``{param}`` placeholders filled from the rule's
    parameters, so a rule can act on a domain or field the recipe names.
    """

    name: str
    domain: str
    at: Location
    intent: Intent = "inout"
    dtype: str = "float64"
    units: str = ""
    doc: str = ""

    def __post_init__(self) -> None:
        if "{" not in self.name:
            check_field_name(self.name)
        if self.at not in LOCATIONS:
            raise ValueError(f"field {self.name!r}: location {self.at!r} not in {LOCATIONS}")
        if self.intent not in INTENTS:
            raise ValueError(f"field {self.name!r}: intent {self.intent!r} not in {INTENTS}")

    def resolve(self, params: dict[str, object]) -> "FieldSpec":
        """Return a copy whose domain placeholders are filled from ``params``."""
        if "{" not in self.domain and "{" not in self.name:
            return self
        return FieldSpec(self.name.format(**params), self.domain.format(**params), self.at, self.intent,
                         self.dtype, self.units, self.doc)


@dataclass(frozen=True)
class FieldInfo:
    """Metadata kept beside a field's array on a domain."""

    at: str
    units: str = ""
    doc: str = ""


class UnitsLedger:
    """Units each (domain, field) was declared with so far in a chain of rules.

    A field name means one thing with one unit everywhere (docs/fields.md); two steps declaring
    one field of one domain in different units is a broken coupling, caught before anything runs.
    """

    def __init__(self) -> None:
        self._seen: dict[tuple[str, str], tuple[str, str]] = {}

    def conflict(self, spec: FieldSpec, where: str) -> str | None:
        """A one-line message if ``spec`` disagrees with an earlier declaration, else None."""
        if not spec.units:
            return None
        key = (spec.domain, spec.name)
        seen = self._seen.setdefault(key, (spec.units, where))
        if seen[0] != spec.units:
            return (f"field {spec.name!r} on {spec.domain!r} is declared in {spec.units!r} here but in "
                    f"{seen[0]!r} by {seen[1]} (one field name, one unit: docs/fields.md)")
        return None
