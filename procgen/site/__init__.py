"""The gallery as a static site: a front page, one page per entry, and the assets they share.

Everything a page needs ships in the package (the stylesheet, the script, and the vendored
<model-viewer> web component with its licences in ``vendor/``), so the site works offline, from
a file:// folder as well as over http, and nothing is fetched when it is viewed.
"""
from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from ..exchange import write
from .entry import write_entry_page
from .front import write_front_page

if TYPE_CHECKING:
    from ..gallery import Entry
    from ..jobs import JobResult

HERE = Path(__file__).parent
ASSETS = ("style.css", "site.js")


def copy_assets(out: Path) -> None:
    """``out/_site``: the stylesheet, the script, the viewer and its licences (copied when changed)."""
    sources = [HERE / a for a in ASSETS] + sorted((HERE / "vendor").iterdir())
    for src in sources:
        dst = out / "_site" / src.name
        data = src.read_bytes()
        if not dst.is_file() or dst.read_bytes() != data:
            write(dst, data)


def write_site(out: Path, entries: list["Entry"], results: list["JobResult"], overrides: dict[str, list[str]],
               recipe_files: dict[str, Path], scale: str = "") -> list[str]:
    """Write the whole site under ``out``; returns the placeholders no run could fill
    (``"<entry> seed N: {key}"``), which the gallery reports."""
    copy_assets(out)
    by = {(r.key, r.seed): r for r in results}
    missing: list[str] = []
    for e in entries:
        runs = [by[(e.slug, s)] for s in e.seeds if (e.slug, s) in by]
        if runs:
            missing += write_entry_page(out, e, runs, overrides[e.slug], recipe_files.get(e.slug), scale)
    write_front_page(out, entries, by, scale)
    return missing
