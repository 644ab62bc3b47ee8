"""The gallery: every plugin's gallery entries rendered in parallel, resumably, into index.html.

Each entry+seed is a job (procgen.jobs), run in local processes or on a dask.distributed cluster
exactly as a sweep's runs are: written into a temporary folder renamed into place when complete,
with a stamp holding a provenance hash (recipe after overrides, seed, package versions; --quick
marks the recipe). A re-run skips entries whose stamp matches, so an interrupted run (Ctrl-C,
kill -9) resumes without redoing finished work.
"""
from __future__ import annotations

import fnmatch
import html
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .errors import RecipeError
from .exchange import write
from .jobs import Job, JobResult, clean_stale_temps, run_jobs
from .recipes import list_recipes, parse_toml, rules_missing

if TYPE_CHECKING:
    from .plugins import PluginHost

ENTRY_KEYS = ("recipe", "seeds", "title", "figure", "caption", "quick", "set", "id", "thesis", "thesis_caption",
              "differs")


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


@dataclass
class GalleryReport:
    out_dir: Path
    results: list[JobResult]
    seconds: float

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
        return "\n".join(lines)


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
    for key in ("quick", "set"):
        if not isinstance(raw.get(key, {}), dict):
            raise RecipeError(f"{where}: {key} must be a table of KEY = VALUE overrides")
    thesis = raw.get("thesis", {})
    if not isinstance(thesis, dict) or not all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                               for v in thesis.values()):
        raise RecipeError(f"{where}: thesis must be a table of REPORT KEY = the thesis's number")
    slug = raw.get("id") or raw["recipe"].replace("/", "-")
    return Entry(raw["recipe"], list(seeds), str(raw.get("title", raw["recipe"])), str(raw.get("figure", "")),
                 str(raw.get("caption", "")), dict(raw.get("quick", {})), dict(raw.get("set", {})), slug, where,
                 {str(k): float(v) for k, v in thesis.items()}, str(raw.get("thesis_caption", "")),
                 str(raw.get("differs", "")))


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
        data = parse_toml(main.read_text(encoding="utf-8"), str(main))
        files.append((main, data))
        for inc in data.get("gallery", {}).get("include", []):
            p = main.parent / inc
            if p.is_file():
                files.append((p, parse_toml(p.read_text(encoding="utf-8"), str(p))))
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


def overrides_for(entry: Entry, quick: bool) -> list[str]:
    items = dict(entry.set)
    if quick:
        items.update(entry.quick)
    return [f"{k}={json.dumps(v) if isinstance(v, str) else _toml_value(v)}" for k, v in items.items()]


def _toml_value(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_toml_value(x) for x in v) + "]"
    if isinstance(v, str):
        return json.dumps(v)
    return repr(v)


def entry_job(entry: Entry, seed: int, out_root: Path, quick: bool) -> Job:
    """The job that renders ``entry`` with ``seed`` into ``out_root/<slug>/seed-<seed>``."""
    overrides = overrides_for(entry, quick) + (["recipe.notes=\"quick\""] if quick else [])
    return Job(entry.slug, entry.recipe, tuple(overrides), seed, str(out_root / entry.slug / f"seed-{seed}"))


def build_gallery(host: "PluginHost", *, only: list[str] | None = None, jobs: int = 1, quick: bool = False,
                  out_dir: Path | None = None, force: bool = False, progress: bool | None = None,
                  scheduler: Any = None) -> GalleryReport:
    """Render all (filtered) entries with ``jobs`` processes, or on the dask cluster at ``scheduler``
    (an address or a ``dask.distributed.Client``), then write index.html."""
    t0 = time.perf_counter()
    out = Path(out_dir) if out_dir else Path("gallery") / "out"
    out.mkdir(parents=True, exist_ok=True)
    clean_stale_temps(out)
    entries = load_gallery(host, only)
    batch = [entry_job(e, s, out, quick) for e in entries for s in e.seeds]
    results = run_jobs(batch, host, processes=jobs, scheduler=scheduler, force=force, desc="gallery",
                       progress=progress)
    write_index(out, entries, results, quick)
    return GalleryReport(out, results, time.perf_counter() - t0)


#: front-page thumbnails: PNG previews this wide; SVGs up to this size are shown as they are
THUMB_WIDTH = 360
SVG_THUMB_BYTES = 300_000


def _pictures(files: list[str]) -> list[str]:
    """The entry's pictures, most telling first: previews, other outputs, then its last frames
    (an entry whose only pictures are frames still shows one)."""
    pics = [f for f in files if f.endswith((".svg", ".png")) and not f.endswith("_texture.png")]
    frames = sorted(f for f in pics if f.startswith("frames/"))
    pics = [f for f in pics if not f.startswith("frames/")]
    previews = [f for f in pics if "preview" in f]
    return previews + [f for f in pics if f not in previews] + frames[::-1]


def _thumbnail(out: Path, base: str, name: str) -> tuple[str, int, int] | None:
    """(src, width, height) of a light front-page picture for ``base/name``, or None when the
    picture is near-blank or an SVG too heavy for a thumbnail. PNGs are scaled down once into
    ``_thumbs/`` (redone only when the run's file is newer)."""
    import io

    import numpy as np
    from PIL import Image, ImageStat

    src = out / base / name
    if name.endswith(".svg"):
        return (f"{base}/{name}", 0, 0) if src.stat().st_size <= SVG_THUMB_BYTES else None
    rel = f"_thumbs/{base}/{name.replace('/', '_')}"
    dst = out / rel
    if not dst.is_file() or dst.stat().st_mtime_ns < src.stat().st_mtime_ns:
        with Image.open(src) as img:
            if img.mode in ("I", "I;16", "I;16B", "F"):        # 16-bit heightmaps: stretch to 8 bits
                a = np.asarray(img, dtype=np.float64)
                lo, hi = float(a.min()), float(a.max())
                img = Image.fromarray(np.uint8(np.round(255 * (a - lo) / (hi - lo if hi > lo else 1))))
            img = img.convert("RGBA" if "A" in img.mode else "RGB")
            img.thumbnail((THUMB_WIDTH, THUMB_WIDTH * 2))
            buf = io.BytesIO()
            img.save(buf, format="PNG", optimize=True)
        write(dst, buf.getvalue())
    with Image.open(dst) as img:
        size = img.size
        if max(ImageStat.Stat(img.convert("L")).stddev) < 2.0:      # a near-blank map says nothing
            return None
    return rel, size[0], size[1]


def _thumbs_html(out: Path, base: str, files: list[str], limit: int = 4) -> str:
    cells = []
    for f in _pictures(files):
        t = _thumbnail(out, base, f)
        if t is not None:
            src, w, h = t
            size = f' width="{w}" height="{h}"' if w else ""
            cells.append(f'<a href="{base}/{html.escape(f)}"><img src="{html.escape(src)}"{size} '
                         f'loading="lazy" alt="{html.escape(f)}"></a>')
        if len(cells) == limit:
            break
    return "".join(cells)


def _params_html(run_json: Path) -> str:
    """A collapsible list of every step's parameters, read back from the entry's run.json."""
    try:
        info = json.loads(run_json.read_text())
    except (OSError, ValueError):
        return ""
    rows = []
    for st in info.get("steps", []):
        params = ", ".join(f"{k}={json.dumps(v, default=str)}" for k, v in sorted(st.get("params", {}).items()))
        rows.append(f"<li><code>{html.escape(st.get('rule', ''))}</code> &times;{st.get('iterations', '')}: "
                    f"{html.escape(params)}</li>")
    return f'<details><summary>parameters</summary><ul class="params">{"".join(rows)}</ul></details>'


#: how a report reads, by the end of its key: (unit, factor); fractions are shown as percentages
_REPORT_UNITS = (("_pct", "%", 1.0), ("completion_r", "%", 100.0), ("_fraction", "%", 100.0),
                 ("start_share", "%", 100.0), ("saturation_ratio", "x", 1.0), ("steps_to_", "steps", 1.0),
                 ("n_cells", "cells", 1.0), ("n_faces", "triangles", 1.0))


def report_unit(key: str) -> tuple[str, float]:
    """(unit, factor) a report is read in, from its key (e.g. a completion 0.962 -> 96.2 %)."""
    leaf = key.rsplit(".", 1)[-1]
    for end, unit, factor in _REPORT_UNITS:
        if end in leaf:
            return unit, factor
    return "", 1.0


def format_number(value: Any, unit: str = "", factor: float = 1.0) -> str:
    """A number as people read it: integers whole (thousands separated), others to 3
    significant figures; ``None`` as a dash; the unit after a thin space ("96.2 %")."""
    if value is None:
        return "-"
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return str(value)
    v = value * factor
    if abs(v) < 1e15 and float(v).is_integer():
        text = f"{int(v):,}"
    elif 1000 <= abs(v) < 1e15:
        text = f"{int(float(f'{v:.3g}')):,}"           # 3 significant figures, no exponent
    else:
        text = f"{v:.3g}"
    return f"{text} {unit}".rstrip() if unit not in ("x",) else f"{text}x"


def report_text(key: str, value: Any, thesis: dict[str, float]) -> str:
    """``key = measured`` with the thesis's figure beside it when the entry names one."""
    unit, factor = report_unit(key)
    text = f"{key} = {format_number(value, unit, factor)}"
    if key in thesis:
        text += f" (thesis: {format_number(thesis[key], unit, factor)})"
    return text


def write_index(out: Path, entries: list[Entry], results: list[JobResult], quick: bool) -> None:
    """The contact sheet: a card per entry+seed with thumbnails, figure, caption and links."""
    by = {(r.key, r.seed): r for r in results}
    families: dict[str, list[str]] = {}          # the recipe's folder: clouds, terrain, meshes, ...
    for e in entries:
        cards = families.setdefault(e.recipe.split("/")[0] if "/" in e.recipe else "files", [])
        for s in e.seeds:
            r = by.get((e.slug, s))
            if r is None:
                continue
            base = f"{e.slug}/seed-{s}"
            if r.status in ("failed", "unavailable"):
                what = "failed" if r.status == "failed" else "left out"
                body = f'<p class="err">{what}: {html.escape(r.error)}</p>'
            else:
                imgs = _thumbs_html(out, base, r.files)
                links = " ".join(f'<a href="{base}/{html.escape(f)}">{html.escape(f)}</a>'
                                 for f in r.files if not f.startswith("frames/"))
                reps = {k: v for k, v in r.reports.items() if not isinstance(v, (dict, list))}
                first = [k for k in e.thesis if k in reps]          # the thesis's numbers lead
                rep = ", ".join(report_text(k, reps[k], e.thesis) for k in first + sorted(set(reps) - set(first)))
                body = (f'<div class="thumbs">{imgs}</div><p class="files">{links}</p>'
                        f'<p class="rep">{html.escape(rep)}{" &middot; " if rep else ""}'
                        f'{r.seconds:.1f} s</p>{_params_html(out / base / "run.json")}')
            cards.append(f'<div class="card"><h2>{html.escape(e.title)}</h2>'
                         f'<p class="fig">{html.escape(e.figure)} &middot; recipe <code>{html.escape(e.recipe)}</code>'
                         f' &middot; seed {s}</p><p>{html.escape(e.caption)}</p>{body}</div>')
    toc = " &middot; ".join(f'<a href="#{html.escape(f)}">{html.escape(f)}</a> ({len(c)})'
                            for f, c in families.items())
    sections = "\n".join(f'<section id="{html.escape(f)}"><h2 class="family">{html.escape(f)}</h2>'
                         f'<div class="grid">\n{chr(10).join(c)}\n</div></section>' for f, c in families.items())
    page = f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><title>procgen gallery</title>
<style>
body {{ font-family: sans-serif; margin: 1.5em; background: #f4f4f2; color: #222; }}
.grid {{ display: grid; grid-template-columns: repeat(auto-fill, minmax(420px, 1fr)); gap: 1em; }}
.card {{ background: white; padding: .8em; border-radius: 6px; box-shadow: 0 1px 3px #0002; }}
.card h2 {{ font-size: 1.05em; margin: 0 0 .2em; }}
.thumbs img {{ max-width: 48%; max-height: 220px; width: auto; height: auto; margin: 1px; background: #ddd; }}
h2.family {{ text-transform: capitalize; border-bottom: 1px solid #ccc; margin-top: 1.5em; }}
nav {{ font-size: .9em; }}
.fig, .files, .rep {{ font-size: .8em; color: #555; }}
.err {{ color: #a00; }}
details {{ font-size: .75em; color: #444; }} .params {{ padding-left: 1.2em; margin: .3em 0; }}
</style></head><body>
<h1>procgen gallery{' (quick)' if quick else ''}</h1>
<nav>{toc}</nav>
{sections}
<script>
// lets a headless browser (and a curious reader) check that every thumbnail decoded
window.addEventListener("load", () => {{
  const imgs = Array.from(document.images);
  document.body.dataset.images = imgs.length;
  document.body.dataset.broken = imgs.filter(i => !(i.complete && i.naturalWidth > 0)).length;
}});
</script></body></html>
"""
    write(out / "index.html", page)
