"""Which of a run's files are pictures, in what order, and their light copies for the site.

The front page must stay light (a few MB for 175 entries) while a run may write 14 MB SVGs and
16-bit heightmaps: PNGs are scaled down once into ``_thumbs/`` (16-bit maps stretched to 8 bits),
small SVGs are used as they are, and near-blank maps are skipped because they say nothing.
"""
from __future__ import annotations

import contextlib
import html
import io
from pathlib import Path
from typing import Any, Iterator

from ..exchange import write

#: front-page thumbnails: lossy WebP (every current browser reads it; a fifth of a PNG's bytes
#: for these pictures) this wide; SVGs up to this size are shown as they are
THUMB_WIDTH = 360
THUMB_QUALITY = 82
SVG_THUMB_BYTES = 150_000
PICTURE_ENDS = (".svg", ".png", ".gif")


def pictures(files: list[str]) -> list[str]:
    """The run's pictures, most telling first: previews, then other outputs (frames and texture
    atlases are not pictures of the result)."""
    pics = [f for f in files if f.endswith(PICTURE_ENDS) and not f.endswith("_texture.png")
            and not f.startswith("frames/")]
    previews = [f for f in pics if "preview" in f]
    return previews + [f for f in pics if f not in previews]


def frame_series(files: list[str]) -> dict[str, list[str]]:
    """Frames by the step that wrote them (``frames/step4/frame_0190.png``), in time order."""
    series: dict[str, list[str]] = {}
    for f in sorted(files):
        parts = f.split("/")
        if parts[0] == "frames" and f.endswith(PICTURE_ENDS):
            series.setdefault(parts[1] if len(parts) > 2 else "", []).append(f)
    return series


def thumbnail(out: Path, base: str, name: str, width: int = THUMB_WIDTH) -> tuple[str, int, int] | None:
    """(src relative to ``out``, width, height) of a light copy of ``base/name``, or None when
    the picture is near-blank or an SVG too heavy to stand in for itself (width 0: an SVG as is)."""
    import numpy as np
    from PIL import Image, ImageStat

    src = out / base / name
    if name.endswith(".svg"):
        return (f"{base}/{name}", 0, 0) if src.stat().st_size <= SVG_THUMB_BYTES else None
    rel = f"_thumbs/{base}/{width}-{name.replace('/', '_').rsplit('.', 1)[0]}.webp"
    dst = out / rel
    if not dst.is_file() or dst.stat().st_mtime_ns < src.stat().st_mtime_ns:
        with _own_image(src) as img:
            if img.mode in ("I", "I;16", "I;16B", "F"):        # 16-bit heightmaps: stretch to 8 bits
                a = np.asarray(img, dtype=np.float64)
                lo, hi = float(a.min()), float(a.max())
                img = Image.fromarray(np.uint8(np.round(255 * (a - lo) / (hi - lo if hi > lo else 1))))
            img = img.convert("RGBA" if "A" in img.mode or img.mode == "P" else "RGB")
            img.thumbnail((width, width * 2))
            buf = io.BytesIO()
            img.save(buf, format="WEBP", quality=THUMB_QUALITY, method=6)
        write(dst, buf.getvalue())
    with Image.open(dst) as img:
        size = img.size
        if max(ImageStat.Stat(img.convert("L")).stddev) < 2.0:      # a near-blank map says nothing
            return None
    return rel, size[0], size[1]


@contextlib.contextmanager
def _own_image(path: Path) -> Iterator[Any]:
    """Open a picture procgen wrote itself, however large: Pillow's decompression-bomb guard
    (about 89 Mpx) is for files from elsewhere, and a thesis-scale texture atlas passes it
    (plate 5.10 at 330,000 cells writes 9,500 x 9,500 maps)."""
    from PIL import Image

    limit = Image.MAX_IMAGE_PIXELS
    Image.MAX_IMAGE_PIXELS = None
    try:
        with Image.open(path) as img:
            yield img
    finally:
        Image.MAX_IMAGE_PIXELS = limit


def img_tag(src: str, w: int, h: int, alt: str, prefix: str = "") -> str:
    """A lazily loaded <img>, its size given so the page does not jump while it loads."""
    size = f' width="{w}" height="{h}"' if w else ""
    return f'<img src="{html.escape(prefix + src)}"{size} loading="lazy" alt="{html.escape(alt)}">'


def thumbs_html(out: Path, base: str, files: list[str], limit: int = 4, href: str = "",
                prefix: str = "") -> str:
    """Up to ``limit`` thumbnails of the run's pictures (its last frames when it has no other
    picture), each linking to ``href`` or to the picture itself."""
    cells = []
    series = frame_series(files)
    last_frames = [fs[-1] for fs in series.values()][::-1]
    for f in pictures(files) + last_frames:
        t = thumbnail(out, base, f)
        if t is not None:
            cells.append(f'<a href="{html.escape(href or prefix + base + "/" + f)}">'
                         f'{img_tag(t[0], t[1], t[2], f, prefix)}</a>')
        if len(cells) == limit:
            break
    return "".join(cells)
