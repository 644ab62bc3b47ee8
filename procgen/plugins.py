"""Finding plugins: a plugin-manager factory, a typed facade, and broken-plugin reports.

There is no module-global manager: every call to :func:`get_plugin_manager` builds a fresh one,
so tests can add throw-away plugins and ``PROCGEN_DISABLE_PLUGINS`` is read when it matters.

Registration cannot be hijacked: the entry points of this project's own distribution (the
built-in plugins) are loaded first, an outside entry point reusing one of their names is
refused, and a plugin defining a rule, exporter or recipe name another plugin already defines
is refused whole, with one line naming both sides -- first come keeps the name, so a built-in
always keeps its own.
"""
from __future__ import annotations

import os
import re
import types
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import pluggy

from . import hookspecs
from .errors import PluginError, printable
from .exchange.registry import Exporter
from .rules import RuleBase, check_rule_class

ENTRY_POINT_GROUP = "procgen"
#: the distribution whose entry points are the built-in plugins (``[project] name`` in pyproject)
BUILTIN_DISTRIBUTION = "procgen-rules"


@dataclass
class PluginStatus:
    """One plugin as ``procgen plugins`` shows it."""

    name: str
    target: str
    distribution: str
    version: str
    ok: bool
    error: str = ""
    rules: list[str] = field(default_factory=list)
    builtin: bool = False

    def label(self) -> str:
        """How a report names this plugin: ``plugin 'evil' (dist evil 1.0)``."""
        dist = f" (dist {self.distribution} {self.version})" if self.distribution else ""
        return printable(f"plugin {self.name!r}{dist}")

    def fail(self, reason: str) -> None:
        """Mark broken; a second reason is added to the first, on the same line."""
        self.error = f"{self.error}; {reason}" if self.error and reason not in self.error else reason
        self.ok = False


@dataclass(frozen=True)
class RecipeFolder:
    """Recipes under ``root``, named by their path relative to it (``clouds/fig-3-22``); with a
    ``family``, only those in ``root/family`` (a plugin's share of a folder several plugins use)."""

    root: Path
    family: str = ""

    @property
    def path(self) -> Path:
        return self.root / self.family if self.family else self.root

    def names(self) -> list[str]:
        """The recipe names this folder ships (``fam/one`` for ``root/fam/one.toml``)."""
        return [f.relative_to(self.root).with_suffix("").as_posix() for f in sorted(self.path.rglob("*.toml"))]


def disabled_plugins() -> set[str]:
    raw = os.environ.get("PROCGEN_DISABLE_PLUGINS", "")
    return {p.strip() for p in raw.split(",") if p.strip()}


def _canonical(dist_name: str) -> str:
    return re.sub(r"[-_.]+", "-", dist_name).lower()


def _status(ep: metadata.EntryPoint) -> PluginStatus:
    dist = getattr(ep, "dist", None)
    name, version = (dist.name or "", dist.version or "") if dist else ("", "")
    return PluginStatus(ep.name, ep.value, name, version, True,
                        builtin=_canonical(name) == BUILTIN_DISTRIBUTION)


def _load_failure(exc: BaseException) -> str:
    """Why a plugin module did not import, in plain words (no exception class)."""
    if isinstance(exc, ModuleNotFoundError) and exc.name:
        return f"cannot import: needs module {exc.name!r}, which is not installed"
    if isinstance(exc, SyntaxError):
        return f"cannot import: {Path(exc.filename or '?').name} line {exc.lineno}: {exc.msg}"
    return f"cannot import: {exc}" if str(exc) else "cannot import its module"


def get_plugin_manager(extra_plugins: list[Any] | None = None, *,
                       entry_points: bool = True) -> "PluginHost":
    """Build a plugin host: entry points of group ``procgen`` (the built-in ones first, then the
    others by name) plus ``extra_plugins``.

    A plugin that fails to import, or reuses the name of one loaded before it, is recorded
    (``host.broken``) instead of raising, so one bad plugin never breaks the CLI.
    """
    pm = pluggy.PluginManager(hookspecs.PROJECT)
    pm.add_hookspecs(hookspecs)
    blocked = disabled_plugins()
    statuses: list[PluginStatus] = []
    holders: dict[str, PluginStatus] = {}        # plugin name -> the plugin that holds it
    loaded: list[PluginStatus] = []              # registered with pluggy, in load order
    if entry_points:
        statuses_eps = [(_status(ep), ep) for ep in metadata.entry_points(group=ENTRY_POINT_GROUP)]
        statuses_eps.sort(key=lambda s_ep: (not s_ep[0].builtin, s_ep[0].name, s_ep[0].distribution))
        for st, ep in statuses_eps:
            statuses.append(st)
            holder = holders.get(ep.name)
            if holder is not None:
                st.fail(f"{st.label()} has the entry-point name of {holder.label()}; ignored")
                continue
            holders[ep.name] = st
            if ep.name in blocked:
                pm.set_blocked(ep.name)
                st.fail("disabled by PROCGEN_DISABLE_PLUGINS")
                continue
            try:
                module = ep.load()
            except (Exception, SystemExit) as exc:  # a broken plugin must not break the host
                st.fail(_load_failure(exc))
                continue
            other = pm.get_name(module) if pm.is_registered(module) else None
            if other is not None:
                st.fail(f"{st.label()} points at module {ep.value!r}, already loaded as "
                        f"{holders[other].label()}; ignored")
                continue
            try:
                pm.register(module, name=ep.name)
            except pluggy.PluginValidationError as exc:
                st.fail(f"a hook has the wrong arguments: {exc}")
                continue
            loaded.append(st)
    for i, plugin in enumerate(extra_plugins or []):
        name = getattr(plugin, "__name__", None) or f"extra-{i}"
        if name in blocked:
            continue
        st = PluginStatus(name, repr(plugin), "", "", True)
        statuses.append(st)
        if name in holders:
            st.fail(f"{st.label()} has the name of {holders[name].label()}; ignored")
            continue
        holders[name] = st
        pm.register(plugin, name=name)
        loaded.append(st)
    try:
        pm.check_pending()
    except pluggy.PluginValidationError as exc:
        raise PluginError(f"plugin implements an unknown hook: {exc}") from None
    return PluginHost(pm, statuses, loaded)


@dataclass
class _Offer:
    """What one plugin registers, before it is checked against what earlier plugins did."""

    rules: list[type[RuleBase]] = field(default_factory=list)
    exporters: list[Exporter] = field(default_factory=list)
    folders: list[RecipeFolder] = field(default_factory=list)
    recipes: list[str] = field(default_factory=list)
    lists: list[Path] = field(default_factory=list)

    def names(self) -> list[tuple[str, str]]:
        """(kind, name) of every name this plugin claims; kinds are separate namespaces."""
        return ([("rule", c.name) for c in self.rules] + [("exporter", e.name) for e in self.exporters]
                + [("recipe", r) for r in self.recipes])


class PluginHost:
    """A typed facade over ``pm.hook``: rules, exporters and recipe dirs by name.

    Every registration is collected once, on first use, plugin by plugin in load order.
    """

    def __init__(self, pm: pluggy.PluginManager, statuses: list[PluginStatus],
                 loaded: list[PluginStatus]) -> None:
        self.pm = pm
        self._statuses = statuses
        self._loaded = loaded          # the plugins registered with pm, in load order
        self._resolved = False
        self._rules: dict[str, type[RuleBase]] = {}
        self._exporters: dict[str, Exporter] = {}
        self._folders: list[RecipeFolder] = []
        self._lists: list[Path] = []

    @property
    def statuses(self) -> list[PluginStatus]:
        self._resolve()
        return self._statuses

    @property
    def broken(self) -> list[PluginStatus]:
        return [s for s in self.statuses if not s.ok]

    def _resolve(self) -> None:
        if self._resolved:
            return
        self._resolved = True
        owners: dict[tuple[str, str], PluginStatus] = {}
        for st in self._loaded:
            offer = self._offer(st)
            clashes = [(kind, name, owners[kind, name]) for kind, name in dict.fromkeys(offer.names())
                       if owners.get((kind, name), st) is not st]
            if clashes:
                kind, name, holder = clashes[0]
                more = f", and {len(clashes) - 1} more such names" if len(clashes) > 1 else ""
                st.fail(f"{st.label()} defines {kind} {printable(repr(name))}, already defined by "
                        f"{holder.label()}{more}; ignored")
                st.rules.clear()
                self.pm.unregister(name=st.name)
                continue
            for kind, name in offer.names():
                owners[kind, name] = st
            for cls in offer.rules:
                self._rules[cls.name] = cls
                st.rules.append(cls.name)
            self._exporters.update((e.name, e) for e in offer.exporters)
            self._folders += offer.folders
            self._lists += offer.lists
        self._rules = dict(sorted(self._rules.items()))
        self._exporters = dict(sorted(self._exporters.items()))

    def _call(self, st: PluginStatus, hook_name: str) -> list[Any]:
        """The items one plugin's implementation of a hook returns; a failing hook marks it broken."""
        out: list[Any] = []
        for impl in getattr(self.pm.hook, hook_name).get_hookimpls():
            if impl.plugin_name != st.name or impl.hookwrapper or impl.wrapper:
                continue
            try:
                result = impl.function()
                out += list(result or [])
            except Exception as exc:  # a broken plugin must not break the host
                st.fail(f"{hook_name} failed: {exc}" if str(exc) else f"{hook_name} failed")
        return out

    def _offer(self, st: PluginStatus) -> _Offer:
        """What ``st`` registers; an invalid item is left out and marks the plugin broken."""
        offer = _Offer()
        for cls in self._call(st, "procgen_register_rules"):
            try:
                check_rule_class(cls)
            except ValueError as exc:
                st.fail(f"invalid rule: {exc}")
                continue
            twin = next((c for c in offer.rules if c.name == cls.name), None)
            if twin is not None and twin is not cls:
                st.fail(f"rule {cls.name!r} is defined twice")
            elif twin is None:
                offer.rules.append(cls)
        for e in self._call(st, "procgen_register_exporters"):
            if not isinstance(e, Exporter) or not isinstance(e.name, str):
                st.fail(f"exporter {e!r} is not a procgen.Exporter")
            elif all(o.name != e.name for o in offer.exporters):
                offer.exporters.append(e)
        for item in self._call(st, "procgen_recipe_dirs"):
            if isinstance(item, tuple) and len(item) == 2 and isinstance(item[1], str):
                folder = RecipeFolder(Path(item[0]), item[1])
            elif isinstance(item, (str, Path)):
                folder = RecipeFolder(Path(item))
            else:
                st.fail(f"procgen_recipe_dirs: {item!r} is neither a Path nor (Path, family)")
                continue
            if folder.path.is_dir():
                offer.folders.append(folder)
                offer.recipes += folder.names()
        for item in self._call(st, "procgen_gallery_lists"):
            if isinstance(item, (str, Path)):
                offer.lists.append(Path(item))
            else:
                st.fail(f"procgen_gallery_lists: {item!r} is not a Path")
        return offer

    @property
    def rules(self) -> dict[str, type[RuleBase]]:
        self._resolve()
        return self._rules

    @property
    def exporters(self) -> dict[str, Exporter]:
        self._resolve()
        return self._exporters

    def recipe_folders(self) -> list[RecipeFolder]:
        """The folders every loaded plugin ships recipes in (``procgen_recipe_dirs``), in load order."""
        self._resolve()
        return [f for f in self._folders if f.path.is_dir()]

    def gallery_lists(self) -> list[Path]:
        """Gallery list files that loaded plugins contribute (``procgen_gallery_lists``)."""
        self._resolve()
        return [p for p in self._lists if p.is_file()]

    def rule(self, name: str) -> type[RuleBase]:
        from .params import did_you_mean

        cls = self.rules.get(name)
        if cls is None:
            raise PluginError(f"unknown rule {name!r}{did_you_mean(name, self.rules)}")
        return cls

    def exporter(self, name: str) -> Exporter:
        from .params import did_you_mean

        e = self.exporters.get(name)
        if e is None:
            raise PluginError(f"unknown output format {name!r}{did_you_mean(name, self.exporters)}"
                              f"; known: {', '.join(self.exporters)}")
        return e

    def versions(self) -> dict[str, str]:
        """Distribution versions of procgen and every loaded plugin (for provenance)."""
        from . import __version__

        out = {"procgen-rules": __version__}
        for s in self.statuses:
            if s.ok and s.distribution:
                out[s.distribution] = s.version
        return dict(sorted(out.items()))


def plugin_module(name: str, **hooks: Any) -> types.ModuleType:
    """Make an in-memory plugin module from hook functions (tests and quick experiments)."""
    mod = types.ModuleType(name)
    for hook_name, fn in hooks.items():
        setattr(mod, hook_name, hookspecs.hookimpl(fn))
    return mod
