"""The hooks a procgen plugin can implement. These docstrings are the plugin author's manual.

A plugin is any importable module listed under the ``procgen`` entry-point group:

    [project.entry-points.procgen]
    lichen = "procgen_lichen.plugin"

and decorating functions in it with ``@procgen.hookimpl``. Every hook returns a list and the
results of all plugins are concatenated. Built-in rules use the same hooks.

Names are first come, first kept: the built-in plugins load first, and a plugin whose entry-point
name, or any rule, exporter or recipe name, is already taken is refused whole (``procgen
plugins`` shows it as BROKEN with the name and the plugin holding it). Prefix your names with
your family (``lichen.grow``, ``lichen_svg``, ``lichen/rock``).
"""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import pluggy

if TYPE_CHECKING:
    from .exchange.registry import Exporter
    from .rules import RuleBase

PROJECT = "procgen"
hookspec = pluggy.HookspecMarker(PROJECT)
hookimpl = pluggy.HookimplMarker(PROJECT)


@hookspec
def procgen_register_rules() -> "list[type[RuleBase]]":
    """Return the rule classes this plugin provides.

    Each class is a ``@dataclass(kw_only=True)`` subclass of ``procgen.RuleBase`` with a unique
    ``name`` such as ``"lichen.grow"``. Its dataclass fields are the parameters a recipe may set
    (declare ranges and units with ``procgen.param``); ``fields``, ``uses`` and ``creates``
    declare the data it reads and writes so ``procgen check`` can validate recipes.

    Example::

        @procgen.hookimpl
        def procgen_register_rules():
            return [LichenGrowth]
    """


@hookspec
def procgen_register_exporters() -> "list[Exporter]":
    """Return ``procgen.Exporter`` objects: named writers from a domain kind to file bytes.

    An exporter's function is pure: ``func(domain, *, stem, provenance, **options)`` returns
    ``bytes`` (written to ``stem + suffix``) or a dict of file name to bytes (for multi-file
    formats). procgen writes the files atomically. Recipes pick it with ``format = "name"``.

    Example::

        @procgen.hookimpl
        def procgen_register_exporters():
            return [procgen.Exporter(name="lichen_svg", kinds=("Grid",), suffix=".svg",
                                     func=lichen_to_svg, doc="lichen patches as SVG circles")]
    """


@hookspec
def procgen_recipe_dirs() -> "list[Path | tuple[Path, str]]":
    """Return directories that hold this plugin's recipes (``*.toml``), e.g. shipped package data.

    A recipe ``<dir>/lichen/rock.toml`` is then runnable as ``procgen run lichen/rock``. A pair
    ``(dir, "lichen")`` ships only the family folder ``<dir>/lichen`` (names stay ``lichen/...``):
    the built-in plugins use it for their share of the checkout's ``rules/`` folder. A disabled
    plugin's recipes (``PROCGEN_DISABLE_PLUGINS``) are not listed and its gallery entries vanish.

    Example::

        @procgen.hookimpl
        def procgen_recipe_dirs():
            return [Path(__file__).parent / "recipes"]
    """


@hookspec
def procgen_gallery_lists() -> "list[Path]":
    """Return gallery list files (TOML with ``[[entry]]`` tables) that this plugin adds.

    Entries name recipes (usually the plugin's own, from ``procgen_recipe_dirs``) and appear in
    ``procgen gallery`` and its contact sheet beside the built-in families. An entry whose recipe
    needs a rule that no loaded plugin registers is left out with a one-line note on stderr.

    Example::

        @procgen.hookimpl
        def procgen_gallery_lists():
            return [Path(__file__).parent / "gallery.toml"]
    """
