"""Where shipped data lives: each built-in plugin's recipes and gallery lists, and the meshes.

Built-in plugins ship recipes exactly as an outside plugin does, through the
``procgen_recipe_dirs`` and ``procgen_gallery_lists`` hooks. In a wheel, pyproject's
force-include copies ``rules/<family>`` into ``<plugin package>/recipes/<family>`` and
``gallery/<list>.toml`` into ``<plugin package>/gallery/``; in a source checkout or an editable
install the families stay in the top-level ``rules/`` and ``gallery/`` folders, of which each
plugin names only its own.
"""
from __future__ import annotations

from pathlib import Path
from typing import Callable

_PKG = Path(__file__).resolve().parent
SOURCE_ROOT = _PKG.parent      # a checkout: rules/ and gallery/ beside the procgen package


def plugin_recipe_dirs(package_dir: Path, *families: str) -> list[Path | tuple[Path, str]]:
    """A built-in plugin's ``procgen_recipe_dirs``: its package's ``recipes`` folder when
    installed from a wheel, else ``(rules/, family)`` pairs naming its families in the checkout."""
    shipped = Path(package_dir) / "recipes"
    if shipped.is_dir():
        return [shipped]
    return [(SOURCE_ROOT / "rules", family) for family in families]


def plugin_gallery_lists(package_dir: Path, *names: str) -> list[Path]:
    """A built-in plugin's ``procgen_gallery_lists``: ``<package>/gallery/<name>`` from a wheel,
    else ``gallery/<name>`` in the checkout."""
    shipped = Path(package_dir) / "gallery"
    base = shipped if shipped.is_dir() else SOURCE_ROOT / "gallery"
    return [base / name for name in names]


def shipping_hooks(plugin_file: str, families: tuple[str, ...], lists: tuple[str, ...]
                   ) -> tuple[Callable[[], list], Callable[[], list[Path]]]:
    """The ``procgen_recipe_dirs`` and ``procgen_gallery_lists`` hook implementations of a
    built-in family plugin that ships ``rules/<family>`` and ``gallery/<list>``; assign them to
    those names in the plugin module (pluggy finds hook implementations by name)."""
    from .hookspecs import hookimpl

    package_dir = Path(plugin_file).parent

    @hookimpl
    def procgen_recipe_dirs() -> list:
        return plugin_recipe_dirs(package_dir, *families)

    @hookimpl
    def procgen_gallery_lists() -> list[Path]:
        return plugin_gallery_lists(package_dir, *lists)

    return procgen_recipe_dirs, procgen_gallery_lists


def builtin_rules_dir() -> Path:
    """The folder holding the built-in plugin's recipe families (``demo``, ``chains``, ``data``)
    and the sample files beside them: in the wheel or in the checkout's ``rules/``."""
    shipped = _PKG / "builtin" / "recipes"
    return shipped if shipped.is_dir() else SOURCE_ROOT / "rules"


def meshes_dir() -> Path:
    return _PKG / "data" / "meshes"
