"""Every command example in README.md, docs/, the recipe and plugin READMEs and every ``--help``
text works: a documented command that fails is a bug here, not a surprise for a new user.

Each example is taken from the text, never retyped. Cheap commands really run; a ``run`` or
``sweep`` example is checked with ``procgen check`` on the same recipe with the same overrides (a
sweep's every grid value), a ``gallery`` example lists its entries with the same filters; the
README's sample recipe is the ``my.toml`` of the examples and really runs. Commands that need
what a test cannot have (a dask scheduler, a package install) are named in SKIPPED below.
"""
from __future__ import annotations

import re
import shlex
from pathlib import Path

import pytest

from procgen.cli import _parser, main
from procgen.sweep import parse_seeds

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md")), ROOT / "rules" / "README.md",
        *sorted((ROOT / "examples").glob("*/README.md"))]
#: options that need what a test cannot have; an example using one is still checked without it
UNREACHABLE = {"--scheduler"}            # a running dask scheduler
#: commands checked elsewhere: new-plugin in test_scaffold (it installs the package it writes)
PLUGIN_RULES = {"lichen.diffuse"}        # the rule `procgen new-plugin lichen` writes


def _doc_commands() -> list[tuple[str, str]]:
    """(where, command) for every ``procgen ...`` in an indented block or inline code of the docs."""
    found = []
    for path in DOCS:
        text = path.read_text(encoding="utf-8")
        for n, line in enumerate(text.splitlines(), 1):
            m = re.match(r"^ {4,}(procgen [^#]*?)(?: {2,}.*)?$", line)
            cmds = [m.group(1)] if m else []
            cmds += re.findall(r"`(procgen [^`]*)`", line)
            found += [(f"{path.relative_to(ROOT)}:{n}", c.strip()) for c in cmds]
    return found


def _help_commands() -> list[tuple[str, str]]:
    """(where, command) for every example line of ``procgen --help`` and each subcommand's help."""
    parser = _parser()
    texts = [("procgen --help", parser.format_help())]
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    texts += [(f"procgen {name} --help", p.format_help()) for name, p in sub.choices.items()]
    found = []
    for where, text in texts:
        for line in text.split("example")[-1].splitlines():
            m = re.match(r"^\s+(procgen \S.*?)(?: {2,}.*)?$", line)
            if m:
                found.append((where, m.group(1).strip()))
    return found


EXAMPLES = sorted(set(_doc_commands() + _help_commands()))


def _sample_recipe(tmp: Path) -> Path:
    text = (ROOT / "README.md").read_text(encoding="utf-8")
    block = re.search(r"## Recipes.*?```toml\n(.*?)```", text, re.S).group(1)
    path = tmp / "my.toml"
    path.write_text(block, encoding="utf-8")
    return path


def _options(args: list[str], name: str) -> list[str]:
    return [args[i + 1] for i, a in enumerate(args[:-1]) if a == name]


def _mention(args: list[str]) -> bool:
    """True for a command named without the arguments it needs (``procgen rules show`` in a
    sentence); asserts that the command and its subcommand exist."""
    parser = _parser()
    sub = next(a for a in parser._actions if a.__class__.__name__ == "_SubParsersAction")
    if not args or args[0] not in sub.choices:
        pytest.fail(f"no command {' '.join(args)!r}")
    needs = {"run": 2, "check": 2, "sweep": 2, "new-plugin": 2, "rules show": 3, "recipes show": 3}
    key = " ".join(args[:2]) if " ".join(args[:2]) in needs else args[0]
    if len(args) < needs.get(key, 0):
        if len(args) == 2:
            inner = next(a for a in sub.choices[args[0]]._actions if a.__class__.__name__ == "_SubParsersAction")
            assert args[1] in inner.choices
        return True
    return False


def _check(recipe: str, sets: list[str], capsys) -> None:
    assert main(["check", recipe, *[x for s in sets for x in ("--set", s)]]) == 0, capsys.readouterr().err


def test_the_docs_and_help_have_examples():
    wheres = {w.split(":")[0] for w, _ in EXAMPLES}
    assert "README.md" in wheres and "procgen --help" in wheres and "procgen sweep --help" in wheres
    assert len(EXAMPLES) >= 25


@pytest.mark.parametrize("where,command", EXAMPLES, ids=[f"{w}: {c}" for w, c in EXAMPLES])
def test_example_works(where, command, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(ROOT)                 # paths in examples are relative to a checkout
    sample = _sample_recipe(tmp_path)
    args = [{"~/src": str(tmp_path / "src"), "my.toml": str(sample)}.get(a, a) for a in shlex.split(command)[1:]]
    if args and args[0] in ("-h", "--help"):
        with pytest.raises(SystemExit) as ex:
            main(args)
        assert ex.value.code == 0
        return
    if _mention(args):          # prose naming a command (`procgen check`): the command must exist
        return
    placeholder = [a for a in args if a.isupper() and a.isalpha()]     # `rules show NAME`
    if placeholder:
        assert args[:2] in (["rules", "show"], ["recipes", "show"]), f"{where}: {command}"
        return
    for opt in UNREACHABLE & set(args):
        i = args.index(opt)
        del args[i:i + 2]
    cmd = args[0] if args else ""
    if cmd == "run":
        _check(args[1], _options(args, "--set"), capsys)
        seed = _options(args, "--seed")
        assert all(s.isdigit() for s in seed)
    elif cmd == "sweep":
        parse_seeds(_options(args, "--seeds")[0] if "--seeds" in args else "1")
        for axis in _options(args, "--grid"):
            key, values = axis.split("=", 1)
            for v in values.split(","):
                _check(args[1], [f"{key}={v}"], capsys)
    elif cmd == "gallery":
        only = [x for p in _options(args, "--only") for x in ("--only", p)]
        assert main(["gallery", "--list", *only]) == 0
        assert capsys.readouterr().out.strip(), f"{where}: {command} selects no entry"
    elif cmd == "rules" and args[1:2] == ["show"] and args[2] in PLUGIN_RULES:
        from procgen.scaffold import new_plugin

        written = new_plugin(args[2].split(".")[0], tmp_path / "scaffold")
        assert any(args[2] in p.read_text() for p in written.rglob("*.py"))
    elif cmd in ("new-plugin", "check", "rules", "recipes", "plugins", "exporters"):
        code = main(args)
        assert code == 0, f"{where}: {command} -> exit {code}: {capsys.readouterr().err}"
    else:
        pytest.fail(f"{where}: {command}: no rule to check this example; add one here")


def test_the_readme_sample_recipe_runs_and_writes_every_output(tmp_path, monkeypatch):
    import tomllib

    monkeypatch.chdir(tmp_path)
    recipe = _sample_recipe(tmp_path)
    assert main(["run", str(recipe), "--out", "o", "--progress", "off"]) == 0
    for out in tomllib.loads(recipe.read_text())["outputs"]:
        assert (tmp_path / "o" / out["file"]).stat().st_size > 0
