"""``procgen check`` is bounded: hostile or careless recipes get one line (exit 1) before compute.

Issue 36's probes: TOML nested 10,000 deep, a million steps, fuzzed numbers in every numeric
parameter of every registered rule, memory estimates of steps, frames and outputs, sweeps of a
billion seeds, and the exit code of an internal error under --debug. The CLI probes run in a
child under a small address-space limit (RLIMIT_AS), so an estimate that let compute start would
die of MemoryError (exit 3) instead of passing slowly.
"""
from __future__ import annotations

import copy
import dataclasses
import math
import subprocess
import sys
import typing
from pathlib import Path

import pytest

from procgen.errors import ProcgenError
from procgen.params import DEFAULT_BOUND, DEFAULT_INT_BOUND, param_info
from procgen.plugins import get_plugin_manager
from procgen.recipes import check_recipe
from procgen.rules import type_hints

ROOT = Path(__file__).resolve().parents[1]
LIMIT_AS = 3 << 30     # the child's address space: the probes ask for hundreds of GiB


def _cli(*args: str, cwd: Path) -> subprocess.CompletedProcess:
    code = ("import resource, sys; resource.setrlimit(resource.RLIMIT_AS, (%d, %d)); "
            "from procgen.cli import main; sys.exit(main(sys.argv[1:]))" % (LIMIT_AS, LIMIT_AS))
    return subprocess.run([sys.executable, "-c", code, *args], capture_output=True, text=True,
                          cwd=cwd, timeout=600)


def _refused(r: subprocess.CompletedProcess, *words: str) -> str:
    """Exit 1 with exactly one line on stderr containing ``words``; returns the line."""
    assert r.returncode == 1, (r.returncode, r.stderr[-2000:])
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr[-2000:]
    line = lines[0]
    assert line.startswith("procgen: error: "), line
    for w in words:
        assert w in line, (w, line)
    for leak in ("Traceback", "Error:", "Exception", "numpy", "tomllib", "site-packages"):
        assert leak not in line, line
    return line


def _write(path: Path, text: str) -> Path:
    path.write_text(text, encoding="utf-8")
    return path


# -- nesting and counts ----------------------------------------------------------------------------
def test_toml_nested_10000_deep_is_one_line(tmp_path):
    deep = "[" * 10_000 + "]" * 10_000
    f = _write(tmp_path / "deep.toml", f"[[steps]]\nrule = 'grid.noise'\nparams = {{ nx = {deep} }}\n")
    _refused(_cli("check", str(f), cwd=tmp_path), "deep.toml", "nested more than 32 levels")


def test_nesting_below_the_parsers_limit_names_the_key(tmp_path):
    f = _write(tmp_path / "d40.toml", "[[steps]]\nrule = 'grid.noise'\nparams = { nx = "
               + "[" * 40 + "]" * 40 + " }\n")
    _refused(_cli("check", str(f), cwd=tmp_path), "d40.toml", "steps[0].params.nx[0]", "nested more than 32")


def test_set_value_nested_deep_is_one_line(tmp_path):
    r = _cli("check", "demo/basics", "--set", "steps.0.params.x=" + "[" * 5000 + "]" * 5000, cwd=tmp_path)
    _refused(r, "--set steps.0.params.x", "nested more than 32")


def test_a_million_steps_is_refused_unparsed(tmp_path):
    f = _write(tmp_path / "million.toml", "[[steps]]\nrule = 'grid.noise'\n" * 1_000_000)
    _refused(_cli("check", str(f), cwd=tmp_path), "million.toml", "more than 10000 [[steps]] tables")


def test_steps_over_the_count_are_refused_in_any_form(tmp_path):
    tables = _write(tmp_path / "t.toml", "[[steps]]\nrule = 'grid.noise'\n" * 10_001)
    _refused(_cli("check", str(tables), cwd=tmp_path), "t.toml", "10001 [[steps]] tables")
    inline = _write(tmp_path / "i.toml", "steps = [" + ", ".join(["{rule = 'grid.noise'}"] * 10_001) + "]\n")
    _refused(_cli("check", str(inline), cwd=tmp_path), "i.toml", "10001 steps")


def test_integer_with_thousands_of_digits_is_one_line(tmp_path):
    f = _write(tmp_path / "digits.toml", "[[steps]]\nrule = 'ca.life'\nparams = { initial_age = "
               + "9" * 5000 + " }\n")
    _refused(_cli("check", str(f), cwd=tmp_path), "digits.toml", "integer with thousands of digits")


def test_recipe_that_is_not_a_regular_file(tmp_path):
    import os

    os.mkfifo(tmp_path / "pipe.toml")
    from procgen.errors import RecipeError
    from procgen.recipes import read_toml

    with pytest.raises(RecipeError, match="not a regular file"):
        read_toml(tmp_path / "pipe.toml")        # opened non-blocking: never hangs


def test_iterations_and_seeds_are_bounded(tmp_path):
    host = get_plugin_manager()
    steps = [{"rule": "grid.noise", "params": {"nx": 4, "ny": 4}, "iterations": 2**63}]
    with pytest.raises(ProcgenError, match=r"steps\[0\] \(grid.noise\): iterations: .* more than"):
        check_recipe({"steps": steps}, host, "it.toml")
    with pytest.raises(ProcgenError, match=r"\[recipe\] seed"):
        check_recipe({"recipe": {"seed": 2**64}, "steps": steps[:1]}, host, "s.toml")
    _refused(_cli("run", "demo/basics", "--seed", str(2**64), "--out", str(tmp_path / "o"), cwd=tmp_path),
             "--seed")
    assert not (tmp_path / "o").exists()


# -- fuzzed numbers in every numeric parameter -----------------------------------------------------
def _numeric(tp: typing.Any) -> bool:
    if tp in (int, float):
        return True
    return any(_numeric(a) for a in typing.get_args(tp) if a is not Ellipsis)


def _declared_upper(info) -> float | None:
    return info.le if info.le is not None else info.lt


HUGE = [2**63, -(2**63) - 1, 2**64, 10**30, 1e300, -1e300, 1e15, 1e12, float("nan"), float("inf"), float("-inf")]
SMALL = [-1, 0, -1.0, 0.0, 1e-300]


def _shaped(default: typing.Any, value: typing.Any) -> typing.Any:
    """``value`` where the default has numbers (every number of a list replaced), or bare."""
    if isinstance(default, (list, tuple)) and default:
        return [_shaped(d, value) for d in default]
    if isinstance(default, dict) and default:
        return {k: _shaped(v, value) for k, v in default.items()}
    return value


def _cases():
    host = get_plugin_manager()
    for name, cls in host.rules.items():
        hints = type_hints(cls)
        for f in dataclasses.fields(cls):
            if _numeric(hints.get(f.name)) and param_info(f).choices is None:
                yield name, f.name


@pytest.mark.parametrize("rule,key", list(_cases()))
def test_fuzzed_numbers_are_refused_in_one_line_or_accepted(rule, key):
    host = get_plugin_manager()
    cls = host.rule(rule)
    f = next(x for x in dataclasses.fields(cls) if x.name == key)
    default = f.default if f.default is not dataclasses.MISSING else (
        f.default_factory() if f.default_factory is not dataclasses.MISSING else None)
    base = [copy.deepcopy(dict(s)) for s in cls.example] or [{"rule": rule}]
    info = param_info(f)
    for value in HUGE + SMALL:
        steps = copy.deepcopy(base)
        steps[-1].setdefault("params", {})[key] = _shaped(default, value)
        try:
            check_recipe({"steps": steps}, host, "fuzz.toml")
        except ProcgenError as exc:
            text = str(exc)
            assert "\n" not in text and text.startswith("fuzz.toml: steps["), text
            continue
        # accepted: then the number is finite and inside the declared range or the default bound
        assert isinstance(value, int) or math.isfinite(value), (rule, key, value)
        upper = _declared_upper(info)
        most = upper if upper is not None else (DEFAULT_INT_BOUND if isinstance(value, int) else DEFAULT_BOUND)
        assert abs(value) <= max(most, abs(info.ge or 0), abs(info.gt or 0)), (rule, key, value)


def test_issue_probes_are_refused_by_name(tmp_path):
    host = get_plugin_manager()
    life = [{"rule": "grid.noise", "params": {"nx": 8, "ny": 8}},
            {"rule": "ca.life", "params": {"cells": "terrain", "initial_age": 2**63}}]
    with pytest.raises(ProcgenError, match=r"steps\[1\] \(ca.life\): parameter 'initial_age': .* beyond 2\^32"):
        check_recipe({"steps": life}, host, "age.toml")
    pts = [{"rule": "points.poisson_disk", "params": {"radius": 1e12}}]
    with pytest.raises(ProcgenError, match=r"parameter 'radius': 1e\+12 is beyond 1e\+09"):
        check_recipe({"steps": pts}, host, "r.toml")
    water = [{"rule": "water.surface", "params": {"base_smoothness": 1e15}}]
    with pytest.raises(ProcgenError, match=r"parameter 'base_smoothness': 1e\+15 is beyond"):
        check_recipe({"steps": water}, host, "w.toml")


# -- memory estimates ------------------------------------------------------------------------------
def test_image_png_scale_is_refused_with_its_estimate(tmp_path):
    line = _refused(_cli("check", "demo/basics", "--set", "outputs.3.options.scale=100000", cwd=tmp_path),
                    "outputs[3] 'terrain_color.png' (image_png): needs about", "GiB", "scale = 100000",
                    "more than the", "lower option 'scale'")
    r = _cli("run", "demo/basics", "--set", "outputs.3.options.scale=100000", "--out", str(tmp_path / "o"),
             cwd=tmp_path)
    assert _refused(r) == line and not (tmp_path / "o").exists()   # refused by run too, before compute


def test_preview_of_a_million_pixels_wide_is_refused(tmp_path):
    _refused(_cli("run", "demo/basics", "--set", "outputs.6.options.width=1000000", "--out", str(tmp_path / "o"),
                  cwd=tmp_path),
             "outputs[6] 'terrain_preview.png' (preview_png): needs about", "1000000 x 480 pixels",
             "lower options 'width' and 'height'")


FRAMES = """\
[[steps]]
id = "ground"
rule = "grid.noise"
params = {{ nx = {n}, ny = {n} }}

[[steps]]
id = "life"
rule = "ca.life"
params = {{ cells = "terrain" }}
iterations = {it}
frames = {{ every = 1, domain = "terrain", format = "image_png", options = {{ field = "surface__height"{opt} }} }}
"""


def test_frames_kept_in_memory_are_counted(tmp_path):
    many = _write(tmp_path / "many.toml", FRAMES.format(n=64, it=20_000, opt=""))
    _refused(_cli("check", str(many), cwd=tmp_path), "many.toml: steps[1] 'life' (ca.life): frames: 20,000 frames",
             "more than the 10,000")
    big = _write(tmp_path / "big.toml", FRAMES.format(n=1024, it=2000, opt=", scale = 4"))
    _refused(_cli("run", str(big), "--out", str(tmp_path / "o"), cwd=tmp_path),
             "big.toml: steps[1] 'life' (ca.life): frames: ", "2,000 frames of scale = 4", "raise 'every'")
    ok = _write(tmp_path / "ok.toml", FRAMES.format(n=64, it=3, opt=""))
    r = _cli("run", str(ok), "--out", str(tmp_path / "ok"), cwd=tmp_path)
    assert r.returncode == 0, r.stderr
    assert len(list((tmp_path / "ok" / "frames").rglob("*.png"))) == 3


def test_an_image_too_large_for_the_address_space_is_refused_at_check(tmp_path):
    from PIL import Image

    Image.new("L", (9_500, 9_500), 128).save(tmp_path / "huge.png")      # 90 Mpx, under the decode limit
    f = _write(tmp_path / "img.toml", "[[steps]]\nid = 'ground'\nrule = 'grid.noise'\nparams = { nx = 64, ny = 64 }\n"
               "[[steps]]\nid = 'paint'\nrule = 'grid.image_field'\nparams = { file = 'huge.png', field = 'paint__w' }\n")
    # under a 3 GiB address space the 2.7 GiB estimate does not fit beside the interpreter
    _refused(_cli("run", str(f), "--out", str(tmp_path / "o"), cwd=tmp_path),
             "img.toml: steps[1] 'paint' (grid.image_field): needs about 2.7 GiB", "GiB this machine can give")
    assert not (tmp_path / "o").exists()


def test_mesh_inputs_are_checked_before_compute(tmp_path):
    # a missing mesh after a (slow) water step: reported by check, naming the step and the file
    steps = [{"rule": "water.surface", "params": {"nx": 64, "ny": 64}},
             {"id": "model", "rule": "mesh.load", "params": {"path": "no-such.obj"}}]
    with pytest.raises(ProcgenError, match=r"m.toml: steps\[1\] \(mesh.load\): .*'no-such.obj' not found"):
        check_recipe({"steps": steps}, get_plugin_manager(), "m.toml", tmp_path)
    # a 10M-face mesh: its face count read at check, the load refused under a 3 GiB address space
    (tmp_path / "big.obj").write_bytes(b"v 0 0 0\nv 1 0 0\nv 0 1 0\n" + b"f 1 2 3\n" * 10_000_000)
    f = _write(tmp_path / "big.toml", "[[steps]]\nrule = 'mesh.load'\nparams = { path = 'big.obj' }\n")
    _refused(_cli("run", str(f), "--out", str(tmp_path / "o"), cwd=tmp_path),
             "big.toml: steps[0] (mesh.load):", "10,000,000 faces", "GiB")


def test_a_bad_field_name_in_a_parameter_is_one_line_naming_the_step():
    steps = [{"rule": "grid.noise", "params": {"nx": 8, "ny": 8}},
             {"rule": "grid.image_field", "params": {"file": "data/weak-map.png", "field": "w"}}]
    with pytest.raises(ProcgenError, match=r"^f.toml: steps\[1\] \(grid.image_field\): field name 'w' must") as info:
        check_recipe({"steps": steps}, get_plugin_manager(), "f.toml", ROOT / "rules")
    assert "Error" not in str(info.value)


def test_sizes_flow_from_a_generator_to_later_outputs(monkeypatch):
    from procgen import recipes
    from procgen.budget import Budget

    host = get_plugin_manager()
    data = {"steps": [{"rule": "grid.noise", "params": {"nx": 300, "ny": 200}},
                      {"rule": "grid.to_mesh"}],
            "outputs": [{"domain": "terrain_mesh", "format": "glb"}]}
    recipe = check_recipe(data, host, "flow.toml")
    budget = Budget("flow.toml", 1 << 60)
    for st in recipe.steps:
        budget.step(st)
    assert budget.sizes == {"terrain": 60_000, "terrain_mesh": 60_000}
    # grid.noise holds 11.0 MiB; the GLB of its 60,000-vertex mesh needs 13.7 MiB more
    monkeypatch.setattr(recipes, "memory_limit_bytes", lambda: 20_000_000)
    with pytest.raises(ProcgenError, match=r"flow.toml: outputs\[0\] 'terrain_mesh.glb' \(glb\): brings the "
                                           r"run to about 24\.7 MiB \(this part 13\.7 MiB; 60,000 "
                                           r"elements\), more than the 19\.1 MiB"):
        check_recipe(data, host, "flow.toml")
    data["outputs"] = []
    check_recipe(data, host, "flow.toml")


def test_sweep_of_a_billion_seeds_and_a_huge_grid(tmp_path):
    _refused(_cli("sweep", "demo/basics", "--seeds", "1-1000000000", "--out", str(tmp_path / "s"), cwd=tmp_path),
             "--seeds '1-1000000000': 1,000,000,000 seeds, more than the 100,000 runs")
    values = ",".join(str(i) for i in range(2, 500))
    _refused(_cli("sweep", "demo/basics", "--grid", f"steps.terrain.params.nx={values}",
                  "--grid", f"steps.terrain.params.ny={values}", "--out", str(tmp_path / "s"), cwd=tmp_path),
             "--grid: 498 x 498 values x 1 seeds is more than a sweep may have")
    _refused(_cli("sweep", "demo/basics", "--seeds", "99999999999999999999", "--out", str(tmp_path / "s"),
                  cwd=tmp_path), "above 2^63 - 1")
    assert not (tmp_path / "s").exists()


def test_debug_keeps_exit_3_for_an_internal_error(monkeypatch, capsys):
    from procgen import cli

    def broken(*args, **kwargs):
        raise ZeroDivisionError("a bug")

    monkeypatch.setattr(cli, "_dispatch", broken)
    assert cli.main(["--debug", "check", "demo/basics"]) == 3
    assert "Traceback" in capsys.readouterr().err
    assert cli.main(["check", "demo/basics"]) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("procgen: internal error:")
