"""GeoTIFF output: a Grid field written with the CRS and transform of the DEM it came from.

Why: an eroded DEM is only useful if it drops back into QGIS or GDAL in place. grid.load
keeps the source CRS (domain field ``geo__crs``, WKT) and the affine map from grid to CRS
coordinates (``geo__to_crs``); this exporter composes that map with the grid's own cell
layout, so a resampled or re-spaced grid still lands where it should. rasterio (extra
``geo``) writes the file in memory; the bytes go through procgen.exchange.write like any
other output.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from ..domains import Domain, Grid
from ..errors import InputError, MissingExtra
from .heightmap import grid_scalar
from .provenance import provenance_json
from .registry import Exporter


def crs_transform(grid: Grid) -> tuple[float, float, float, float, float, float]:
    """rasterio/GDAL affine (a, b, c, d, e, f) of the grid's north-up raster in CRS coordinates."""
    m = np.asarray(grid["geo__to_crs"], np.float64) if "geo__to_crs" in grid else np.eye(3)
    s, (ox, oy), ny = grid.spacing, grid.origin, grid.shape[0]
    top = oy + ny * s
    return (m[0, 0] * s, -m[0, 1] * s, m[0, 0] * ox + m[0, 1] * top + m[0, 2],
            m[1, 0] * s, -m[1, 1] * s, m[1, 0] * ox + m[1, 1] * top + m[1, 2])


def geotiff_export(domain: Domain, *, stem: str, provenance: dict[str, Any] | None = None,
                   field: str = "surface__height", layer: int | None = None, crs: str = "",
                   nodata_field: str = "") -> bytes:
    """Float32 GeoTIFF (deflate) of a Grid field, north-up; cells marked in ``nodata_field``
    (grid.load's ``surface__nodata``) are written as NaN nodata. CRS: the grid's ``geo__crs``, else the ``crs`` option (e.g.
    "EPSG:32633"), else none."""
    try:
        from rasterio.crs import CRS
        from rasterio.errors import CRSError
        from rasterio.io import MemoryFile
        from rasterio.transform import Affine
    except ImportError:
        raise MissingExtra("geotiff: writing GeoTIFF needs rasterio: pip install 'procgen-rules[geo]'", "geo") from None
    arr = grid_scalar(domain, field, layer, "geotiff")
    assert isinstance(domain, Grid)
    wkt = str(domain["geo__crs"]) if "geo__crs" in domain else crs
    try:
        crs_obj = CRS.from_user_input(wkt) if wkt else None
    except CRSError as exc:
        raise InputError(f"geotiff: crs {wkt[:60]!r} is not a CRS rasterio knows ({exc})") from None
    data = np.flipud(arr).astype(np.float32)
    if nodata_field:
        data[np.flipud(np.asarray(domain[nodata_field]) > 0.5)] = np.nan
    ny, nx = data.shape
    profile = {"driver": "GTiff", "width": nx, "height": ny, "count": 1, "dtype": "float32",
               "crs": crs_obj, "transform": Affine(*crs_transform(domain)), "nodata": float("nan"),
               "compress": "deflate", "predictor": 3}
    with MemoryFile() as mem:
        with mem.open(**profile) as dst:
            dst.write(data, 1)
            dst.update_tags(procgen=provenance_json(provenance), field=field)
        return bytes(mem.read())


GEOTIFF_EXPORTER = Exporter("geotiff", ("Grid",), ".tif", geotiff_export,
                            "a Grid field as float32 GeoTIFF with the source DEM's CRS and transform (extra geo)")
