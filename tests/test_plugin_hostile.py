"""Hostile plugins cannot hijack registration: the built-ins are loaded first and keep their names.

Each test installs real distributions (a ``.dist-info`` with ``entry_points.txt`` beside the
module) in a temporary folder put on ``sys.path`` (or ``PYTHONPATH`` for the CLI), as pip would.
"""
from __future__ import annotations

import os
import re
import subprocess
import sys
import textwrap
from importlib import metadata
from pathlib import Path

import pytest

from procgen import get_plugin_manager
from procgen.recipes import list_recipes

BUILTIN = f"plugin 'builtin' (dist procgen-rules {metadata.version('procgen-rules')})"

RULE = '''
from dataclasses import dataclass
from typing import ClassVar
import procgen

@dataclass(kw_only=True)
class Impostor(procgen.RuleBase):
    """Pretends to be {name}."""
    name: ClassVar[str] = "{name}"
    def step(self, state):
        return False
'''


def install(root: Path, dist: str, entry_points: dict[str, str], modules: dict[str, str]) -> None:
    """An installed-looking distribution ``dist`` 1.0 whose ``procgen`` entry points name modules."""
    for module, body in modules.items():
        (root / f"{module}.py").write_text(textwrap.dedent(body))
    info = root / f"{dist.replace('-', '_')}-1.0.dist-info"    # as a wheel spells it
    info.mkdir()
    (info / "METADATA").write_text(f"Metadata-Version: 2.1\nName: {dist}\nVersion: 1.0\n")
    lines = "".join(f"{name} = {target}\n" for name, target in entry_points.items())
    (info / "entry_points.txt").write_text(f"[procgen]\n{lines}")


def rule_plugin(name: str, extra: str = "") -> str:
    return RULE.format(name=name) + textwrap.dedent(f'''
        @procgen.hookimpl
        def procgen_register_rules():
            return [Impostor{extra}]
        ''')


def status(host, name: str, dist: str):
    return next(s for s in host.statuses if s.name == name and s.distribution == dist)


@pytest.fixture
def site(tmp_path, monkeypatch):
    monkeypatch.syspath_prepend(str(tmp_path))
    return tmp_path


def test_a_plugin_sorting_before_builtin_cannot_replace_a_rule(site):
    # 'aaa' loads before 'builtin' when entry points are taken in name order
    install(site, "evil", {"aaa": "evil_rule"}, {"evil_rule": rule_plugin("mesh.primitive") + textwrap.dedent('''
        @dataclass(kw_only=True)
        class Extra(procgen.RuleBase):
            """A rule of its own."""
            name: ClassVar[str] = "evil.extra"
            def step(self, state):
                return False

        @procgen.hookimpl
        def procgen_register_exporters():
            return []
        ''').replace("return [Impostor]", "return [Impostor, Extra]")})
    from procgen.builtin.meshes import MeshPrimitive

    host = get_plugin_manager()
    assert host.rules["mesh.primitive"] is MeshPrimitive
    assert "evil.extra" not in host.rules                 # the refused plugin gives nothing at all
    builtin, evil = status(host, "builtin", "procgen-rules"), status(host, "aaa", "evil")
    assert builtin.ok and "mesh.primitive" in builtin.rules
    assert not evil.ok and evil.rules == []
    assert evil.error == (f"plugin 'aaa' (dist evil 1.0) defines rule 'mesh.primitive', already defined by "
                          f"{BUILTIN}; ignored")
    assert host.pm.get_plugin("aaa") is None
    assert "evil" not in host.versions()                  # provenance never names a refused plugin


def test_a_plugin_cannot_replace_an_exporter(site):
    install(site, "evil-svg", {"aaa": "evil_svg"}, {"evil_svg": '''
        import procgen

        def fake(domain, *, stem, provenance, **options):
            return b"<svg/>"

        @procgen.hookimpl
        def procgen_register_exporters():
            return [procgen.Exporter("svg", ("PointSet",), ".svg", fake, "not the real one")]
        '''})
    from procgen.exchange import BUILTIN_EXPORTERS

    host = get_plugin_manager()
    assert host.exporters["svg"] is next(e for e in BUILTIN_EXPORTERS if e.name == "svg")
    evil = status(host, "aaa", "evil-svg")
    assert evil.error == (f"plugin 'aaa' (dist evil-svg 1.0) defines exporter 'svg', already defined by "
                          f"{BUILTIN}; ignored")
    assert status(host, "builtin", "procgen-rules").ok


def test_a_plugin_cannot_replace_a_recipe(site):
    (site / "evil_recipes" / "demo").mkdir(parents=True)
    (site / "evil_recipes" / "demo" / "basics.toml").write_text('name = "evil"\n[[steps]]\nrule = "x.y"\n')
    (site / "evil_recipes" / "demo" / "own.toml").write_text('[[steps]]\nrule = "x.y"\n')
    install(site, "evil-recipes", {"aaa": "evil_recipe"}, {"evil_recipe": '''
        from pathlib import Path
        import procgen

        @procgen.hookimpl
        def procgen_recipe_dirs():
            return [Path(__file__).parent / "evil_recipes"]
        '''})
    host = get_plugin_manager()
    recipes = list_recipes(host)
    assert "evil_recipes" not in str(recipes["demo/basics"]) and "demo/own" not in recipes
    evil = status(host, "aaa", "evil-recipes")
    assert evil.error == (f"plugin 'aaa' (dist evil-recipes 1.0) defines recipe 'demo/basics', already "
                          f"defined by {BUILTIN}; ignored")


def test_an_entry_point_named_builtin_is_refused_and_never_imported(site):
    install(site, "evil-name", {"builtin": "evil_builtin"}, {"evil_builtin": rule_plugin("evil.mine")})
    host = get_plugin_manager()
    builtins = [s for s in host.statuses if s.name == "builtin"]
    assert [(s.distribution, s.ok) for s in builtins] == [("procgen-rules", True), ("evil-name", False)]
    assert builtins[1].error == (f"plugin 'builtin' (dist evil-name 1.0) has the entry-point name of "
                                 f"{BUILTIN}; ignored")
    assert "mesh.primitive" in host.rules and "points.poisson_disk" in host.rules
    assert "evil.mine" not in host.rules and "evil_builtin" not in sys.modules


def test_two_outside_plugins_with_one_rule_name(site):
    install(site, "alpha", {"alpha": "alpha_plugin"}, {"alpha_plugin": rule_plugin("shared.rule")})
    install(site, "beta", {"beta": "beta_plugin"}, {"beta_plugin": rule_plugin("shared.rule")})
    host = get_plugin_manager()
    assert host.rules["shared.rule"].__module__ == "alpha_plugin"   # the first loaded keeps it
    assert status(host, "alpha", "alpha").ok
    assert status(host, "beta", "beta").error == ("plugin 'beta' (dist beta 1.0) defines rule 'shared.rule', "
                                                  "already defined by plugin 'alpha' (dist alpha 1.0); ignored")


def test_two_outside_distributions_with_one_entry_point_name(site):
    install(site, "first", {"same": "first_plugin"}, {"first_plugin": rule_plugin("first.rule")})
    install(site, "second", {"same": "second_plugin"}, {"second_plugin": rule_plugin("second.rule")})
    host = get_plugin_manager()
    assert "first.rule" in host.rules and "second.rule" not in host.rules
    assert status(host, "same", "second").error == ("plugin 'same' (dist second 1.0) has the entry-point "
                                                    "name of plugin 'same' (dist first 1.0); ignored")


def test_an_entry_point_pointing_at_a_builtin_module_is_refused(site):
    install(site, "copycat", {"aaa": "procgen.builtin.plugin"}, {})
    host = get_plugin_manager()
    assert status(host, "builtin", "procgen-rules").ok and "mesh.primitive" in host.rules
    assert status(host, "aaa", "copycat").error == ("plugin 'aaa' (dist copycat 1.0) points at module "
                                                    f"'procgen.builtin.plugin', already loaded as {BUILTIN}; "
                                                    "ignored")


def test_procgen_plugins_reports_the_refused_and_the_builtin_keeps_working(tmp_path):
    (tmp_path / "hostile_recipes" / "demo").mkdir(parents=True)
    (tmp_path / "hostile_recipes" / "demo" / "basics.toml").write_text('[[steps]]\nrule = "x.y"\n')
    install(tmp_path, "hostile", {"aaa": "hostile_all"}, {"hostile_all": rule_plugin("mesh.primitive") + '''
import pathlib

def fake(domain, *, stem, provenance, **options):
    return b""

@procgen.hookimpl
def procgen_register_exporters():
    return [procgen.Exporter("svg", ("PointSet",), ".svg", fake, "fake")]

@procgen.hookimpl
def procgen_recipe_dirs():
    return [pathlib.Path(__file__).parent / "hostile_recipes"]
'''})
    install(tmp_path, "hostile-name", {"builtin": "hostile_name"}, {"hostile_name": rule_plugin("h.h")})
    env = {**os.environ, "PYTHONPATH": str(tmp_path) + os.pathsep + os.environ.get("PYTHONPATH", "")}

    def cli(*args: str) -> subprocess.CompletedProcess:
        return subprocess.run([sys.executable, "-m", "procgen.cli", *args], capture_output=True, text=True,
                              env=env, timeout=120, cwd=tmp_path)

    r = cli("plugins")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert lines[0].startswith("builtin      ok     procgen.builtin.plugin [procgen-rules ")
    refused = {i: line for i, line in enumerate(lines) if "BROKEN" in line}
    assert len(refused) == 2
    reasons = [lines[i + 1].strip() for i in refused]
    assert (f"reason: plugin 'aaa' (dist hostile 1.0) defines rule 'mesh.primitive', already defined by "
            f"{BUILTIN}, and 2 more such names; ignored") in reasons
    assert f"reason: plugin 'builtin' (dist hostile-name 1.0) has the entry-point name of {BUILTIN}; ignored" \
        in reasons
    assert "Error" not in r.stdout and "pluggy" not in r.stdout
    r = cli("check", "demo/basics")     # the hostile copy names rule 'x.y' and would not check
    assert r.returncode == 0 and r.stdout.startswith("demo/basics: ok (6 steps"), r.stdout + r.stderr
    r = cli("recipes", "show", "demo/basics")
    assert r.returncode == 0 and "hostile_recipes" not in r.stdout
    assert re.search(r"^file: .*(rules|procgen/builtin/recipes)/demo/basics\.toml$", r.stdout, re.M), r.stdout
    r = cli("exporters")
    assert r.returncode == 0 and "fake" not in r.stdout


@pytest.mark.parametrize("slug", ["../../escape", "/tmp/abs", "a/b", ".hidden", "..", "a\\u001b[2J"])
def test_a_gallery_entry_id_cannot_name_a_folder_outside_the_gallery(slug, site):
    from procgen.errors import RecipeError
    from procgen.gallery import load_gallery

    (site / "evil_gallery.toml").write_text(f'[[entry]]\nid = "{slug}"\nrecipe = "demo/basics"\nseeds = [1]\n')
    install(site, "evil-gallery", {"evilgal": "evil_gal"}, {"evil_gal": '''
        import pathlib
        import procgen

        @procgen.hookimpl
        def procgen_gallery_lists():
            return [pathlib.Path(__file__).parent / "evil_gallery.toml"]
        '''})
    host = get_plugin_manager()
    with pytest.raises(RecipeError, match=r"^evil_gallery.toml: entry\[0\]: id .* must be a plain name"):
        load_gallery(host)
