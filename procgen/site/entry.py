"""One page per gallery entry: what a reader takes away, and how to make it again.

Large pictures, the frames as a strip that plays, a 3-D view of each GLB, the thesis's caption
beside ours with a plainly marked line on how ours differs, the command that reproduces each
run, the recipe to download, and the reports as a table in their units.
"""
from __future__ import annotations

import base64
import html
import json
import re
import shlex
from pathlib import Path
from typing import TYPE_CHECKING, Any

from ..exchange import write
from .numbers import format_number, report_unit
from .pictures import frame_series, img_tag, pictures, thumbnail
from .text import fill

if TYPE_CHECKING:
    from ..gallery import Entry
    from ..jobs import JobResult

#: GLBs up to this size get a script copy so their 3-D view works from a file:// page too
#: (a browser will not let a file:// page read a neighbouring file); bigger ones need http
VIEW_COPY_BYTES = 1_000_000
#: entry pages show pictures up to this size as they are, bigger SVGs through a thumbnail
PAGE_SVG_BYTES = 4_000_000


def run_info(folder: Path) -> dict[str, Any]:
    try:
        return json.loads((folder / "run.json").read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return {}


def reproduce_command(entry: "Entry", seed: int, overrides: list[str]) -> str:
    """The shell command that makes this run again into ``out/<entry id>``."""
    words = ["procgen", "run", entry.recipe, "--seed", str(seed)]
    for o in overrides:
        words += ["--set", o]
    return " ".join(shlex.quote(w) for w in words + ["--out", f"out/{entry.slug}"])


def run_time(seconds: float, thesis_time: str) -> str:
    """This run's time, and the thesis's for its figure where the thesis states one."""
    ours = f"{seconds:.1f} s" if seconds < 120 else f"{seconds / 60:.1f} min"
    return html.escape(f"{ours} (thesis: {thesis_time})" if thesis_time else ours)


def reports_table(reports: dict[str, Any], thesis: dict[str, float]) -> str:
    """Every report in its unit to 3 significant figures, the thesis's number beside it."""
    rows = []
    lead = [k for k in thesis if k in reports]
    for key in lead + sorted(set(reports) - set(lead)):
        v = reports[key]
        unit, factor = report_unit(key)
        if isinstance(v, list):
            ours = f"{len(v)} values (run.json)"
        elif isinstance(v, dict):
            ours = f"{len(v)} entries (run.json)"
        else:
            ours = format_number(v, unit, factor)
        theirs = format_number(thesis[key], unit, factor) if key in thesis else ""
        rows.append(f'<tr><td><code>{html.escape(key)}</code></td><td class="v">{html.escape(ours)}</td>'
                    f'<td class="v">{html.escape(theirs)}</td></tr>')
    if not rows:
        return ""
    return ('<table class="nums"><tr><th>report</th><th>ours</th><th>thesis</th></tr>'
            + "".join(rows) + "</table>")


def params_html(info: dict[str, Any]) -> str:
    """Every step's parameters as the run used them."""
    rows = []
    for st in info.get("steps", []):
        params = ", ".join(f"{k}={json.dumps(v, default=str)}" for k, v in sorted(st.get("params", {}).items()))
        rows.append(f"<li><code>{html.escape(st.get('rule', ''))}</code> &times;{st.get('iterations', '')}: "
                    f"{html.escape(params)}</li>")
    return f'<details><summary>parameters</summary><ul class="params">{"".join(rows)}</ul></details>' if rows else ""


def _size(n: int) -> str:
    return f"{n / 1e6:.1f} MB" if n >= 1e6 else f"{max(1, round(n / 1e3))} kB"


def _picture(out: Path, base: str, name: str) -> str:
    path = out / base / name
    src, w, h = f"{base}/{name}", 0, 0
    if name.endswith(".svg") and path.stat().st_size > PAGE_SVG_BYTES:
        t = thumbnail(out, base, name, width=1200)
        if t is None:
            return ""
        src, w, h = t
    return (f'<figure><a href="../{html.escape(base)}/{html.escape(name)}">{img_tag(src, w, h, name, "../")}</a>'
            f"<figcaption>{html.escape(name)} ({_size(path.stat().st_size)})</figcaption></figure>")


def _frames(out: Path, base: str, files: list[str]) -> str:
    players = []
    for step, frames in frame_series(files).items():
        cells = []
        for f in frames:
            t = thumbnail(out, base, f, width=240)
            src, w, h = t if t is not None else (f"{base}/{f}", 0, 0)
            cells.append(f'<img src="../{html.escape(src)}" data-full="../{html.escape(base)}/{html.escape(f)}"'
                         f'{f" width={w} height={h}" if w else ""} loading="lazy" alt="{html.escape(f)}">')
        last = frames[-1]
        players.append(f'<div class="player"><p class="meta">{len(frames)} frames of {html.escape(step)} '
                       f'<button type="button">play</button></p>'
                       f'<img class="big" src="../{html.escape(base)}/{html.escape(last)}" loading="lazy" '
                       f'alt="{html.escape(last)}"><div class="strip">{"".join(cells)}</div></div>')
    return "".join(players)


def _views(out: Path, base: str, files: list[str]) -> str:
    views = []
    for f in (f for f in files if f.endswith(".glb")):
        path = out / base / f
        js = ""
        if path.stat().st_size <= VIEW_COPY_BYTES:
            js = f"_site/models/{base}/{f}.js"
            copy = out / js
            if not copy.is_file() or copy.stat().st_mtime_ns < path.stat().st_mtime_ns:
                key = json.dumps(f"../{base}/{f}")
                write(copy, f"window.procgenModels[{key}] = \"{base64.b64encode(path.read_bytes()).decode()}\";\n")
        note = "" if js else " (too large for a file:// page: serve the folder over http to view it)"
        views.append(f'<div class="view3d" data-glb="../{html.escape(base)}/{html.escape(f)}" '
                     f'data-js="{"../" + html.escape(js) if js else ""}" data-viewer="../_site/model-viewer.min.js">'
                     f'<p class="meta">{html.escape(f)} ({_size(path.stat().st_size)}){note}</p>'
                     f'<button type="button">show in 3-D</button></div>')
    return "".join(views)


def write_entry_page(out: Path, entry: "Entry", results: list["JobResult"], overrides: list[str],
                     recipe_file: Path | None, scale: str) -> list[str]:
    """``out/<entry id>/index.html``; returns the placeholders its runs could not fill."""
    missing: list[str] = []
    page_dir = out / entry.slug
    recipe_link = ""
    if recipe_file is not None and recipe_file.is_file():
        write(page_dir / recipe_file.name, recipe_file.read_bytes())
        recipe_link = f' &middot; <a href="{html.escape(recipe_file.name)}" download>recipe {html.escape(recipe_file.name)}</a>'
    runs, title, caption, differs = [], "", "", ""
    for r in results:
        base = f"{entry.slug}/seed-{r.seed}"
        info = run_info(out / base)
        t, m1 = fill(entry.title, info, entry.thesis)
        c, m2 = fill(entry.caption, info, entry.thesis)
        d, m3 = fill(entry.differs, info, entry.thesis)
        missing += [f"{entry.slug} seed {r.seed}: {{{k}}}" for k in m1 + m2 + m3]
        title, caption, differs = title or t, caption or c, differs or d
        head = f'<h2 id="seed-{r.seed}">seed {r.seed}</h2>'
        if r.status in ("failed", "unavailable"):
            what = "failed" if r.status == "failed" else "left out"
            runs.append(f'<section class="run">{head}<p class="err">{what}: {html.escape(r.error)}</p></section>')
            continue
        pics = "".join(_picture(out, base, f) for f in pictures(r.files))
        files = " &middot; ".join(f'<a href="../{html.escape(base)}/{html.escape(f)}">{html.escape(f)}</a> '
                                  f'({_size((out / base / f).stat().st_size)})'
                                  for f in r.files if not f.startswith("frames/") and (out / base / f).is_file())
        runs.append(f'<section class="run">{head}'
                    f'{"<p class=cap>" + t + "</p>" if len(results) > 1 else ""}'
                    f'<div class="pics">{pics}</div>{_frames(out, base, r.files)}{_views(out, base, r.files)}'
                    f'<h3>make it again</h3><pre class="cmd">{html.escape(reproduce_command(entry, r.seed, overrides))}</pre>'
                    f'<h3>numbers</h3>{reports_table(info.get("reports", r.reports), entry.thesis)}'
                    f'<p class="meta">{run_time(r.seconds, entry.thesis_time)} &middot; files: {files}</p>'
                    f'{params_html(info)}</section>')
    thesis = (f'<div><h2>The thesis ({html.escape(entry.figure)})</h2><blockquote>'
              f'{html.escape(entry.thesis_caption)}</blockquote></div>') if entry.thesis_caption else ""
    ours = f'<div><h2>Ours</h2><p class="cap">{caption}</p></div>'
    diff = f'<p class="differs"><b>How ours differs from the thesis:</b> {differs}</p>' if differs else ""
    family = entry.recipe.split("/")[0] if "/" in entry.recipe else "files"
    page = f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><meta name="viewport" content="width=device-width, initial-scale=1">
<title>{title and html.escape(html.unescape(_strip(title)))} - procgen gallery</title>
<link rel="stylesheet" href="../_site/style.css"></head><body>
<nav class="toc"><a href="../index.html#{html.escape(family)}">&larr; gallery: {html.escape(family)}</a></nav>
<h1>{title}</h1>
<p class="fig">{html.escape(entry.figure)} &middot; recipe <code>{html.escape(entry.recipe)}</code>{recipe_link}{f' &middot; {html.escape(scale)}' if scale else ''}</p>
<div class="compare">{thesis}{ours}</div>
{diff}
{"".join(runs)}
<script src="../_site/site.js"></script></body></html>
"""
    write(page_dir / "index.html", page)
    return missing


def _strip(markup: str) -> str:
    return re.sub(r"<[^>]+>", "", markup)
