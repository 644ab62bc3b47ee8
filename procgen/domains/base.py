"""Domain base class: immutable topology plus size-checked named fields."""
from __future__ import annotations

from typing import Any, ClassVar, Iterator

import numpy as np

from ..errors import InputError
from ..fields import FieldInfo, check_field_name


def frozen(array: Any, dtype: Any = None) -> np.ndarray:
    """Return a read-only contiguous copy: topology must never change under a rule's feet."""
    out = np.array(array, dtype=dtype, copy=True, order="C")
    out.setflags(write=False)
    return out


class Domain:
    """Geometry/topology that fields live on.

    Subclasses set ``kind`` and ``locations`` and implement ``location_shape``,
    ``topology_arrays``/``topology_meta`` and ``from_topology`` (for save/load).
    """

    kind: ClassVar[str] = "Domain"
    locations: ClassVar[tuple[str, ...]] = ()

    def __init__(self) -> None:
        self._fields: dict[str, np.ndarray] = {}
        self._info: dict[str, FieldInfo] = {}

    # -- fields ---------------------------------------------------------------------------
    def location_shape(self, at: str) -> tuple[int, ...]:
        raise NotImplementedError

    def add_field(self, name: str, values: Any, *, at: str, units: str = "", doc: str = "") -> np.ndarray:
        """Set (or replace) field ``name`` on location ``at``; leading dims must fit the location.

        ``at="domain"`` holds one array for the whole domain (a texture image, a light table).
        """
        try:
            check_field_name(name)
        except ValueError as exc:
            raise InputError(f"{self.kind}: {exc}") from None
        if at not in self.locations and at != "domain":
            raise InputError(f"{self.kind} field {name!r}: location {at!r} not one of {self.locations}")
        arr = np.asarray(values)
        want = () if at == "domain" else self.location_shape(at)
        if arr.shape[: len(want)] != want:
            raise InputError(
                f"{self.kind} field {name!r} on {at!r}: shape {arr.shape} does not start with {want}")
        if arr.dtype == object:
            raise InputError(f"{self.kind} field {name!r}: object arrays are not allowed")
        self._fields[name] = arr
        self._info[name] = FieldInfo(at=at, units=units, doc=doc)
        return arr

    def __getitem__(self, name: str) -> np.ndarray:
        try:
            return self._fields[name]
        except KeyError:
            have = ", ".join(sorted(self._fields)) or "none"
            raise InputError(f"{self.kind} has no field {name!r} (fields: {have})") from None

    def __setitem__(self, name: str, values: Any) -> None:
        """Replace an existing field's values (location and metadata kept)."""
        info = self._info.get(name)
        if info is None:
            raise InputError(f"{self.kind} has no field {name!r}; use add_field(name, values, at=...)")
        self.add_field(name, values, at=info.at, units=info.units, doc=info.doc)

    def __contains__(self, name: object) -> bool:
        return name in self._fields

    def field_names(self, at: str | None = None) -> list[str]:
        return sorted(n for n, i in self._info.items() if at is None or i.at == at)

    def field_info(self, name: str) -> FieldInfo:
        self[name]
        return self._info[name]

    def fields(self) -> Iterator[tuple[str, np.ndarray, FieldInfo]]:
        for name in sorted(self._fields):
            yield name, self._fields[name], self._info[name]

    def remove_field(self, name: str) -> None:
        self._fields.pop(name, None)
        self._info.pop(name, None)

    def copy_fields_from(self, other: "Domain", at_map: dict[str, str]) -> None:
        """Copy every field of ``other`` whose location is in ``at_map`` (old -> new location)."""
        for name, arr, info in other.fields():
            if info.at in at_map:
                self.add_field(name, arr.copy(), at=at_map[info.at], units=info.units, doc=info.doc)

    # -- persistence ----------------------------------------------------------------------
    def topology_arrays(self) -> dict[str, np.ndarray]:
        raise NotImplementedError

    def topology_meta(self) -> dict[str, Any]:
        return {}

    @classmethod
    def from_topology(cls, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> "Domain":
        raise NotImplementedError

    def summary(self) -> str:
        sizes = ", ".join(f"{loc}={int(np.prod(self.location_shape(loc)))}" for loc in self.locations)
        return f"{self.kind}({sizes}; fields: {', '.join(self.field_names()) or 'none'})"

    def __repr__(self) -> str:
        return self.summary()
