"""Reading rasters people bring: greyscale/RGB PNG (with procgen's own JSON sidecar), NPY, GeoTIFF.

Why: a heightmap, a DEM or a painted mask is the first thing users want to feed an erosion or
weathering recipe. Pillow reads images, numpy reads NPY, rasterio (optional extra ``geo``)
reads GeoTIFF with its CRS, affine transform, nodata and scale/offset. Everything comes back
north-up (row 0 = top of the picture) as float64 with a validity mask, plus what the file says
about where its cells are; the rules turn that into a Grid (row 0 = south).

``probe_raster`` reads headers only, so ``procgen check`` can refuse a colour image given as
heights, a file that is not an image, a degree-based DEM or a raster too big for memory
before anything is computed.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import InputError, MissingExtra

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
    if not path.is_file():
        raise InputError(f"{path}: file not found")
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
    """procgen's JSON sidecar beside ``path`` (``stem.json``), if there is one."""
    side = path.with_suffix(".json")
    if not side.is_file():
        return None
    try:
        doc = json.loads(side.read_text())
    except (OSError, ValueError) as exc:
        raise InputError(f"{side}: sidecar is not readable JSON ({exc})") from None
    if not isinstance(doc, dict) or "encoding" not in doc:
        return None                 # someone else's JSON: not ours to interpret
    shape = doc.get("shape")
    if not (isinstance(shape, list) and len(shape) == 2):
        raise InputError(f"{side}: sidecar has no [rows, columns] 'shape'")
    return doc


# -- images (Pillow) ------------------------------------------------------------------------

def _open_image(path: Path):
    from PIL import Image, UnidentifiedImageError

    try:
        return Image.open(path)
    except Image.DecompressionBombError as exc:
        raise InputError(f"{path}: image too large to load ({str(exc).split('.')[0]})") from None
    except (UnidentifiedImageError, OSError) as exc:
        raise InputError(f"{path}: not an image file Pillow can read ({type(exc).__name__})") from None


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
            if mode in ("P", "PA"):
                im = im.convert("RGBA")
                mode = "RGBA"
            a = np.asarray(im)
        except (OSError, ValueError) as exc:
            raise InputError(f"{info.path}: image data is damaged ({exc})") from None
    a = a.astype(np.float64)
    valid = np.ones(info.shape, bool)
    if mode in ("LA", "RGBA"):
        valid = a[..., -1] > 0      # fully transparent pixels carry no value
        a = a[..., :-1]
        if mode == "LA":
            a = a[..., 0]
    return Raster(info, a, valid, None, None, sidecar_of(info.path))


# -- NPY ------------------------------------------------------------------------------------

def _probe_npy(path: Path) -> RasterInfo:
    try:
        with path.open("rb") as fh:
            version = np.lib.format.read_magic(fh)
            read = np.lib.format.read_array_header_1_0 if version == (1, 0) \
                else np.lib.format.read_array_header_2_0
            shape, _, dtype = read(fh)  # the header only: no data read
    except (OSError, ValueError) as exc:
        raise InputError(f"{path}: not an NPY file ({exc})") from None
    if dtype.kind not in "fiub" or len(shape) not in (2, 3) or (len(shape) == 3 and shape[2] not in (1, 3)):
        raise InputError(f"{path}: NPY holds {dtype} {shape}; need a (rows, cols) or (rows, cols, 3) number array")
    bands = 1 if len(shape) == 2 else int(shape[2])
    return RasterInfo(path, "npy", (int(shape[0]), int(shape[1])), bands, None, None, False, "")


def _read_npy(info: RasterInfo) -> Raster:
    a = np.load(info.path, allow_pickle=False).astype(np.float64)
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


def _probe_geotiff(path: Path) -> RasterInfo:
    rasterio = _rasterio()
    try:
        with rasterio.open(path) as src:
            crs = src.crs
            t = src.transform
            shape, count = (src.height, src.width), src.count
    except rasterio.errors.RasterioIOError as exc:
        raise InputError(f"{path}: not a raster GDAL can read ({str(exc).splitlines()[0]})") from None
    if t.b != 0 or t.d != 0:
        raise InputError(f"{path}: rotated or sheared raster (transform {tuple(t)[:6]}); warp it north-up first")
    wkt = crs.to_wkt() if crs else None
    units = (crs.linear_units or "") if crs and not crs.is_geographic else ("degree" if crs else "")
    return RasterInfo(path, "geotiff", shape, count, None, wkt, bool(crs and crs.is_geographic), units)


def _read_geotiff(info: RasterInfo, band: int) -> Raster:
    rasterio = _rasterio()
    if not 1 <= band <= info.bands:
        raise InputError(f"{info.path}: band {band} does not exist (the file has {info.bands})")
    with rasterio.open(info.path) as src:
        m = src.read(band, masked=True)
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
