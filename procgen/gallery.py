"""The gallery: every plugin's gallery entries rendered in parallel, resumably, into index.html.

Each entry+seed is a job (procgen.jobs), run in local processes or on a dask.distributed cluster
exactly as a sweep's runs are: written into a temporary folder renamed into place when complete,
with a stamp holding a provenance hash (recipe after overrides, seed, package versions; --quick
marks the recipe). A re-run skips entries whose stamp matches, so an interrupted run (Ctrl-C,
kill -9) resumes without redoing finished work.
"""
from __future__ import annotations

import fnmatch
import json
import re
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .errors import RecipeError, printable
from .exchange.write import make_folder
from .jobs import Job, JobResult, clean_stale_temps, run_jobs
from .recipes import find_recipe, list_recipes, read_toml, rules_missing
from .site import write_site

if TYPE_CHECKING:
    from .plugins import PluginHost

ENTRY_KEYS = ("recipe", "seeds", "title", "figure", "caption", "quick", "set", "id", "thesis", "thesis_caption",
              "differs", "thesis_scale", "thesis_time")


@dataclass
class Entry:
    recipe: str
    seeds: list[int]
    title: str
    figure: str = ""
    caption: str = ""
    quick: dict[str, Any] = field(default_factory=dict)
    set: dict[str, Any] = field(default_factory=dict)
    slug: str = ""
    source: str = ""
    thesis: dict[str, float] = field(default_factory=dict)
    #: the thesis figure's own caption, quoted, and how our entry departs from it (stand-ins,
    #: scale, our own parameters); title, caption and differs hold placeholders (procgen.site.text)
    thesis_caption: str = ""
    differs: str = ""
    #: overrides that run the entry at the thesis's own size (``procgen gallery --scale thesis``),
    #: and the run time the thesis states for it, quoted
    thesis_scale: dict[str, Any] = field(default_factory=dict)
    thesis_time: str = ""


@dataclass
class GalleryReport:
    out_dir: Path
    results: list[JobResult]
    seconds: float
    #: placeholders in a title or caption that no run could fill ("<entry> seed N: {key}")
    warnings: list[str] = field(default_factory=list)

    @property
    def failed(self) -> list[JobResult]:
        return [r for r in self.results if r.status == "failed"]

    @property
    def left_out(self) -> list[JobResult]:
        """Entries that need an optional extra this installation lacks: a note, not a failure."""
        return [r for r in self.results if r.status == "unavailable"]

    def summary(self) -> str:
        done = sum(r.status == "done" for r in self.results)
        skipped = sum(r.status == "skipped" for r in self.results)
        left = f", {len(self.left_out)} left out" if self.left_out else ""
        lines = [f"gallery: {done} rendered, {skipped} up to date{left}, {len(self.failed)} failed "
                 f"in {self.seconds:.1f} s -> {self.out_dir / 'index.html'}"]
        lines += [f"  left out {r.key} seed {r.seed}: {r.error}" for r in self.left_out]
        lines += [f"  FAILED {r.key} seed {r.seed}: {r.error}" for r in self.failed]
        if self.warnings:
            lines.append(f"  {len(self.warnings)} placeholders no run fills (shown as ?): "
                         + "; ".join(self.warnings[:5]) + (" ..." if len(self.warnings) > 5 else ""))
        return "\n".join(lines)


#: an entry's id: a folder name inside the gallery's output folder, never a path out of it
_SLUG = re.compile(r"[A-Za-z0-9][A-Za-z0-9_.-]{0,127}")


def _entry_from(raw: Any, where: str, index: int) -> Entry:
    if not isinstance(raw, dict):
        raise RecipeError(f"{where}: each [[entry]] must be a table")
    for k in raw:
        if k not in ENTRY_KEYS:
            from .params import did_you_mean

            raise RecipeError(f"{where}: unknown key {k!r}{did_you_mean(k, ENTRY_KEYS)}")
    if not isinstance(raw.get("recipe"), str):
        raise RecipeError(f"{where}: missing 'recipe' (a recipe name such as 'clouds/fig-3-22')")
    seeds = raw.get("seeds", [1])
    if not isinstance(seeds, list) or not seeds or not all(isinstance(s, int) and s >= 0 for s in seeds):
        raise RecipeError(f"{where}: seeds must be a list of non-negative integers")
    for key in ("quick", "set", "thesis_scale"):
        if not isinstance(raw.get(key, {}), dict):
            raise RecipeError(f"{where}: {key} must be a table of KEY = VALUE overrides")
    thesis = raw.get("thesis", {})
    if not isinstance(thesis, dict) or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                               for v in thesis.values()):
        raise RecipeError(f"{where}: thesis must be a table of REPORT KEY = the thesis's number")
    slug = raw.get("id") or raw["recipe"].replace("/", "-")
    if not (isinstance(slug, str) and _SLUG.fullmatch(slug)):     # the entry's folder under the gallery's
        raise RecipeError(f"{where}: id {printable(repr(slug))[:80]} must be a plain name (letters, digits, "
                          "'_', '.', '-'; no folders), the entry's folder inside the gallery")
    return Entry(raw["recipe"], list(seeds), str(raw.get("title", raw["recipe"])), str(raw.get("figure", "")),
                 str(raw.get("caption", "")), dict(raw.get("quick", {})), dict(raw.get("set", {})), slug, where,
                 {str(k): float(v) for k, v in thesis.items()}, str(raw.get("thesis_caption", "")),
                 str(raw.get("differs", "")), dict(raw.get("thesis_scale", {})), str(raw.get("thesis_time", "")))


def load_gallery(host: "PluginHost", only: list[str] | None = None, path: Path | None = None) -> list[Entry]:
    """Entries of every loaded plugin's gallery lists (or of the file ``path``), filtered by ``only``.

    A list may include others (``[gallery] include = [...]``, relative to it). An entry whose
    recipe needs a rule that no loaded plugin registers (its family is disabled or not installed),
    or whose recipe no loaded plugin ships (a family listing plates that live in another
    family's recipe folder), is left out with a one-line note on stderr rather than failing the
    gallery.
    """
    files = []
    for main in [path] if path else host.gallery_lists():
        data = read_toml(main)          # regular files only, bounded, one-line errors
        files.append((main, data))
        for inc in data.get("gallery", {}).get("include", []):
            p = main.parent / str(inc)
            if p.is_file():
                files.append((p, read_toml(p)))
    recipes = list_recipes(host)
    entries: list[Entry] = []
    seen: set[str] = set()
    for p, d in files:
        for i, raw in enumerate(d.get("entry", [])):
            e = _entry_from(raw, f"{p.name}: entry[{i}]", i)
            if e.slug in seen:
                raise RecipeError(f"{p.name}: entry[{i}]: id {e.slug!r} is used twice; give one an 'id'")
            seen.add(e.slug)
            if e.recipe not in recipes and not e.recipe.endswith(".toml"):   # not a file: a name
                # that no loaded plugin ships (its folder's plugin is disabled, or a typo)
                print(f"gallery: left out {e.slug}: no loaded plugin ships recipe {e.recipe}",
                      file=sys.stderr)
                continue
            missing = rules_missing(recipes[e.recipe], host) if e.recipe in recipes else []
            if missing:
                print(f"gallery: left out {e.slug}: recipe {e.recipe} needs {', '.join(missing)} "
                      "(its plugin is disabled or not installed)", file=sys.stderr)
                continue
            entries.append(e)
    if only:
        entries = [e for e in entries if any(fnmatch.fnmatch(e.recipe, pat) or fnmatch.fnmatch(e.slug, pat)
                                             or fnmatch.fnmatch(e.title, pat) for pat in only)]
    return entries


def overrides_for(entry: Entry, quick: bool, thesis_scale: bool = False) -> list[str]:
    """The entry's ``--set`` overrides: its own, then its quick or thesis-scale sizes."""
    items = dict(entry.set)
    if quick:
        items.update(entry.quick)
    elif thesis_scale:
        items.update(entry.thesis_scale)
    return [f"{k}={json.dumps(v) if isinstance(v, str) else _toml_value(v)}" for k, v in items.items()]


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, str):
        return json.dumps(v)
    return repr(v)


def entry_job(entry: Entry, seed: int, out_root: Path, quick: bool, thesis_scale: bool = False) -> Job:
    """The job that renders ``entry`` with ``seed`` into ``out_root/<slug>/seed-<seed>``."""
    overrides = overrides_for(entry, quick, thesis_scale) + (["recipe.notes=\"quick\""] if quick else [])
    return Job(entry.slug, entry.recipe, tuple(overrides), seed, str(out_root / entry.slug / f"seed-{seed}"))


def build_gallery(host: "PluginHost", *, only: list[str] | None = None, jobs: int = 1, quick: bool = False,
                  out_dir: Path | None = None, force: bool = False, progress: bool | None = None,
                  scheduler: Any = None, gallery_file: Path | None = None,
                  thesis_scale: bool = False) -> GalleryReport:
    """Render all (filtered) entries with ``jobs`` processes, or on the dask cluster at ``scheduler``
    (an address or a ``dask.distributed.Client``), then write the site (procgen.site). The
    entries are every plugin's gallery lists, or the one list ``gallery_file``. With
    ``thesis_scale``, only the entries that run smaller than the thesis by default, at the
    thesis's size, into ``gallery/out-thesis``."""
    t0 = time.perf_counter()
    out = Path(out_dir) if out_dir else Path("gallery") / ("out-thesis" if thesis_scale else "out")
    make_folder(out)
    clean_stale_temps(out)
    entries = load_gallery(host, only, gallery_file)
    if thesis_scale:
        entries = [e for e in entries if e.thesis_scale]
    batch = [entry_job(e, s, out, quick, thesis_scale) for e in entries for s in e.seeds]
    results = run_jobs(batch, host, processes=jobs, scheduler=scheduler, force=force, desc="gallery",
                       progress=progress)
    warnings = write_site(out, entries, results, {e.slug: overrides_for(e, quick, thesis_scale) for e in entries},
                          {e.slug: find_recipe(e.recipe, host) for e in entries},
                          "quick sizes" if quick else "the thesis's sizes" if thesis_scale else "")
    return GalleryReport(out, results, time.perf_counter() - t0, warnings)
