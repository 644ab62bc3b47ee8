"""The error hierarchy: every expected failure is a ProcgenError with a one-line message.

The CLI prints ``str(error)`` and exits non-zero; anything that is not a ProcgenError is a bug.
"""
from __future__ import annotations

import functools
import os


def printable(text: str) -> str:
    """``text`` with control characters (terminal escapes included) shown as ``?``: what a
    message echoes from a file or a recipe must not drive the user's terminal."""
    return "".join(c if c.isprintable() else "?" for c in text)


@functools.cache
def installed_roots() -> tuple[str, ...]:
    """The folders Python installs packages into (site-packages, as spelled and resolved),
    longest first."""
    import site
    import sysconfig

    roots = {sysconfig.get_path(k) for k in ("purelib", "platlib")}
    roots.update(getattr(site, "getsitepackages", list)())
    if site.ENABLE_USER_SITE:
        roots.add(site.getusersitepackages())
    roots |= {os.path.realpath(r) for r in roots if r}
    return tuple(sorted((r.rstrip(os.sep) for r in roots if r and r != os.sep), key=len, reverse=True))


def shown(text: str) -> str:
    """``text`` as a message shows it: a file of an installed package named from its package
    (``installed procgen/data/meshes/spot.obj``), never by its site-packages path, and control
    characters as ``?`` (:func:`printable`). The last guard: rules name shipped files by name."""
    for root in installed_roots():
        text = text.replace(root + os.sep, "installed ")
    return printable(text)


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
