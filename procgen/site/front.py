"""The gallery's front page: one section per family, a table of contents, light cards.

A card says what the entry is and the few numbers that matter (those the thesis also gives,
side by side); everything else is one click away on the entry's own page.
"""
from __future__ import annotations

import html
from pathlib import Path
from typing import TYPE_CHECKING

from ..exchange import write
from .entry import run_info, run_time
from .numbers import format_number, report_unit
from .pictures import thumbs_html
from .text import fill

if TYPE_CHECKING:
    from ..gallery import Entry
    from ..jobs import JobResult


def family_of(entry: "Entry") -> str:
    """The recipe's folder (clouds, terrain, meshes, ...): the front page's sections."""
    return entry.recipe.split("/")[0] if "/" in entry.recipe else "files"


def _thesis_numbers(reports: dict, thesis: dict[str, float]) -> str:
    rows = []
    for key, theirs in thesis.items():
        if key in reports and isinstance(reports[key], (int, float)):
            unit, factor = report_unit(key)
            rows.append(f'<tr><td>{html.escape(key.rsplit(".", 1)[-1].replace("_", " "))}</td>'
                        f'<td class="v">{html.escape(format_number(reports[key], unit, factor))}</td>'
                        f'<td class="v">{html.escape(format_number(theirs, unit, factor))}</td></tr>')
    return ('<table class="nums"><tr><th></th><th>ours</th><th>thesis</th></tr>' + "".join(rows)
            + "</table>") if rows else ""


def card(out: Path, entry: "Entry", r: "JobResult") -> str:
    base = f"{entry.slug}/seed-{r.seed}"
    page = f"{entry.slug}/index.html#seed-{r.seed}"
    info = run_info(out / base)
    title = fill(entry.title, info, entry.thesis)[0]
    caption = fill(entry.caption, info, entry.thesis)[0]
    differs = fill(entry.differs, info, entry.thesis)[0]
    if r.status in ("failed", "unavailable"):
        what = "failed" if r.status == "failed" else "left out"
        body = f'<p class="err">{what}: {html.escape(r.error)}</p>'
    else:
        body = (f'<div class="thumbs">{thumbs_html(out, base, r.files, href=page)}</div>'
                f'{_thesis_numbers(info.get("reports", r.reports), entry.thesis)}'
                f'{f"<p class=differs><b>Differs:</b> {differs}</p>" if differs else ""}'
                f'<p class="meta">{run_time(r.seconds, entry.thesis_time)} &middot; <a href="{html.escape(page)}">page, files and numbers</a></p>')
    return (f'<div class="card"><h3><a href="{html.escape(page)}">{title}</a></h3>'
            f'<p class="fig">{html.escape(entry.figure)} &middot; <code>{html.escape(entry.recipe)}</code>'
            f' &middot; seed {r.seed}</p><p class="cap">{caption}</p>{body}</div>')


def write_front_page(out: Path, entries: list["Entry"], results: dict[tuple[str, int], "JobResult"],
                     scale: str) -> None:
    families: dict[str, list[str]] = {}
    for e in entries:
        cards = families.setdefault(family_of(e), [])
        cards += [card(out, e, results[(e.slug, s)]) for s in e.seeds if (e.slug, s) in results]
    toc = " &middot; ".join(f'<a href="#{html.escape(f)}">{html.escape(f)}</a> ({len(c)})'
                            for f, c in families.items())
    sections = "\n".join(f'<section id="{html.escape(f)}"><h2 class="family">{html.escape(f)}</h2>'
                         f'<div class="grid">\n{chr(10).join(c)}\n</div></section>' for f, c in families.items())
    total = sum(len(c) for c in families.values())
    write(out / "index.html", f"""<!doctype html>
<html lang="en"><head><meta charset="utf-8"><meta name="viewport" content="width=device-width, initial-scale=1">
<title>procgen gallery</title><link rel="stylesheet" href="_site/style.css"></head><body>
<h1>procgen gallery{f' ({html.escape(scale)})' if scale else ''}</h1>
<p>{total} runs of the recipes every installed plugin ships; each card opens its page with the
pictures, 3-D views, numbers and the command that makes it again.</p>
<nav class="toc">{toc}</nav>
{sections}
<script src="_site/site.js"></script></body></html>
""")
