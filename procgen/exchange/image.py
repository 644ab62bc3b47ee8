"""Raster images: colour maps and RGB fields of a Grid as 8-bit PNG (Pillow)."""
from __future__ import annotations

import io
from typing import Any

import numpy as np
from PIL import Image
from PIL.PngImagePlugin import PngInfo

from ..domains import Domain, Grid
from ..errors import InputError
from .provenance import provenance_json


def png_bytes(array: np.ndarray, provenance: dict[str, Any] | None = None,
              extra: dict[str, Any] | None = None) -> bytes:
    """Encode uint8 (h, w[, 3|4]) or uint16 (h, w) as PNG with provenance in a text chunk.

    The one PNG encoder of procgen: every PNG exporter goes through it, so every PNG carries
    its provenance (``procgen`` text chunk; ``extra`` adds one text chunk per key, e.g. the
    scale of a 16-bit height map).  Large images are compressed less hard (level 3): the
    bytes stay the same for the same input, and the time stays small beside the run's."""
    arr = np.ascontiguousarray(array)
    if arr.dtype == np.uint16:
        img = Image.fromarray(arr.astype("<u2")) if arr.ndim == 2 else None
        if img is None:
            raise InputError("png: 16-bit images must be single-channel")
    elif arr.dtype == np.uint8:
        img = Image.fromarray(arr)
    else:
        raise InputError(f"png: unsupported dtype {arr.dtype}")
    info = PngInfo()
    info.add_text("procgen", provenance_json(provenance))
    for key, value in sorted((extra or {}).items()):
        info.add_text(key, provenance_json(value) if not isinstance(value, str) else value)
    buf = io.BytesIO()
    level = 6 if arr.size < 4_000_000 else 3
    img.save(buf, format="PNG", pnginfo=info, optimize=False, compress_level=level)
    return buf.getvalue()


def to_rgb8(arr: np.ndarray, cmap: str = "terrain", vmin: float | None = None,
            vmax: float | None = None) -> np.ndarray:
    """Scalars through a matplotlib colour map, or 0..1 RGB(A) floats, to uint8 RGB(A)."""
    a = np.asarray(arr)
    if a.ndim == 3 and a.shape[2] in (3, 4):
        if a.dtype == np.uint8:
            return a
        f = np.clip(a.astype(np.float32, copy=False), 0.0, 1.0) * np.float32(255.0)
        return np.rint(f).astype(np.uint8)
    if a.ndim != 2:
        raise InputError(f"image: expected (h, w) scalars or (h, w, 3|4) colours, got {a.shape}")
    from matplotlib import colormaps

    try:
        cm = colormaps[cmap]
    except KeyError:
        shown = cmap if len(str(cmap)) <= 60 else f"{str(cmap)[:57]}..."
        raise InputError(f"image: unknown colour map {shown!r} (a colour map name such as "
                         "'terrain', 'viridis', 'gray')") from None
    a = a.astype(np.float64)
    lo = float(np.nanmin(a)) if vmin is None else vmin
    hi = float(np.nanmax(a)) if vmax is None else vmax
    t = np.clip((a - lo) / (hi - lo if hi > lo else 1.0), 0, 1)
    return np.round(cm(t)[..., :3] * 255).astype(np.uint8)


def image_png(domain: Domain, *, stem: str = "", provenance: dict[str, Any] | None = None,
              field: str = "surface__color", cmap: str = "terrain", layer: int | None = None,
              vmin: float | None = None, vmax: float | None = None, scale: int = 1) -> bytes:
    """A Grid field as an 8-bit PNG, north up; scalars are colour-mapped, RGB written as is."""
    if not isinstance(domain, Grid):
        raise InputError(f"image_png: expected a Grid, got {domain.kind}")
    arr = np.asarray(domain[field])
    if arr.ndim == 3 and arr.shape[2] not in (3, 4):
        if layer is None:
            raise InputError(f"image_png: field {field!r} has {arr.shape[2]} layers; give option 'layer'")
        arr = arr[:, :, layer]
    if arr.dtype != np.uint8 and not np.all(np.isfinite(arr)):
        raise InputError(f"image_png: field {field!r} contains NaN or inf")
    rgb = np.flipud(to_rgb8(arr, cmap, vmin, vmax))
    if scale > 1:
        rgb = np.repeat(np.repeat(rgb, scale, axis=0), scale, axis=1)
    return png_bytes(rgb, provenance)
