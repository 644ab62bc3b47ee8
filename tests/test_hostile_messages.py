"""Issue 36: what procgen prints about hostile or careless input names the file and the problem,
never an installed library's path, a warning's class or the file that raised it.

Found by running the issue's probes through the installed CLI: a recipe that is a FIFO was
"no such recipe", an SVG declaring an unknown encoding was an internal error (exit 3), a
Latin-1 OBJ needed an optional encoding-guessing module, warnings printed the site-packages
path and line that raised them.
"""
from __future__ import annotations

import builtins
import os
import re
import shutil
import subprocess
import sys
import sysconfig
import textwrap
from pathlib import Path

import pytest

import procgen
import procgen.errors
from procgen.cli import main
from procgen.errors import shown

NS = 'xmlns="http://www.w3.org/2000/svg"'
LEAK = re.compile(r"\w*(Error|Exception|Warning)\b|Traceback|site-packages|\.py\b")
CLI = [shutil.which("procgen")] if shutil.which("procgen") else \
    [sys.executable, "-c", "import sys; from procgen.cli import main; sys.exit(main(sys.argv[1:]))"]


def _one_line(capsys, argv: list[str], *needles: str) -> str:
    assert main(argv) == 1
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and err.startswith("procgen: error: "), err
    assert not LEAK.search(err.removeprefix("procgen: error: ")), err
    for n in needles:
        assert n in err, (n, err)
    return err


def test_a_recipe_that_is_a_fifo_or_a_folder_says_so(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    os.mkfifo("pipe.toml")
    (tmp_path / "dir.toml").mkdir()
    _one_line(capsys, ["check", "pipe.toml"], "pipe.toml: is a named pipe (FIFO), not a regular file")
    _one_line(capsys, ["run", "pipe.toml"], "pipe.toml: is a named pipe (FIFO)")     # opened non-blocking
    _one_line(capsys, ["check", "dir.toml"], "dir.toml: is a folder, not a regular file")
    _one_line(capsys, ["check", "missing.toml"], "missing.toml: no such recipe file or built-in recipe")


@pytest.mark.parametrize("encoding", ["x-no-such", "shift_jis"])
def test_an_svg_in_an_encoding_procgen_cannot_read_is_one_line(encoding, tmp_path, capsys):
    (tmp_path / "enc.svg").write_bytes(f'<?xml version="1.0" encoding="{encoding}"?><svg {NS} viewBox="0 0 9 9">'
                                       '<path d="M0 0 L1 1 L0 1 Z"/></svg>'.encode())
    (tmp_path / "r.toml").write_text('[[steps]]\nrule = "lines.load"\nparams = { file = "enc.svg" }\n')
    _one_line(capsys, ["check", str(tmp_path / "r.toml")], "steps[0] (lines.load)", "enc.svg",
              f"its encoding '{encoding}' is not one procgen reads; save it as UTF-8")


def test_an_svg_in_another_readable_encoding_loads():
    from procgen.exchange.svg_read import read_svg

    for enc in ("utf-16", "latin-1"):
        doc = f'<?xml version="1.0" encoding="{enc}"?><svg {NS} viewBox="0 0 9 9"><path d="M0 0 L1 1 L0 1 Z"/></svg>'
        (pts, closed), = read_svg(doc.encode(enc)).polylines
        assert closed and len(pts) == 3


def test_an_obj_that_is_not_utf8_loads_without_an_encoding_guesser(tmp_path, monkeypatch):
    """trimesh guesses a text file's encoding with charset_normalizer/chardet, which may be
    missing; procgen hands it UTF-8 (the odd bytes only sit in comments and names)."""
    from procgen.exchange.mesh_read import read_mesh

    path = tmp_path / "latin.obj"
    path.write_bytes(b"# caf\xe9 \xff\xfe\nmtllib caf\xe9.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
    real = builtins.__import__

    def no_guessers(name, *args, **kwargs):
        if name.split(".")[0] in ("charset_normalizer", "chardet"):
            raise ModuleNotFoundError(f"No module named {name!r}", name=name)
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_guessers)
    mesh = read_mesh(path)
    assert mesh.faces.tolist() == [[0, 1, 2]]


def test_installed_files_are_named_from_their_package(tmp_path, capsys, monkeypatch):
    site = sysconfig.get_path("purelib")
    assert shown(f"{site}/procgen/data/meshes/x.obj: bad\x1b[31m") == "installed procgen/data/meshes/x.obj: bad?[31m"
    # as if procgen were installed where this checkout is (a non-editable install)
    monkeypatch.setattr(procgen.errors, "installed_roots", lambda: (str(Path(procgen.__file__).parents[1]),))
    (tmp_path / "r.toml").write_text('[[steps]]\nrule = "mesh.load"\nparams = { path = "nope.obj" }\n')
    err = _one_line(capsys, ["check", str(tmp_path / "r.toml")], "nope.obj", "the shipped meshes")
    assert str(Path(procgen.__file__).parent) not in err


NOISY = '''
import warnings
from dataclasses import dataclass
from typing import ClassVar
import numpy as np
import procgen

@dataclass(kw_only=True)
class Noisy(procgen.RuleBase):
    """Warns as libraries do: a UserWarning and a numpy RuntimeWarning."""
    name: ClassVar[str] = "noisy.warn"
    def step(self, state):
        warnings.warn("careful: the thing is odd")
        np.array([1e308]) * 10
        return False

@procgen.hookimpl
def procgen_register_rules():
    return [Noisy]
'''


def test_warnings_are_one_line_naming_neither_class_nor_file(tmp_path):
    (tmp_path / "noisy_rule.py").write_text(textwrap.dedent(NOISY))
    info = tmp_path / "noisy-1.0.dist-info"
    info.mkdir()
    (info / "METADATA").write_text("Metadata-Version: 2.1\nName: noisy\nVersion: 1.0\n")
    (info / "entry_points.txt").write_text("[procgen]\nnoisy = noisy_rule\n")
    (tmp_path / "r.toml").write_text('[[steps]]\nrule = "noisy.warn"\n')
    env = {**os.environ, "PYTHONPATH": str(tmp_path)}

    def cli(*args: str) -> list[str]:
        r = subprocess.run([*CLI, *args], capture_output=True, text=True, cwd=tmp_path, env=env, timeout=300)
        assert r.returncode == 0, r.stderr
        return [line for line in r.stderr.splitlines() if "warning" in line]

    assert cli("run", "r.toml", "--out", "o") == ["procgen: warning: careful: the thing is odd",
                                                  "procgen: warning: overflow encountered in multiply"]
    lines = cli("sweep", "r.toml", "--seeds", "1-2", "--jobs", "2", "--out", "s")     # in worker processes
    assert sorted(lines) == [f"procgen: warning: base/seed-{s}: {text}" for s in (1, 2)
                             for text in ("careful: the thing is odd", "overflow encountered in multiply")]


def _grid_recipe(tmp_path: Path, outputs: str) -> str:
    (tmp_path / "r.toml").write_text('[[steps]]\nrule = "grid.noise"\nparams = { nx = 8, ny = 8 }\n'
                                     '[[steps]]\nrule = "grid.to_mesh"\nparams = { grid = "terrain", mesh = "m" }\n'
                                     + outputs)
    return str(tmp_path / "r.toml")


@pytest.mark.parametrize("key", ["width", "height"])
def test_a_preview_of_no_pixels_is_refused_at_check(key, tmp_path, capsys):
    """An exporter option's declared range (Annotated[int, ParamInfo(ge=1)]) is checked before
    compute; the exporter used to fail after it with a library's exception class."""
    recipe = _grid_recipe(tmp_path, f'[[outputs]]\ndomain = "m"\nformat = "preview_png"\nfile = "p.png"\n'
                                    f'options = {{ {key} = 0 }}\n')
    _one_line(capsys, ["check", recipe], "outputs[0]", "preview_png", f"option '{key}': 0 is outside the allowed "
              "range [1, inf)")


def test_an_unknown_colour_map_is_named_short(tmp_path, capsys):
    recipe = _grid_recipe(tmp_path, '[[outputs]]\ndomain = "terrain"\nformat = "image_png"\nfile = "a.png"\n'
                                    f'options = {{ field = "surface__height", cmap = "{"x" * 5000}" }}\n')
    err = _one_line(capsys, ["run", recipe, "--out", str(tmp_path / "o")], "unknown colour map 'xxx", "...'")
    assert len(err) < 300 and "matplotlib" not in err


@pytest.mark.parametrize("argv", [["sweep", "demo/basics", "--seeds", "1", "--jobs", "1"],
                                  ["gallery", "--only", "no-such-entry*", "--jobs", "1"],
                                  ["run", "demo/basics"]])
def test_an_output_folder_that_cannot_be_made_is_one_line(argv, tmp_path, capsys, monkeypatch):
    """A batch's folder under a file (or on a read-only disk) was an internal error for sweep and
    gallery; now each says which folder and why, before any run."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "afile").write_text("")
    _one_line(capsys, [*argv, "--out", "afile/out"], "afile/out: cannot write (afile is a file, not a folder)")
