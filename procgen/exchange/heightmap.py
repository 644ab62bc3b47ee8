"""Heightmaps: a Grid field as 16-bit PNG or NPY, each with a JSON sidecar (scale, provenance)."""
from __future__ import annotations

import io
import json
from typing import Any

import numpy as np

from ..domains import Domain, Grid
from ..errors import InputError
from .image import png_bytes
from .provenance import provenance_json


def grid_scalar(domain: Domain, field: str, layer: int | None = None, exporter: str = "") -> np.ndarray:
    """A (ny, nx) float array from a Grid field (picking ``layer`` of a layered field)."""
    if not isinstance(domain, Grid):
        raise InputError(f"{exporter}: expected a Grid, got {domain.kind}")
    arr = np.asarray(domain[field], dtype=np.float64)
    if arr.ndim == 3:
        if layer is None:
            raise InputError(f"{exporter}: field {field!r} has {arr.shape[2]} layers; give option 'layer'")
        if not -arr.shape[2] <= layer < arr.shape[2]:
            raise InputError(f"{exporter}: layer {layer} out of range for {field!r} ({arr.shape[2]} layers)")
        arr = arr[:, :, layer]
    elif arr.ndim != 2:
        raise InputError(f"{exporter}: field {field!r} has shape {arr.shape}, expected (ny, nx[, layers])")
    if not np.all(np.isfinite(arr)):
        raise InputError(f"{exporter}: field {field!r} contains NaN or inf")
    return arr


def _sidecar(domain: Grid, field: str, lo: float, hi: float, provenance: dict[str, Any] | None,
             extra: dict[str, Any]) -> bytes:
    info = domain.field_info(field)
    doc = {"field": field, "units": info.units, "z_min": lo, "z_max": hi,
           "spacing": domain.spacing, "origin": list(domain.origin), "shape": list(domain.shape),
           "row_order": "north-up (first row is the largest y)",
           "provenance": json.loads(provenance_json(provenance)), **extra}
    return (json.dumps(doc, indent=2, sort_keys=True) + "\n").encode()


def heightmap_png16(domain: Domain, *, stem: str, provenance: dict[str, Any] | None = None,
                    field: str = "surface__height", layer: int | None = None,
                    z_min: float | None = None, z_max: float | None = None) -> dict[str, bytes]:
    """16-bit greyscale PNG (0 = z_min, 65535 = z_max) plus ``stem.json`` with the scale."""
    arr = grid_scalar(domain, field, layer, "heightmap_png16")
    lo = float(arr.min()) if z_min is None else float(z_min)
    hi = float(arr.max()) if z_max is None else float(z_max)
    span = hi - lo if hi > lo else 1.0
    q = np.round(np.clip((arr - lo) / span, 0.0, 1.0) * 65535.0).astype(np.uint16)
    png = png_bytes(np.flipud(q), provenance)
    side = _sidecar(domain, field, lo, hi, provenance, {"encoding": "png16", "layer": layer})
    return {f"{stem}.png": png, f"{stem}.json": side}


def heightmap_npy(domain: Domain, *, stem: str, provenance: dict[str, Any] | None = None,
                  field: str = "surface__height", layer: int | None = None) -> dict[str, bytes]:
    """Raw float field as NPY (north-up rows) plus ``stem.json``."""
    arr = grid_scalar(domain, field, layer, "npy") if layer is not None or np.ndim(domain[field]) == 2 \
        else np.asarray(domain[field], np.float64)
    buf = io.BytesIO()
    np.save(buf, np.ascontiguousarray(np.flipud(arr)), allow_pickle=False)
    side = _sidecar(domain, field, float(np.min(arr)), float(np.max(arr)), provenance,
                    {"encoding": "npy", "layer": layer, "dtype": "float64"})
    return {f"{stem}.npy": buf.getvalue(), f"{stem}.json": side}
