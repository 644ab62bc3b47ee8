"""The four domain kinds every rule works on, and the registry of domain classes by kind."""
from __future__ import annotations

from .base import Domain, frozen
from .grid import Grid
from .pointset import PointSet
from .polylines import Polylines
from .trimesh_domain import TriMesh

DOMAIN_KINDS: dict[str, type[Domain]] = {c.kind: c for c in (Grid, PointSet, TriMesh, Polylines)}


def register_domain_kind(cls: type[Domain]) -> type[Domain]:
    """Make a plugin-defined Domain subclass known to State.load and the recipe checker."""
    DOMAIN_KINDS[cls.kind] = cls
    return cls


def is_kind(domain_cls: type[Domain], kind: str) -> bool:
    """True if ``domain_cls`` is ``kind`` or derives from the class registered under ``kind``."""
    target = DOMAIN_KINDS.get(kind)
    if target is None:
        return any(c.kind == kind for c in domain_cls.__mro__ if hasattr(c, "kind"))
    return issubclass(domain_cls, target)


__all__ = ["Domain", "Grid", "PointSet", "TriMesh", "Polylines", "DOMAIN_KINDS",
           "register_domain_kind", "is_kind", "frozen"]
