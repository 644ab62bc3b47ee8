"""Reading rasters people bring: greyscale/RGB PNG (with procgen's own JSON sidecar), NPY, GeoTIFF.

Why: a heightmap, a DEM or a painted mask is the first thing users want to feed an erosion or
weathering recipe. Pillow reads images, numpy reads NPY, rasterio (optional extra ``geo``)
reads GeoTIFF with its CRS, affine transform, nodata and scale/offset. Everything comes back
north-up (row 0 = top of the picture) as float64 with a validity mask, plus what the file says
about where its cells are; the rules turn that into a Grid (row 0 = south).

``probe_raster`` reads headers only, so ``procgen check`` can refuse a colour image given as
heights, a file that is not an image, a degree-based DEM or a raster too big for memory
before anything is computed. Every file is opened through procgen.exchange.input_files
(regular files only, bounded in size); an image's pixel count is bounded from its header
before any pixel is decoded; a truncated NPY or damaged GeoTIFF is refused in one line that
never echoes the file's bytes or a library's message; the sidecar's values are checked.
"""
from __future__ import annotations

import contextlib
import json
import math
import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator

import numpy as np

from ..errors import InputError, MissingExtra, printable
from .input_files import MAX_BYTES, check_input, open_input, read_input

#: most pixels an image may have (checked from its header, before decoding): 100 Mpx is
#: 10,000 x 10,000, already 2.4 GB as float64 RGB
IMAGE_MAX_PIXELS = 100_000_000
#: what Pillow may decode: the extensions procgen reads images from
_PIL_FORMATS = ("PNG", "JPEG", "BMP", "WEBP")

_PNG_EXT = (".png",)
_NPY_EXT = (".npy",)
_TIFF_EXT = (".tif", ".tiff")
IMAGE_EXT = _PNG_EXT + (".jpg", ".jpeg", ".bmp", ".webp")


@dataclass(frozen=True)
class RasterInfo:
    """What a file's header says: size, bands, integer range, georeferencing."""

    path: Path
    format: str                 # "image", "npy" or "geotiff"
    shape: tuple[int, int]      # (rows, columns)
    bands: int                  # 1 greyscale, 3 RGB (alpha is not a band here)
    max_value: float | None     # full scale of integer images (255, 65535); None for real values
    crs: str | None             # WKT, GeoTIFF only
    geographic: bool            # the CRS counts in degrees
    crs_units: str              # linear unit of the CRS ("metre"), "" when none


@dataclass(frozen=True)
class Raster:
    """A raster's values north-up (rows, cols[, bands]) with ``valid`` (rows, cols) cells, and
    where its cells are: ``pixel`` = (dx, dy) cell size and ``origin`` = the south-west
    corner, in the CRS's units (None when the file does not say)."""

    info: RasterInfo
    values: np.ndarray
    valid: np.ndarray
    pixel: tuple[float, float] | None
    origin: tuple[float, float] | None
    sidecar: dict | None        # procgen's own JSON sidecar (heightmap_png16 / npy exporters)


def probe_raster(path: Path) -> RasterInfo:
    """Header facts of ``path`` (no pixel data read); InputError naming the file otherwise."""
    suffix = path.suffix.lower()
    if suffix in _NPY_EXT:
        return _probe_npy(path)
    if suffix in _TIFF_EXT:
        return _probe_geotiff(path)
    return _probe_image(path)


def read_raster(path: Path, band: int = 1) -> Raster:
    """Values, validity and georeferencing of ``path`` (``band`` counts from 1, GeoTIFF only)."""
    info = probe_raster(path)
    if info.format == "npy":
        return _read_npy(info)
    if info.format == "geotiff":
        return _read_geotiff(info, band)
    return _read_image(info)


def sidecar_of(path: Path) -> dict | None:
    """procgen's JSON sidecar beside ``path`` (``stem.json``), if there is one, its values
    checked: ``shape`` two counts > 0, ``spacing`` a number > 0, ``origin`` two numbers,
    ``z_min``/``z_max`` numbers (all finite). InputError naming the sidecar and key otherwise."""
    side = path.with_suffix(".json")
    if not side.exists() and not side.is_symlink():
        return None
    name = printable(str(side))
    data = read_input(side, "sidecar", name)
    try:
        doc = json.loads(data.decode("utf-8"))
    except UnicodeDecodeError:
        raise InputError(f"{name}: sidecar is not UTF-8 text") from None
    except json.JSONDecodeError as exc:
        raise InputError(f"{name}: sidecar is not readable JSON (line {exc.lineno}, column {exc.colno})") from None
    except (ValueError, RecursionError):
        raise InputError(f"{name}: sidecar is not readable JSON (nested too deep or a number out of range)") from None
    if not isinstance(doc, dict) or "encoding" not in doc:
        return None                 # someone else's JSON: not ours to interpret
    shape = doc.get("shape")
    if not (isinstance(shape, list) and len(shape) == 2
            and all(isinstance(n, int) and not isinstance(n, bool) and n > 0 for n in shape)):
        raise InputError(f"{name}: sidecar has no [rows, columns] 'shape' (two whole numbers > 0)")
    if "spacing" in doc:
        sp = _number(doc["spacing"], name, "spacing")
        if not sp > 0:
            raise InputError(f"{name}: sidecar 'spacing' must be > 0, got {sp:g}")
    for key in ("z_min", "z_max"):
        if key in doc:
            _number(doc[key], name, key)
    if "origin" in doc:
        o = doc["origin"]
        if not (isinstance(o, list) and len(o) == 2):
            raise InputError(f"{name}: sidecar 'origin' must be [x, y]")
        for v in o:
            _number(v, name, "origin")
    return doc


_JSON_KIND = {str: "text", list: "a list", dict: "an object", bool: "true/false", type(None): "null"}


def _number(value: object, name: str, key: str) -> float:
    """A sidecar value as a finite float; InputError naming the sidecar and key otherwise."""
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        got = _JSON_KIND.get(type(value), "something else")
        raise InputError(f"{name}: sidecar {key!r} must be a number, got {got}")
    v = float(value)
    if not math.isfinite(v):
        raise InputError(f"{name}: sidecar {key!r} must be a finite number, got {v}")
    return v


# -- images (Pillow) ------------------------------------------------------------------------

@contextlib.contextmanager
def _open_image(path: Path) -> Iterator:
    """The image's header opened (nothing decoded yet), its pixel count within IMAGE_MAX_PIXELS."""
    from PIL import Image

    name = printable(str(path))
    with open_input(path, "image", name) as fh:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")     # Pillow's own decompression-bomb warning
            try:
                im = Image.open(fh, formats=_PIL_FORMATS)
            except Image.DecompressionBombError:
                raise InputError(f"{name}: image has more than {IMAGE_MAX_PIXELS:,} pixels") from None
            except Exception:  # Pillow raises many types (OSError, SyntaxError, struct.error...) for non-images
                raise InputError(f"{name}: not an image file procgen reads (PNG, JPEG, BMP, WebP), or its header is damaged") from None
        with im:
            w, h = im.size
            if w * h > IMAGE_MAX_PIXELS:
                raise InputError(f"{name}: image is {w:,} x {h:,} = {w * h / 1e6:,.0f} Mpx, more than the "
                                 f"{IMAGE_MAX_PIXELS / 1e6:,.0f} Mpx procgen decodes; downsample it first")
            if w * h == 0:
                raise InputError(f"{name}: image has no pixels")
            yield im


def _probe_image(path: Path) -> RasterInfo:
    with _open_image(path) as im:
        mode, (w, h) = im.mode, im.size
    if mode in ("1", "L", "LA", "P", "PA", "RGB", "RGBA"):
        full = 1.0 if mode == "1" else 255.0
    elif mode.startswith("I;16"):
        full = 65535.0
    elif mode == "I":               # Pillow opens 16-bit greyscale PNG as "I" on some versions
        full = 65535.0
    else:
        raise InputError(f"{path}: image mode {mode!r} is not greyscale or RGB")
    bands = 3 if mode in ("P", "PA", "RGB", "RGBA") else 1
    return RasterInfo(path, "image", (h, w), bands, full, None, False, "")


def _read_image(info: RasterInfo) -> Raster:
    with _open_image(info.path) as im:
        mode = im.mode
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                if mode in ("P", "PA"):
                    im = im.convert("RGBA")
                    mode = "RGBA"
                a = np.asarray(im)
        except Exception:  # Pillow's decoders raise OSError, SyntaxError, ValueError... for bad data
            raise InputError(f"{printable(str(info.path))}: image data is damaged or truncated") from None
    if a.shape[:2] != info.shape:
        raise InputError(f"{printable(str(info.path))}: image data does not match its header")
    a = a.astype(np.float64)
    valid = np.ones(info.shape, bool)
    if mode in ("LA", "RGBA"):
        valid = a[..., -1] > 0      # fully transparent pixels carry no value
        a = a[..., :-1]
        if mode == "LA":
            a = a[..., 0]
    return Raster(info, a, valid, None, None, sidecar_of(info.path))


# -- NPY ------------------------------------------------------------------------------------

_NPY_MAGIC = b"\x93NUMPY"


def _npy_header(fh, name: str) -> tuple[tuple[int, ...], np.dtype, int]:
    """(shape, dtype, data offset) from an open NPY file's header; InputError that never
    echoes the file's bytes."""
    head = fh.read(8)
    if len(head) < 8 or head[:6] != _NPY_MAGIC:
        raise InputError(f"{name}: not an NPY file (no NPY signature at its start)")
    read = {1: np.lib.format.read_array_header_1_0, 2: np.lib.format.read_array_header_2_0,
            3: np.lib.format.read_array_header_2_0}.get(head[6])
    if read is None:
        raise InputError(f"{name}: NPY format version {head[6]}.{head[7]} is unknown (1.0, 2.0 or 3.0 expected)")
    try:
        shape, fortran, dtype = read(fh)  # the header only: no data read
    except Exception:  # numpy raises ValueError/SyntaxError/... for a damaged header
        raise InputError(f"{name}: NPY header is damaged (not a shape, order and number type)") from None
    return tuple(int(n) for n in shape), dtype, fh.tell()


def _probe_npy(path: Path) -> RasterInfo:
    name = printable(str(path))
    with open_input(path, "NPY", name) as fh:
        shape, dtype, offset = _npy_header(fh, name)
        size = fh.seek(0, 2)
    if dtype.kind not in "fiub" or dtype.hasobject or len(shape) not in (2, 3) \
            or (len(shape) == 3 and shape[2] not in (1, 3)):
        raise InputError(f"{name}: NPY holds {dtype} {shape}; need a (rows, cols) or (rows, cols, 3) number array")
    if 0 in shape:
        raise InputError(f"{name}: NPY array {shape} has no cells")
    need = math.prod(shape) * dtype.itemsize
    # an array larger than any file procgen reads is left to the reading rule's memory check,
    # whose message says what to do; reading re-checks the data length in any case
    if size - offset < need <= MAX_BYTES["NPY"]:
        raise InputError(f"{name}: NPY file is truncated: its header promises {need:,} bytes of data, "
                         f"the file has {max(size - offset, 0):,}")
    bands = 1 if len(shape) == 2 else int(shape[2])
    return RasterInfo(path, "npy", (int(shape[0]), int(shape[1])), bands, None, None, False, "")


def _read_npy(info: RasterInfo) -> Raster:
    name = printable(str(info.path))
    with open_input(info.path, "NPY", name) as fh:
        shape, dtype, offset = _npy_header(fh, name)
        if fh.seek(0, 2) - offset < math.prod(shape) * dtype.itemsize:
            raise InputError(f"{name}: NPY file is truncated: its header promises "
                             f"{math.prod(shape) * dtype.itemsize:,} bytes of data")
        fh.seek(0)
        try:
            a = np.load(fh, allow_pickle=False).astype(np.float64)
        except (ValueError, OSError, EOFError):
            raise InputError(f"{name}: NPY file is damaged or changed since it was checked") from None
    if a.ndim == 3 and a.shape[2] == 1:
        a = a[:, :, 0]
    valid = np.all(np.isfinite(a), axis=-1) if a.ndim == 3 else np.isfinite(a)
    return Raster(info, a, valid, None, None, sidecar_of(info.path))


# -- GeoTIFF (rasterio, extra "geo") --------------------------------------------------------

def _rasterio():
    try:
        import rasterio
    except ImportError:
        raise MissingExtra("reading GeoTIFF needs rasterio: pip install 'procgen-rules[geo]'", "geo") from None
    return rasterio


@contextlib.contextmanager
def _open_geotiff(path: Path) -> Iterator:
    """The GeoTIFF opened by rasterio after the file checks, as the GeoTIFF driver only, with
    no look for files beside it (.aux.xml, .ovr, world files: any of them could be a FIFO)."""
    rasterio = _rasterio()
    name = printable(str(path))
    check_input(path, "GeoTIFF", name)
    with rasterio.Env(GDAL_DISABLE_READDIR_ON_OPEN="EMPTY_DIR", GDAL_PAM_ENABLED="NO"), \
            warnings.catch_warnings():
        warnings.simplefilter("ignore")     # "not georeferenced" and the like: the probe reports what matters
        try:
            src = rasterio.open(path, driver="GTiff")
        except Exception:  # rasterio/GDAL raise several types for a file that is not a GeoTIFF
            raise InputError(f"{name}: not a raster procgen reads (GeoTIFF), or its header is damaged") from None
        with src:
            yield src


def _probe_geotiff(path: Path) -> RasterInfo:
    name = printable(str(path))
    with _open_geotiff(path) as src:
        try:
            crs = src.crs
            t = src.transform
            shape, count = (src.height, src.width), src.count
            wkt = crs.to_wkt() if crs else None
            units = (crs.linear_units or "") if crs and not crs.is_geographic else ("degree" if crs else "")
            geographic = bool(crs and crs.is_geographic)
        except Exception:  # a CRS GDAL cannot turn into WKT
            raise InputError(f"{name}: GeoTIFF's coordinate reference system is damaged") from None
    _refuse_truncated_tiff(path, name)
    if not all(map(math.isfinite, tuple(t)[:6])) or t.a == 0 or t.e == 0:
        raise InputError(f"{name}: GeoTIFF's cell size is zero or not a number")
    if t.b != 0 or t.d != 0:
        raise InputError(f"{name}: rotated or sheared raster (transform {tuple(t)[:6]}); warp it north-up first")
    return RasterInfo(path, "geotiff", shape, count, None, wkt, geographic, units)


#: most TIFF blocks (strips or tiles) whose extent the probe compares with the file's length
_MAX_BLOCKS_CHECKED = 200_000


def _refuse_truncated_tiff(path: Path, name: str) -> None:
    """InputError if a strip or tile of the TIFF ends past the end of the file (a cut download):
    from the block offsets and sizes in the header, before any pixel is read."""
    length = check_input(path, "GeoTIFF", name)
    with _open_geotiff(path) as src:
        bh, bw = src.block_shapes[0]
        rows, cols = -(-src.height // bh), -(-src.width // bw)
        if rows * cols * src.count > _MAX_BLOCKS_CHECKED:
            return
        end = 0
        for b in range(1, src.count + 1):
            for i in range(rows):
                for j in range(cols):
                    off = src.get_tag_item(f"BLOCK_OFFSET_{j}_{i}", "TIFF", bidx=b)
                    size = src.get_tag_item(f"BLOCK_SIZE_{j}_{i}", "TIFF", bidx=b)
                    if off is None or size is None:
                        return              # not a layout GDAL reports: leave it to the read
                    end = max(end, int(off) + int(size))
    if end > length:
        raise InputError(f"{name}: GeoTIFF is truncated: its pixel data runs to byte {end:,}, "
                         f"the file has {length:,}")


def _read_geotiff(info: RasterInfo, band: int) -> Raster:
    name = printable(str(info.path))
    if not 1 <= band <= info.bands:
        raise InputError(f"{name}: band {band} does not exist (the file has {info.bands})")
    with _open_geotiff(info.path) as src:
        try:
            m = src.read(band, masked=True)
        except Exception:  # truncated strips or tiles, a broken compression stream
            raise InputError(f"{name}: GeoTIFF's pixel data is damaged or truncated") from None
        scale, offset = src.scales[band - 1], src.offsets[band - 1]
        t = src.transform
    valid = ~np.ma.getmaskarray(m) & np.isfinite(np.ma.getdata(m))
    a = np.ma.getdata(m).astype(np.float64) * scale + offset
    dx, dy = float(t.a), float(-t.e)
    if dy < 0:                       # south-up file: make it north-up like every other raster
        a, valid, dy = a[::-1], valid[::-1], -dy
        top = float(t.f) + info.shape[0] * dy
    else:
        top = float(t.f)
    if dx < 0:
        a, valid, dx = a[:, ::-1], valid[:, ::-1], -dx
        left = float(t.c) - info.shape[1] * dx
    else:
        left = float(t.c)
    return Raster(info, a, valid, (dx, dy), (left, top - info.shape[0] * dy), None)


def metres_per_degree(lat_deg: float) -> tuple[float, float]:
    """(east, north) metres per degree at latitude ``lat_deg`` on the WGS84 ellipsoid (series)."""
    p = math.radians(lat_deg)
    north = 111132.92 - 559.82 * math.cos(2 * p) + 1.175 * math.cos(4 * p) - 0.0023 * math.cos(6 * p)
    east = 111412.84 * math.cos(p) - 93.5 * math.cos(3 * p) + 0.118 * math.cos(5 * p)
    return east, north
