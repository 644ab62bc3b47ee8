"""Raster images: colour maps and RGB fields of a Grid as 8-bit PNG, and the one PNG encoder."""
from __future__ import annotations

import hashlib
import struct
import zlib
from collections import OrderedDict
from typing import Any

import numpy as np

from ..domains import Domain, Grid
from ..errors import InputError
from .provenance import provenance_json


#: PNG colour type of an (h, w) / (h, w, 3) / (h, w, 4) array: grey, truecolour, truecolour + alpha
_COLOUR_TYPE = {1: 0, 2: 4, 3: 2, 4: 6}
#: images of more samples than this are deflated at level 3, smaller ones at 6 (see png_bytes)
LARGE = 4_000_000
#: encoded PNGs of large images, keyed by a digest of everything that goes into the bytes
_CACHE: OrderedDict[bytes, bytes] = OrderedDict()
_CACHE_BYTES = 96_000_000


def _chunk(kind: bytes, data: bytes) -> bytes:
    """One PNG chunk: length, type, data, CRC-32 of type and data (PNG 1.2, section 5.3)."""
    return struct.pack(">I", len(data)) + kind + data + struct.pack(">I", zlib.crc32(data, zlib.crc32(kind)))


def _text_chunk(key: str, value: str) -> bytes:
    """tEXt when the value is Latin-1 (as Pillow's ``PngInfo.add_text``), else iTXt (UTF-8);
    the key is 1..79 Latin-1 bytes either way (PNG 1.2, section 11.3.4)."""
    try:
        k = key.encode("latin-1")
    except UnicodeEncodeError:
        k = b""
    if not 1 <= len(k) <= 79 or b"\0" in k:
        raise InputError(f"png: a text key must be 1..79 Latin-1 characters, got {key!r}")
    try:
        return _chunk(b"tEXt", k + b"\0" + value.encode("latin-1"))
    except UnicodeEncodeError:
        return _chunk(b"iTXt", k + b"\0\0\0\0\0" + value.encode("utf-8"))


def _scanlines(arr: np.ndarray) -> np.ndarray:
    """(h, 1 + row bytes) filtered scanlines: filter type 2 ('Up', PNG 1.2 section 6.3) on every
    row, the byte difference to the row above (the first row's 'above' is zeros).

    Why 'Up' for every row: it is one vectorised subtraction (Pillow's encoder took 0.8 to
    1.6 s per 16 Mpx atlas map), and it deflates about as small: plate 5.10's six atlas maps
    (level 3) came to 14.26 MB against Pillow's 14.28 MB (each map within 12 %), the 720 x 640
    previews (level 6) within 3 %."""
    h = arr.shape[0]
    rows = arr.view(np.uint8).reshape(h, -1)
    out = np.empty((h, rows.shape[1] + 1), np.uint8)
    out[:, 0] = 2
    if h:
        out[0, 1:] = rows[0]
        np.subtract(rows[1:], rows[:-1], out=out[1:, 1:])       # uint8 wraps: modulo 256
    return out


def png_bytes(array: np.ndarray, provenance: dict[str, Any] | None = None,
              extra: dict[str, Any] | None = None) -> bytes:
    """Encode uint8 (h, w[, 2|3|4]) or uint16 (h, w) as PNG with provenance in a text chunk.

    The one PNG encoder of procgen: every PNG exporter goes through it, so every PNG carries
    its provenance (``procgen`` text chunk; ``extra`` adds one text chunk per key, e.g. the
    scale of a 16-bit height map).  Written here rather than by Pillow: 'Up'-filtered
    scanlines (numpy) deflated by zlib in one call, so a 16 Mpx atlas map takes a fraction
    of a second.  Large images are deflated less hard (level 3): the bytes stay the same for
    the same input, and the time stays small beside the run's.  A large image encoded again
    with the same provenance (the OBJ and the GLB of one run share their atlas maps) is
    served from a small cache of the last encodings: same input, same bytes, encoded once."""
    arr = np.asarray(array)
    if arr.dtype == np.uint16:
        if arr.ndim != 2:
            raise InputError("png: 16-bit images must be single-channel")
        arr = arr.astype(">u2")                  # PNG samples are big-endian
    elif arr.dtype != np.uint8:
        raise InputError(f"png: unsupported dtype {arr.dtype}")
    channels = 1 if arr.ndim == 2 else (arr.shape[2] if arr.ndim == 3 else 0)
    if channels not in _COLOUR_TYPE or arr.shape[0] < 1 or arr.shape[1] < 1:
        raise InputError(f"png: expected a non-empty (h, w), (h, w, 2|3|4) image, got shape {arr.shape}")
    arr = np.ascontiguousarray(arr)
    texts = [("procgen", provenance_json(provenance))]
    texts += [(k, provenance_json(v) if not isinstance(v, str) else v) for k, v in sorted((extra or {}).items())]
    key = None
    if arr.size > LARGE:
        digest = hashlib.sha256(arr.data)
        digest.update(repr((arr.shape, arr.dtype.str, texts)).encode())
        key = digest.digest()
        if key in _CACHE:
            _CACHE.move_to_end(key)
            return _CACHE[key]
    h, w = arr.shape[:2]
    ihdr = struct.pack(">IIBBBBB", w, h, 8 * arr.itemsize, _COLOUR_TYPE[channels], 0, 0, 0)
    level = 6 if arr.size <= LARGE else 3
    png = b"".join([b"\x89PNG\r\n\x1a\n", _chunk(b"IHDR", ihdr), *(_text_chunk(k, v) for k, v in texts),
                    _chunk(b"IDAT", zlib.compress(_scanlines(arr), level)), _chunk(b"IEND", b"")])
    if key is not None:
        _CACHE[key] = png
        while sum(len(b) for b in _CACHE.values()) > _CACHE_BYTES:
            _CACHE.popitem(last=False)
    return png


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
