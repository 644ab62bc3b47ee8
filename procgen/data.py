"""Where shipped data lives: recipes (rules/), gallery lists (gallery/) and meshes.

In a wheel they are copied under ``procgen/_data``; in a source checkout or an editable install
they are the top-level folders beside the package. Both are looked up, in that order.
"""
from __future__ import annotations

from pathlib import Path

_PKG = Path(__file__).resolve().parent


def _first(*candidates: Path) -> Path:
    for c in candidates:
        if c.exists():
            return c
    return candidates[0]


def builtin_rules_dir() -> Path:
    return _first(_PKG / "_data" / "rules", _PKG.parent / "rules")


def gallery_dir() -> Path:
    return _first(_PKG / "_data" / "gallery", _PKG.parent / "gallery")


def meshes_dir() -> Path:
    return _PKG / "data" / "meshes"
