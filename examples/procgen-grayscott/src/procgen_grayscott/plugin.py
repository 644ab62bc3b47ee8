"""The hooks procgen calls: register the rule and point at the shipped recipes."""
from __future__ import annotations

from pathlib import Path

import procgen


@procgen.hookimpl
def procgen_register_rules():
    from .rules import GrayScott

    return [GrayScott]


@procgen.hookimpl
def procgen_recipe_dirs():
    return [Path(__file__).parent / "recipes"]


@procgen.hookimpl
def procgen_gallery_lists():
    return [Path(__file__).parent / "gallery.toml"]
