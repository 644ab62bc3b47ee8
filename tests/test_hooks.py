"""Every hook is documented with an example and exercised by a test (datasette's meta-test)."""
from __future__ import annotations

import inspect
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import pytest

from procgen import Exporter, PluginError, get_plugin_manager, hookspecs
from procgen.plugins import plugin_module

HOOKS = [n for n, f in inspect.getmembers(hookspecs, inspect.isfunction) if n.startswith("procgen_")]
TESTS = Path(__file__).parent


def test_there_are_hooks():
    assert set(HOOKS) == {"procgen_register_rules", "procgen_register_exporters", "procgen_recipe_dirs",
                          "procgen_gallery_lists"}


@pytest.mark.parametrize("hook", HOOKS)
def test_hook_is_documented_with_example(hook):
    doc = inspect.getdoc(getattr(hookspecs, hook)) or ""
    assert len(doc) > 80 and "Example::" in doc and "@procgen.hookimpl" in doc


@pytest.mark.parametrize("hook", HOOKS)
def test_hook_is_tested(hook):
    this = Path(__file__).read_text()
    body = this.split("# -- hook tests --", 1)[1]
    assert f"def {hook}" in body, f"no test in test_hooks.py implements {hook}"


# -- hook tests --
def test_throwaway_plugin_adds_rule_exporter_and_recipe_dir(tmp_path):
    import procgen

    @dataclass(kw_only=True)
    class Noop(procgen.RuleBase):
        """Does nothing."""

        name: ClassVar[str] = "test.noop"

        def step(self, state):
            return False

    def procgen_register_rules():
        return [Noop]

    def to_text(domain, *, stem, provenance, **opts):
        return f"{domain.kind}\n".encode()

    def procgen_register_exporters():
        return [Exporter("kindname", ("Grid", "TriMesh", "PointSet", "Polylines"), ".txt", to_text, "kind")]

    (tmp_path / "fam").mkdir()
    (tmp_path / "fam" / "one.toml").write_text('[[steps]]\nrule = "test.noop"\n')

    def procgen_recipe_dirs():
        return [tmp_path]

    (tmp_path / "g.toml").write_text('[[entry]]\nrecipe = "fam/one"\ntitle = "noop"\n')

    def procgen_gallery_lists():
        return [tmp_path / "g.toml"]

    mod = plugin_module("throwaway", procgen_register_rules=procgen_register_rules,
                        procgen_register_exporters=procgen_register_exporters,
                        procgen_recipe_dirs=procgen_recipe_dirs, procgen_gallery_lists=procgen_gallery_lists)
    host = get_plugin_manager([mod])
    assert "test.noop" in host.rules and "kindname" in host.exporters
    assert tmp_path in [f.root for f in host.recipe_folders()]
    from procgen.gallery import load_gallery
    from procgen.recipes import load_recipe

    assert load_recipe("fam/one", host).steps[0].rule.name == "test.noop"
    assert [e.recipe for e in load_gallery(host, ["fam/*"])] == ["fam/one"]


def test_invalid_registrations_mark_plugin_broken():
    class NotARule:
        name = "x.y"

    def procgen_register_rules():
        return [NotARule]

    def procgen_register_exporters():
        return ["not an exporter"]

    def procgen_recipe_dirs():
        raise RuntimeError("boom")

    host = get_plugin_manager([plugin_module("bad", procgen_register_rules=procgen_register_rules,
                                             procgen_register_exporters=procgen_register_exporters,
                                             procgen_recipe_dirs=procgen_recipe_dirs)])
    assert "x.y" not in host.rules and "not an exporter" not in host.exporters
    host.recipe_folders()
    bad = [s for s in host.statuses if s.name == "bad"][0]
    assert not bad.ok and "boom" in bad.error or "not a procgen.Exporter" in bad.error


def test_unknown_hook_is_refused():
    mod = plugin_module("typo", procgen_register_rulez=lambda: [])
    with pytest.raises(PluginError, match="unknown hook"):
        get_plugin_manager([mod], entry_points=False)
