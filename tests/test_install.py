"""The install carries every entry point, plugin package, recipe and gallery list."""
from __future__ import annotations

import importlib
import tomllib
from importlib import metadata

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


def _forced() -> dict[str, str]:
    data = tomllib.loads((ROOT / "pyproject.toml").read_text())
    return data["tool"]["hatch"]["build"]["targets"]["wheel"]["force-include"]


def test_recipes_and_gallery_lists_are_found(host):
    recipes = list_recipes(host)
    assert "demo/basics" in recipes
    for f in (ROOT / "rules").rglob("*.toml"):
        name = f.relative_to(ROOT / "rules").with_suffix("").as_posix()
        assert name in recipes, f"recipe {name} is not visible through the install"
    lists = {p.name for p in host.gallery_lists()}
    for f in (ROOT / "gallery").glob("*.toml"):
        assert f.name in lists, f"gallery/{f.name} is shipped by no plugin"


def test_every_family_folder_and_gallery_list_ships_in_a_plugin_package():
    forced = _forced()
    packages = {t.split(".")[0] for t in _declared_entry_points().values()}
    for family in (ROOT / "rules").iterdir():
        if family.is_dir():
            target = forced.get(f"rules/{family.name}", "")
            assert target.endswith(f"/recipes/{family.name}"), f"rules/{family.name} is not shipped"
            assert target.split("/")[0] in packages | {"procgen"}
    for f in (ROOT / "gallery").glob("*.toml"):
        assert forced.get(f"gallery/{f.name}", "").endswith(f"/gallery/{f.name}"), f"gallery/{f.name} not shipped"


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
    forced = _forced()
    for f in (ROOT / "rules").rglob("*"):
        if f.is_file() and f.parent != ROOT / "rules":     # recipes and the meshes they name
            family = f.relative_to(ROOT / "rules").parts[0]
            rest = f.relative_to(ROOT / "rules" / family).as_posix()
            assert f"{forced[f'rules/{family}']}/{rest}" in names, f"{f} missing from the wheel"
    for f in (ROOT / "gallery").glob("*.toml"):
        assert forced[f"gallery/{f.name}"] in names
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
