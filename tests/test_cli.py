"""The command line: exit codes, one-line errors, written files, teaching help, broken plugins."""
from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import cairosvg
import numpy as np
import trimesh
from PIL import Image

from procgen.cli import main


def _cli(*args, env=None, cwd=None):
    return subprocess.run([sys.executable, "-m", "procgen.cli", *args], capture_output=True, text=True,
                          env={**os.environ, **(env or {})}, cwd=cwd, timeout=300)


def test_run_writes_svg_png_obj_that_other_tools_open(tmp_path):
    out = tmp_path / "basics"
    assert main(["run", "demo/basics", "--out", str(out), "--state", "--progress", "off"]) == 0
    cairosvg.svg2png(url=str(out / "outline.svg"), write_to=str(tmp_path / "o.png"))
    px = np.asarray(Image.open(tmp_path / "o.png").convert("L"))
    assert px.std() > 10                                    # not blank
    h = Image.open(out / "terrain_height.png")
    assert h.mode in ("I;16", "I;16B", "I") and np.asarray(h).max() > 255
    tess = trimesh.load(out / "tessellation.obj", force="mesh", process=False)
    info = json.loads((out / "run.json").read_text())
    assert len(tess.faces) == info["reports"]["tessellation.n_faces"]
    assert len(tess.vertices) == info["reports"]["tessellation.n_vertices"]
    glb = trimesh.load(out / "terrain.glb", force="mesh", process=False)
    assert len(glb.vertices) == 128 * 128
    assert info["seed"] == 7 and [s["rule"] for s in info["steps"]][:2] == ["points.poisson_disk", "mesh.delaunay"]
    assert (out / "state.npz").is_file()


def test_same_seed_same_bytes(tmp_path):
    for d in ("a", "b"):
        assert main(["run", "demo/basics", "--out", str(tmp_path / d), "--seed", "3", "--progress", "off"]) == 0
    for f in ("outline.svg", "terrain_height.png", "tessellation.obj", "terrain.glb", "terrain_color.png"):
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes(), f
    assert main(["run", "demo/basics", "--out", str(tmp_path / "c"), "--seed", "4", "--progress", "off"]) == 0
    assert (tmp_path / "a/outline.svg").read_bytes() != (tmp_path / "c/outline.svg").read_bytes()


def test_bad_recipe_one_line_error_and_nothing_written(tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text('[[steps]]\nrule = "points.poisson_disk"\nparams = { radius = -1 }\n')
    r = _cli("run", str(bad), "--out", str(tmp_path / "o"))
    assert r.returncode == 1
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert "bad.toml: steps[0] (points.poisson_disk): parameter 'radius'" in r.stderr
    assert not (tmp_path / "o").exists()
    r = _cli("check", str(bad), "--set", "steps.0.params.radius=0.2")
    assert r.returncode == 0 and "ok" in r.stdout
    r = _cli("run", "no/such/recipe")
    assert r.returncode == 1 and "no such recipe" in r.stderr
    bad.write_text("[[steps]\n")
    r = _cli("check", str(bad))
    assert r.returncode == 1 and "invalid TOML" in r.stderr and r.stderr.count("\n") == 1


def test_debug_shows_traceback(tmp_path):
    r = _cli("--debug", "run", "no/such/recipe")
    assert r.returncode != 0 and "Traceback" in r.stderr


def test_help_teaches_with_examples():
    r = _cli("--help")
    assert r.returncode == 0
    for word in ("run", "check", "rules", "recipes", "plugins", "gallery", "example"):
        assert word in r.stdout
    for sub in ("run", "check", "gallery", "rules"):
        r = _cli(sub, "--help")
        assert r.returncode == 0 and "example" in r.stdout


def test_rules_list_and_show(capsys):
    assert main(["rules", "list"]) == 0
    out = capsys.readouterr().out
    assert "points.poisson_disk" in out and "mesh.delaunay" in out
    assert main(["rules", "show", "points.poisson_disk"]) == 0
    out = capsys.readouterr().out
    assert "radius" in out and "(0, inf)" in out and "length" in out and "creates" in out
    assert main(["rules", "show", "points.poison_disk"]) == 1
    assert "did you mean 'points.poisson_disk'" in capsys.readouterr().err
    assert main(["recipes", "list"]) == 0
    assert "demo/basics" in capsys.readouterr().out


def _fake_plugin_dist(root: Path, name: str, body: str) -> None:
    """An installed-looking distribution whose entry point is a module of ours."""
    (root / f"{name}.py").write_text(textwrap.dedent(body))
    di = root / f"fake_{name}-1.0.dist-info"
    di.mkdir()
    (di / "METADATA").write_text(f"Metadata-Version: 2.1\nName: fake-{name}\nVersion: 1.0\n")
    (di / "entry_points.txt").write_text(f"[procgen]\n{name} = {name}\n")


def test_broken_plugin_is_reported_and_breaks_nothing(tmp_path):
    _fake_plugin_dist(tmp_path, "brokenplug", "raise ImportError('needs libfoo 9')\n")
    _fake_plugin_dist(tmp_path, "goodplug", """
        from dataclasses import dataclass
        from typing import ClassVar
        import procgen

        @dataclass(kw_only=True)
        class Hello(procgen.RuleBase):
            \"\"\"Says hello.\"\"\"
            name: ClassVar[str] = "hello.world"
            def step(self, state):
                return False

        @procgen.hookimpl
        def procgen_register_rules():
            return [Hello]
        """)
    env = {"PYTHONPATH": str(tmp_path) + os.pathsep + os.environ.get("PYTHONPATH", "")}
    r = _cli("plugins", env=env)
    assert r.returncode == 0
    assert "brokenplug" in r.stdout and "BROKEN" in r.stdout and "needs libfoo 9" in r.stdout
    r = _cli("rules", "list", env=env)
    assert r.returncode == 0 and "hello.world" in r.stdout and "points.poisson_disk" in r.stdout
    r = _cli("rules", "list", env={**env, "PROCGEN_DISABLE_PLUGINS": "goodplug,brokenplug"})
    assert r.returncode == 0 and "hello.world" not in r.stdout
    r = _cli("plugins", env={**env, "PROCGEN_DISABLE_PLUGINS": "goodplug"})
    assert "disabled by PROCGEN_DISABLE_PLUGINS" in r.stdout


def test_rules_show_wraps_every_range_and_choice_in_full(capsys, host):
    # the longest range/choices text of any rule's parameters must appear whole, and no line may
    # exceed the width (80 off a terminal): wrapped, not cut off
    longest = max(((cls, p) for cls in host.rules.values() for p in cls.parameters()),
                  key=lambda cp: len(cp[1].info.range_text()))
    cls, p = longest
    assert len(p.info.range_text()) > 40                      # a case that used to be cut at 28
    assert main(["rules", "show", cls.name]) == 0
    out = capsys.readouterr().out
    assert " ".join(p.info.range_text().split()) in " ".join(out.split())
    assert max(len(line) for line in out.splitlines()[1:]) <= 80


def test_recipes_list_describes_each_recipe_and_show_prints_steps(capsys, host):
    from procgen.recipes import list_recipes, read_toml

    assert main(["recipes", "list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    recipes = list_recipes(host)
    assert len(lines) == len(recipes)
    for line, (name, path) in zip(lines, recipes.items()):
        desc = read_toml(path)["recipe"]["description"]
        assert line.startswith(name) and desc in line
    assert main(["recipes", "show", "demo/basics"]) == 0
    out = capsys.readouterr().out
    data = read_toml(recipes["demo/basics"])
    for st in data["steps"]:
        assert st["rule"] in out
    for o in data["outputs"]:
        assert o["file"] in out and o["format"] in out
    assert data["recipe"]["description"].split()[0] in out
    assert main(["recipes", "show", "demo/basic"]) == 1
    assert "did you mean" in capsys.readouterr().err


def test_gallery_off_a_terminal_prints_one_line_per_finished_run(tmp_path):
    r = _cli("gallery", "--quick", "--only", "demo/*", "--jobs", "1", "--out", str(tmp_path / "g"))
    assert r.returncode == 0, r.stderr
    runs = [line for line in r.stderr.splitlines() if line.startswith("gallery [")]
    assert len(runs) == 1 and "demo-basics seed 7:" in runs[0] and runs[0].endswith(" s done")
    again = _cli("gallery", "--quick", "--only", "demo/*", "--jobs", "1", "--out", str(tmp_path / "g"))
    assert not [line for line in again.stderr.splitlines() if line.startswith("gallery [")]  # nothing ran
    assert "1 up to date" in again.stdout


def test_an_entry_needing_a_missing_extra_is_left_out_not_failed(tmp_path, host, monkeypatch):
    from procgen.gallery import build_gallery
    from procgen_wood import exposure

    monkeypatch.setattr(exposure, "ray_engine", lambda: None)     # as if neither embreex nor rtree
    rep = build_gallery(host, only=["weathering-exposure-on"], quick=True, out_dir=tmp_path / "g",
                        progress=False)
    assert rep.failed == [] and len(rep.left_out) == 1
    assert "procgen-rules[embree]" in rep.left_out[0].error and "left out" in rep.summary()
    assert "left out" in (tmp_path / "g" / "index.html").read_text()


def test_default_output_folder_stays_inside_out_whatever_the_recipe_name(tmp_path):
    for name, expect in (("/some/abs/dir", "some_abs_dir"), ("../../x", "x"), ("..", "recipe"),
                         ("cloud\x1b[2J", "cloud_2J")):
        recipe = tmp_path / "r.toml"
        recipe.write_text(f'[recipe]\nname = {json.dumps(name)}\n[[steps]]\nrule = "grid.noise"\n'
                          'params = { grid = "g", nx = 8, ny = 8 }\n[[outputs]]\ndomain = "g"\n'
                          'format = "heightmap_png16"\nfile = "h.png"\n')
        work = tmp_path / "work"
        work.mkdir(exist_ok=True)
        r = _cli("run", str(recipe), "--progress", "off", cwd=work)
        assert r.returncode in (0, 1), r.stderr
        if r.returncode == 0:
            assert (work / "out" / expect).is_dir(), (name, sorted(p.name for p in (work / "out").iterdir()))
        assert "\x1b" not in r.stdout + r.stderr
    assert not (tmp_path / "x").exists() and not Path("/some/abs/dir").exists()


def test_debug_internal_error_exits_3_with_the_traceback(monkeypatch, capsys):
    import procgen.cli as cli

    def boom(*a, **k):
        raise ZeroDivisionError("a bug")
    monkeypatch.setattr(cli, "_dispatch", boom)
    assert cli.main(["--debug", "plugins"]) == 3
    assert "Traceback" in capsys.readouterr().err
    assert cli.main(["plugins"]) == 3


def test_an_output_file_that_is_a_folder_or_the_runs_own_record_is_refused_at_check(tmp_path):
    for file, what in ((".", "must name a file"), ("sub/", "must name a file"), ("run.json", "own record"),
                       ("state.npz", "own record"), ("frames/x.png", "own record"), ("a\x1bb.png", "printable")):
        recipe = tmp_path / "r.toml"
        recipe.write_text('[[steps]]\nrule = "grid.noise"\nparams = { grid = "g", nx = 8, ny = 8 }\n'
                          f'[[outputs]]\ndomain = "g"\nformat = "heightmap_png16"\nfile = {json.dumps(file)}\n')
        r = _cli("check", str(recipe))
        assert r.returncode == 1 and what in r.stderr and len(r.stderr.strip().splitlines()) == 1, (file, r.stderr)
        assert "\x1b" not in r.stderr
