"""The error hierarchy: every expected failure is a ProcgenError with a one-line message.

The CLI prints ``str(error)`` and exits non-zero; anything that is not a ProcgenError is a bug.
"""
from __future__ import annotations


def printable(text: str) -> str:
    """``text`` with control characters (terminal escapes included) shown as ``?``: what a
    message echoes from a file or a recipe must not drive the user's terminal."""
    return "".join(c if c.isprintable() else "?" for c in text)


class ProcgenError(Exception):
    """Base of every error procgen raises on purpose (bad input, bad recipe, broken plugin)."""


class RecipeError(ProcgenError):
    """A recipe (TOML file or --set override) is malformed or inconsistent."""


class PluginError(ProcgenError):
    """A plugin failed to load, or registered something invalid."""


class MissingExtra(ProcgenError):
    """What a recipe asks for needs an optional extra that is not installed (``extra`` names it).

    Not a failure of the recipe: the gallery leaves such an entry out with this one line.
    """

    def __init__(self, message: str, extra: str) -> None:
        super().__init__(message)
        self.extra = extra


class InputError(ProcgenError):
    """Data handed to a rule or exporter is unusable (wrong shape, broken mesh, NaN...)."""
