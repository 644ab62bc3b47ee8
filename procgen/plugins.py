"""Finding plugins: a plugin-manager factory, a typed facade, and broken-plugin reports.

There is no module-global manager: every call to :func:`get_plugin_manager` builds a fresh one,
so tests can add throw-away plugins and ``PROCGEN_DISABLE_PLUGINS`` is read when it matters.
"""
from __future__ import annotations

import os
import types
from dataclasses import dataclass, field
from importlib import metadata
from pathlib import Path
from typing import Any

import pluggy

from . import hookspecs
from .errors import PluginError
from .exchange.registry import Exporter
from .rules import RuleBase, check_rule_class

ENTRY_POINT_GROUP = "procgen"


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


@dataclass(frozen=True)
class RecipeFolder:
    """Recipes under ``root``, named by their path relative to it (``clouds/fig-3-22``); with a
    ``family``, only those in ``root/family`` (a plugin's share of a folder several plugins use)."""

    root: Path
    family: str = ""

    @property
    def path(self) -> Path:
        return self.root / self.family if self.family else self.root


def disabled_plugins() -> set[str]:
    raw = os.environ.get("PROCGEN_DISABLE_PLUGINS", "")
    return {p.strip() for p in raw.split(",") if p.strip()}


def get_plugin_manager(extra_plugins: list[Any] | None = None, *,
                       entry_points: bool = True) -> "PluginHost":
    """Build a plugin host: entry points of group ``procgen`` plus ``extra_plugins``.

    A plugin that fails to import is recorded (``host.broken``) instead of raising, so one bad
    plugin never breaks the CLI.
    """
    pm = pluggy.PluginManager(hookspecs.PROJECT)
    pm.add_hookspecs(hookspecs)
    blocked = disabled_plugins()
    statuses: list[PluginStatus] = []
    if entry_points:
        eps = sorted(metadata.entry_points(group=ENTRY_POINT_GROUP), key=lambda e: e.name)
        seen: set[str] = set()
        for ep in eps:
            if ep.name in seen:
                continue
            seen.add(ep.name)
            dist = getattr(ep, "dist", None)
            st = PluginStatus(ep.name, ep.value, dist.name if dist else "", dist.version if dist else "", True)
            if ep.name in blocked:
                pm.set_blocked(ep.name)
                st.ok, st.error = False, "disabled by PROCGEN_DISABLE_PLUGINS"
                statuses.append(st)
                continue
            try:
                module = ep.load()
                pm.register(module, name=ep.name)
            except Exception as exc:  # a broken plugin must not break the host
                st.ok, st.error = False, f"{type(exc).__name__}: {exc}"
            statuses.append(st)
    for i, plugin in enumerate(extra_plugins or []):
        name = getattr(plugin, "__name__", None) or f"extra-{i}"
        if name in blocked:
            continue
        pm.register(plugin, name=name)
        statuses.append(PluginStatus(name, repr(plugin), "", "", True))
    try:
        pm.check_pending()
    except pluggy.PluginValidationError as exc:
        raise PluginError(f"plugin implements an unknown hook: {exc}") from None
    return PluginHost(pm, statuses)


class PluginHost:
    """A typed facade over ``pm.hook``: rules, exporters and recipe dirs by name."""

    def __init__(self, pm: pluggy.PluginManager, statuses: list[PluginStatus]) -> None:
        self.pm = pm
        self.statuses = statuses
        self._rules: dict[str, type[RuleBase]] | None = None
        self._exporters: dict[str, Exporter] | None = None

    @property
    def broken(self) -> list[PluginStatus]:
        return [s for s in self.statuses if not s.ok]

    def _collect(self, hook_name: str) -> list[tuple[str, Any]]:
        """(plugin name, item) for each item every plugin returns; a failing hook marks it broken."""
        out: list[tuple[str, Any]] = []
        hook = getattr(self.pm.hook, hook_name)
        for impl in hook.get_hookimpls():
            try:
                result = impl.function()
            except Exception as exc:
                self._mark_broken(impl.plugin_name, f"{hook_name} raised {type(exc).__name__}: {exc}")
                continue
            for item in result or []:
                out.append((impl.plugin_name, item))
        return out

    def _mark_broken(self, plugin: str, error: str) -> None:
        for s in self.statuses:
            if s.name == plugin:
                s.ok, s.error = False, error
                return
        self.statuses.append(PluginStatus(plugin, "", "", "", False, error))

    @property
    def rules(self) -> dict[str, type[RuleBase]]:
        if self._rules is None:
            rules: dict[str, type[RuleBase]] = {}
            for plugin, cls in self._collect("procgen_register_rules"):
                try:
                    check_rule_class(cls)
                except ValueError as exc:
                    self._mark_broken(plugin, f"invalid rule: {exc}")
                    continue
                if cls.name in rules and rules[cls.name] is not cls:
                    self._mark_broken(plugin, f"rule {cls.name!r} is already registered")
                    continue
                rules[cls.name] = cls
                for s in self.statuses:
                    if s.name == plugin:
                        s.rules.append(cls.name)
            self._rules = dict(sorted(rules.items()))
        return self._rules

    @property
    def exporters(self) -> dict[str, Exporter]:
        if self._exporters is None:
            ex: dict[str, Exporter] = {}
            for plugin, e in self._collect("procgen_register_exporters"):
                if not isinstance(e, Exporter):
                    self._mark_broken(plugin, f"exporter {e!r} is not a procgen.Exporter")
                    continue
                ex.setdefault(e.name, e)
            self._exporters = dict(sorted(ex.items()))
        return self._exporters

    def recipe_folders(self) -> list["RecipeFolder"]:
        """The folders every loaded plugin ships recipes in (``procgen_recipe_dirs``), in load order."""
        folders = []
        for plugin, item in self._collect("procgen_recipe_dirs"):
            if isinstance(item, tuple) and len(item) == 2 and isinstance(item[1], str):
                folder = RecipeFolder(Path(item[0]), item[1])
            elif isinstance(item, (str, Path)):
                folder = RecipeFolder(Path(item))
            else:
                self._mark_broken(plugin, f"procgen_recipe_dirs: {item!r} is neither a Path nor (Path, family)")
                continue
            if folder.path.is_dir():
                folders.append(folder)
        return folders

    def gallery_lists(self) -> list[Path]:
        """Gallery list files that loaded plugins contribute (``procgen_gallery_lists``)."""
        return [Path(p) for _, p in self._collect("procgen_gallery_lists") if Path(p).is_file()]

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
