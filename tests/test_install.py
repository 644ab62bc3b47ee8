"""The install carries every entry point, plugin package, recipe and gallery list."""
from __future__ import annotations

import importlib
import tomllib
from importlib import metadata

from procgen.data import builtin_rules_dir, gallery_dir
from procgen.recipes import list_recipes, load_recipe

from _paths import ROOT


def _declared_entry_points() -> dict[str, str]:
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())
    return data["project"]["entry-points"]["procgen"]


def test_every_declared_entry_point_is_installed():
    installed = {ep.name: ep.value for ep in metadata.entry_points(group="procgen")}
    for name, target in _declared_entry_points().items():
        assert name in installed, f"entry point {name!r} missing from the install (reinstall the project)"
        assert installed[name] == target


def test_every_plugin_package_imports_and_is_shipped():
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())
    shipped = {p.rsplit("/", 1)[-1] for p in data["tool"]["hatch"]["build"]["targets"]["wheel"]["packages"]}
    for target in _declared_entry_points().values():
        module = target.split(":")[0]
        importlib.import_module(module)
        assert module.split(".")[0] in shipped, f"{module} is not listed in the wheel packages"
    for pkg in (ROOT / "plugins").iterdir():
        if (pkg / "__init__.py").exists():
            assert pkg.name in shipped, f"plugins/{pkg.name} is not shipped in the wheel"


def test_no_plugin_is_broken(host):
    assert host.broken == []
    for s in host.statuses:
        assert s.ok


def test_recipes_and_gallery_lists_are_found(host):
    assert builtin_rules_dir().is_dir()
    assert (gallery_dir() / "gallery.toml").is_file()
    recipes = list_recipes(host)
    assert "demo/basics" in recipes
    for f in (ROOT / "rules").rglob("*.toml"):
        name = f.relative_to(ROOT / "rules").with_suffix("").as_posix()
        assert name in recipes, f"recipe {name} is not visible through the install"


def test_every_gallery_list_file_is_shipped():
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())
    forced = data["tool"]["hatch"]["build"]["targets"]["wheel"]["force-include"]
    for f in (ROOT / "gallery").glob("*.toml"):
        assert f"gallery/{f.name}" in forced, f"gallery/{f.name} is not shipped in the wheel"


def test_every_shipped_recipe_passes_check(host):
    for name in list_recipes(host):
        load_recipe(name, host)


def test_wheel_ships_plugins_recipes_and_gallery(tmp_path):
    """Build the wheel as pip would and look inside: nothing the install needs is left out."""
    import subprocess
    import sys
    import zipfile

    subprocess.run([sys.executable, "-m", "pip", "wheel", str(ROOT), "--no-deps", "--no-build-isolation",
                    "-w", str(tmp_path), "-q"], check=True, capture_output=True, timeout=300)
    wheel = next(tmp_path.glob("procgen_rules-*.whl"))
    names = set(zipfile.ZipFile(wheel).namelist())
    for target in _declared_entry_points().values():
        pkg = target.split(".")[0]
        assert f"{pkg}/__init__.py" in names, f"{pkg} missing from the wheel"
    for f in (ROOT / "rules").rglob("*.toml"):
        assert f"procgen/_data/rules/{f.relative_to(ROOT / 'rules').as_posix()}" in names
    for f in (ROOT / "gallery").glob("*.toml"):
        assert f"procgen/_data/gallery/{f.name}" in names
    ep = next(n for n in names if n.endswith("entry_points.txt"))
    text = zipfile.ZipFile(wheel).read(ep).decode()
    for name in _declared_entry_points():
        assert f"{name} = " in text


def test_base_paths_never_import_optional_extras():
    """dask and numba are extras: importing procgen, its plugins and the CLI must not load them."""
    import subprocess
    import sys

    code = ("import sys, procgen, procgen.cli, procgen.sweep, procgen.gallery\n"
            "h = procgen.get_plugin_manager(); h.rules; h.exporters\n"
            "from procgen.recipes import load_recipe; from procgen.runner import run\n"
            "run(load_recipe('demo/basics', h), h)\n"
            "bad = [m for m in ('dask', 'distributed', 'numba') if m in sys.modules]\n"
            "assert not bad, bad\n")
    r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr[-2000:]
