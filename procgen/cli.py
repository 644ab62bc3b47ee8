"""The ``procgen`` command: a thin layer over the library (every command is an API call)."""
from __future__ import annotations

import argparse
import json
import os
import sys
import re
import textwrap
import traceback
import warnings
from pathlib import Path
from typing import TYPE_CHECKING, Sequence

from .errors import ProcgenError, RecipeError, printable, shown

if TYPE_CHECKING:
    from .recipes import Recipe

EPILOG = """\
examples:
  procgen gallery                                   render every built-in gallery entry
  procgen run demo/basics --out out/basics          run a built-in recipe, write its files
  procgen run my.toml --seed 3 --set steps.0.params.radius=0.01
  procgen check my.toml                             validate a recipe without running it
  procgen rules list                                every registered rule
  procgen rules show points.poisson_disk            parameters, ranges, units, fields
  procgen recipes list                              built-in and plugin recipes, one line each
  procgen recipes show clouds/fig-4-3a              figure, description, steps and outputs
  procgen plugins                                   loaded plugins, and why a broken one failed
  procgen sweep demo/basics --grid "steps.0.params.radius=0.05,0.1" --seeds 1-4
  procgen new-plugin lichen --dir ~/src              start an outside plugin package
"""


def _parser() -> argparse.ArgumentParser:
    from . import __version__

    p = argparse.ArgumentParser(
        prog="procgen", formatter_class=argparse.RawDescriptionHelpFormatter, epilog=EPILOG,
        description="Grow natural-looking content from simple local rules: snaxel clouds (SVG), "
                    "eroded multi-layer surfaces (heightmaps), cellular automata on meshes (OBJ/GLB).")
    p.add_argument("--version", action="version", version=f"procgen {__version__}")
    p.add_argument("--debug", action="store_true", help="show full tracebacks on errors")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    def cmd(name: str, help_: str, example: str) -> argparse.ArgumentParser:
        sp = sub.add_parser(name, help=f"{help_}  (e.g. {example})", description=help_,
                            epilog=f"example:\n  {example}", formatter_class=argparse.RawDescriptionHelpFormatter)
        sp.add_argument("--debug", action="store_true", default=argparse.SUPPRESS, help=argparse.SUPPRESS)
        return sp

    r = cmd("run", "Run a recipe and write its outputs plus run.json.",
            "procgen run demo/basics --seed 3 --out out/basics")
    r.add_argument("recipe", help="recipe file (.toml) or built-in name such as demo/basics")
    r.add_argument("--seed", type=int, help="override the recipe's seed")
    r.add_argument("--out", type=Path, help="output folder (default: out/<recipe name>)")
    r.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override a recipe value, e.g. steps.0.params.radius=0.01 (repeatable)")
    r.add_argument("--state", action="store_true", help="also write state.npz (every field)")
    r.add_argument("--progress", choices=("auto", "on", "off"), default="auto", help="progress bars")

    c = cmd("check", "Validate a recipe (names, types, ranges, data flow) without running it.",
            "procgen check rules/demo/basics.toml --set steps.0.params.radius=0.1")
    c.add_argument("recipe")
    c.add_argument("--set", action="append", default=[], metavar="KEY=VALUE")

    ru = cmd("rules", "List registered rules or show one rule's parameters.", "procgen rules show mesh.delaunay")
    ru_sub = ru.add_subparsers(dest="rules_cmd", metavar="list|show")
    ru_sub.add_parser("list", help="every rule with its one-line summary")
    show = ru_sub.add_parser("show", help="one rule's parameters, ranges, units and fields")
    show.add_argument("name")

    rc = cmd("recipes", "List built-in and plugin recipes, or show one.", "procgen recipes show demo/basics")
    rc_sub = rc.add_subparsers(dest="recipes_cmd", metavar="list|show")
    rc_sub.add_parser("list", help="every recipe with its one-line description")
    rshow = rc_sub.add_parser("show", help="one recipe's figure, description, steps and outputs")
    rshow.add_argument("name", help="a recipe name (procgen recipes list) or a .toml file")

    cmd("plugins", "List plugins, their rules, and the reason a broken plugin failed.", "procgen plugins")
    cmd("exporters", "List output formats and the domains they write.", "procgen exporters")

    g = cmd("gallery", "Render every gallery entry (parallel, resumable) and write index.html.",
            "procgen gallery --quick --jobs 2 --only clouds/*")
    g.add_argument("--only", action="append", default=[], metavar="PATTERN",
                   help="glob on recipe names or titles (repeatable)")
    g.add_argument("--jobs", type=int, default=max(1, (os.cpu_count() or 1)), help="parallel processes")
    g.add_argument("--quick", action="store_true", help="small sizes for a fast check (CI)")
    g.add_argument("--scale", choices=["thesis"], default=None,
                   help="run the entries that are smaller than the thesis by default at the thesis's "
                        "own size (into gallery/out-thesis)")
    g.add_argument("--out", type=Path, default=None, help="output folder (default gallery/out)")
    g.add_argument("--force", action="store_true", help="re-render entries that are up to date")
    g.add_argument("--list", action="store_true", help="list the entries and exit")
    g.add_argument("--scheduler", metavar="ADDRESS",
                   help="render on a dask.distributed cluster (tcp://host:8786); needs the dask extra")
    sw = cmd("sweep", "Run a recipe over a grid of parameter values and seeds; write summary.csv.",
             'procgen sweep clouds/fig-4-3a --grid "steps.grow.params.n_c=2,4,8" --seeds 1-100')
    sw.add_argument("recipe")
    sw.add_argument("--grid", action="append", default=[], metavar="KEY=V1,V2,...",
                    help="a parameter axis (repeatable; the sweep is their product)")
    sw.add_argument("--seeds", default="1", help="seeds: N, A-B or a comma list (default 1)")
    sw.add_argument("--out", type=Path, default=None, help="output folder (default out/sweep-<recipe>)")
    sw.add_argument("--jobs", type=int, default=max(1, (os.cpu_count() or 1)), help="local processes")
    sw.add_argument("--scheduler", metavar="ADDRESS",
                    help="run on a dask.distributed cluster (tcp://host:8786); needs the dask extra")
    sw.add_argument("--force", action="store_true", help="re-run runs that are already done")

    np_ = cmd("new-plugin", "Write a ready-to-install plugin package with one rule, recipe and test.",
              "procgen new-plugin lichen --dir ~/src")
    np_.add_argument("name", help="family name: lower case letters, digits and _ (e.g. lichen)")
    np_.add_argument("--dir", type=Path, default=Path("."), help="where to create procgen-NAME/")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    parser = _parser()
    args = parser.parse_args(argv)
    if args.command is None:
        parser.print_help()
        return 0
    with warnings.catch_warnings():      # restores the warning display when main returns
        if not args.debug:
            warnings.showwarning = show_warning
        return _main(args, parser)


def show_warning(message: Warning | str, category: type[Warning], filename: str, lineno: int,
                 file: object = None, line: str | None = None) -> None:
    """A warning (ours, a plugin's or a library's) as one line ``procgen: warning: ...``: its
    text only, never the warning's class or the file and line that raised it (an installed
    library's site-packages path); ``--debug`` keeps Python's own display."""
    print(f"procgen: warning: {_one_line(str(message))}", file=sys.stderr)


def _main(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    try:
        return _dispatch(args, parser)
    except ProcgenError as exc:
        if args.debug:
            traceback.print_exc()
        print(f"procgen: error: {_one_line(str(exc))}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print("procgen: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:  # `procgen rules list | head`: the reader left, not an error
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
        return 0
    except Exception as exc:  # a bug, not bad input: still one line, the traceback with --debug
        if args.debug:
            traceback.print_exc()
            return 3
        print(f"procgen: internal error: {type(exc).__name__}: {_one_line(str(exc))} "
              "(run again with --debug for the traceback)", file=sys.stderr)
        return 3


def _one_line(text: str) -> str:
    """``text`` on one line, control characters (terminal escapes) shown as ``?`` and installed
    packages' files named from their package (:func:`procgen.errors.shown`)."""
    return shown(" ".join(text.split()))


def default_out(name: str, root: Path = Path("out")) -> Path:
    """``out/<name>`` for a recipe's name, sanitised so that it stays inside ``out``: a name such
    as ``/etc`` or ``../../x`` is a name, never a path (separators and dots become ``_``)."""
    safe = re.sub(r"[^A-Za-z0-9_.-]+", "_", name).strip("._") or "recipe"
    return root / safe


def _dispatch(args: argparse.Namespace, parser: argparse.ArgumentParser) -> int:
    from .plugins import get_plugin_manager

    host = get_plugin_manager()
    if args.command in ("run", "check"):
        from .recipes import load_recipe

        recipe = load_recipe(args.recipe, host, args.set)
        if args.command == "check":
            print(f"{recipe.source}: ok ({len(recipe.steps)} steps, {len(recipe.outputs)} outputs)")
            return 0
        from .recipes import MAX_SEED
        from .runner import run

        if args.seed is not None and not 0 <= args.seed <= MAX_SEED:
            raise RecipeError(f"--seed {args.seed}: expected an integer in [0, 2^63 - 1]")
        out = args.out or default_out(recipe.name)
        progress = {"auto": None, "on": True, "off": False}[args.progress]
        result = run(recipe, host, seed=args.seed, out_dir=out, progress=progress, save_state=args.state)
        print(f"wrote {len(result.files)} files to {printable(str(out))}/")
        for f in sorted(result.files):
            print(f"  {printable(str(out / f))}")
        for key, value in sorted(result.state.reports.items()):   # series are in run.json
            print(f"  {key} = {f'({len(value)} values in run.json)' if isinstance(value, list) else value}")
        return 0
    if args.command == "rules":
        if args.rules_cmd == "show":
            print(describe_rule(host.rule(args.name)))
            return 0
        width = max((len(n) for n in host.rules), default=10)
        for name, cls in host.rules.items():
            print(f"{name:<{width}}  {cls.summary()}")
        return 0
    if args.command == "recipes":
        from .recipes import find_recipe, list_recipes, load_recipe, rules_missing

        if args.recipes_cmd == "show":
            print(describe_recipe(load_recipe(args.name, host), find_recipe(args.name, host)))
            return 0
        recipes = list_recipes(host)
        width = max((len(n) for n in recipes), default=10)
        for name, path in recipes.items():
            missing = rules_missing(path, host)      # a chain through a disabled family
            text = (f"(needs {', '.join(missing)}: plugin disabled or not installed)" if missing
                    else recipe_summary(path))
            line = f"{name:<{width}}  {text}".rstrip()
            print(textwrap.shorten(line, _width(), placeholder=" ...") if sys.stdout.isatty() else line)
        return 0
    if args.command == "plugins":
        for s in host.statuses:
            host.rules  # noqa: B018 - loading rules may mark more plugins broken
        for s in host.statuses:
            state = "ok" if s.ok else "BROKEN"
            dist = f" [{s.distribution} {s.version}]" if s.distribution else ""
            print(f"{s.name:<12} {state:<6} {s.target}{dist}")
            if s.error:
                print(f"{'':<12} reason: {_one_line(s.error)}")
            elif s.rules:
                print(textwrap.fill(", ".join(s.rules), 96, initial_indent=" " * 13, subsequent_indent=" " * 13))
        return 0
    if args.command == "exporters":
        for name, e in host.exporters.items():
            print(f"{name:<16} {'/'.join(e.kinds):<20} {e.doc}")
        return 0
    if args.command == "gallery":
        from .gallery import build_gallery, load_gallery

        if args.quick and args.scale:
            raise RecipeError("gallery: --quick and --scale thesis ask for opposite sizes; choose one")
        if args.list:
            for e in load_gallery(host, args.only):
                if args.scale != "thesis" or e.thesis_scale:
                    print(f"{e.slug:<40} {e.figure:<16} {e.title}")
            return 0
        report = build_gallery(host, only=args.only, jobs=args.jobs, quick=args.quick, out_dir=args.out,
                               force=args.force, scheduler=args.scheduler, thesis_scale=args.scale == "thesis")
        print(report.summary())
        return min(len(report.failed), 125)   # the exit code says how many entries failed
    if args.command == "sweep":
        from .recipes import find_recipe
        from .sweep import parse_seeds, sweep

        find_recipe(args.recipe, host)
        out = args.out or Path("out") / f"sweep-{Path(args.recipe).stem}"
        results = sweep(args.recipe, args.grid, parse_seeds(args.seeds), out, jobs=args.jobs,
                        scheduler=args.scheduler, force=args.force)
        failed = [r for r in results if r.status in ("failed", "unavailable")]
        done = sum(r.status == "done" for r in results)
        print(f"sweep: {done} run, {len(results) - done - len(failed)} up to date, {len(failed)} failed "
              f"-> {out / 'summary.csv'}")
        for r in failed:
            print(f"  FAILED {r.key}: {r.error}")
        if (out / "ensemble.json").is_file():
            for label, stats in json.loads((out / "ensemble.json").read_text()).items():
                print(f"  ensemble {label}: " + ", ".join(f"{k} = {v}" for k, v in stats.items()))
        return 1 if failed else 0
    if args.command == "new-plugin":
        from .scaffold import new_plugin

        path = new_plugin(args.name, args.dir)
        print(f"wrote {path}/ - next: pip install -e {path} && pytest {path}")
        return 0
    parser.error(f"unknown command {args.command}")
    return 2


def recipe_summary(path: Path) -> str:
    """One line for ``procgen recipes list``: the recipe's description, its figure if it names none."""
    from .recipes import read_toml

    try:
        meta = read_toml(path).get("recipe", {})
    except ProcgenError as exc:
        return f"(unreadable: {_one_line(str(exc))})"
    text = str(meta.get("description", ""))
    figure = str(meta.get("figure", ""))
    return f"{text} [{figure}]" if figure and figure not in text else text


def describe_recipe(recipe: "Recipe", path: Path) -> str:
    """The text of ``procgen recipes show``: figure, description, seed, steps with parameters, outputs,
    and the file to copy to start one's own."""
    meta = recipe.meta
    lines = [f"{recipe.name}  ({recipe.source})", f"file: {path}"]
    for key in ("figure", "description", "caption"):
        if meta.get(key):
            lines.append(textwrap.fill(f"{key}: {meta[key]}", _width(), subsequent_indent="  "))
    lines += [f"seed: {recipe.seed}", "", "steps:"]
    for st in recipe.steps:
        label = f" [{st.id}]" if st.id else ""
        runs = "until stable" if st.until_stable else f"x{st.iterations}"
        lines.append(f"  {st.index}{label} {st.rule.name} {runs}")
        if st.params:
            params = ", ".join(f"{k}={json.dumps(v, default=str)}" for k, v in st.params.items())
            lines.append(textwrap.fill(params, _width(), initial_indent="      ", subsequent_indent="      "))
    lines += ["", "outputs:"]
    lines += [f"  {o.file:<28} {o.format} of {o.domain}" for o in recipe.outputs]
    return "\n".join(lines)


def _width() -> int:
    """The terminal's width (80 off a terminal), never under 60 columns."""
    import shutil

    return max(60, shutil.get_terminal_size((80, 24)).columns - 1)


def describe_rule(cls: type) -> str:
    """The text of ``procgen rules show``: summary, parameters table, fields, domains."""
    import dataclasses

    lines = [f"{cls.name}  ({cls.__module__}.{cls.__name__})", ""]
    width = _width()
    for para in textwrap.dedent(cls.__doc__ or "").strip().split("\n\n"):   # refilled to the width
        lines += [textwrap.fill(" ".join(para.split()), width, initial_indent="  ", subsequent_indent="  "), ""]
    # One block per parameter, wrapped to the terminal: a range or a list of choices can be as
    # long as it needs to be and nothing is cut off.
    for p in cls.parameters():
        default = "(required)" if p.required else repr(p.default)
        head = f"  {p.name}: {p.type} = {default}" + (f" [{p.info.units}]" if p.info.units else "")
        lines.append(textwrap.fill(head, width, subsequent_indent="      "))
        for label, text in (("range", p.info.range_text()), ("", p.info.doc)):
            if text:
                lines.append(textwrap.fill(f"{label}: {text}" if label else text, width,
                                           initial_indent="      ", subsequent_indent="      "))
    specs = list(cls.fields)
    if specs:
        lines += ["", "  fields:"]
        for s in specs:
            lines.append(textwrap.fill(f"{s.intent:<5} {s.name} on {s.domain}.{s.at} [{s.units}] {s.doc}", width,
                                       initial_indent="    ", subsequent_indent="          "))
    if cls.uses:
        from .ca.cells import CELL_DOMAIN, cell_domain_kinds
        lines.append("  uses:    " + ", ".join(
            f"{k} (any cell domain: {', '.join(cell_domain_kinds())})" if v == CELL_DOMAIN else f"{k} ({v})"
            for k, v in cls.uses.items()))
    if cls.creates:
        lines.append("  creates: " + ", ".join(f"{k} ({v})" for k, v in cls.creates.items()))
    lines.append(f"  default iterations: {cls.default_iterations}")
    del dataclasses
    return "\n".join(lines)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
