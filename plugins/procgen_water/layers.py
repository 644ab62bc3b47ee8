"""The 2.5D multi-layer surface: base height plus stacked layer thicknesses (thesis 2.4.1).

A layer spec is a recipe dict mixing geometry keys (below) with material keys
(:mod:`procgen_layers.materials`).  Geometry: nominal ``thickness``; ``noise`` amplitude (same units)
of a midpoint-displacement field with Hurst exponent ``hurst``; ``smoothness`` (Gaussian sigma in
cells, applied to the noise, digest #29); and where the layer exists: ``coverage`` (fraction of
the grid, patches from smooth noise), ``rect`` [x0, y0, x1, y1] (fractions of the extent),
``spots`` [[x, y, r], ...] (fractions; r of the smaller side) or ``n_spots``/``spot_radius``
(random), with ``edge`` (Gaussian sigma, cells) softening the mask's border.

``periodic`` (a tileable surface): every noise, blur and spot wraps round the edges, so the
maps tile; a ``rect`` stays where it is put (it is the user's own cut).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Mapping, Sequence

import numpy as np

from procgen import portable
from procgen.errors import InputError
from procgen_layers.materials import MaterialTable, split_layer_specs

from .noise import midpoint_displacement, rank_normalise, smooth

GEOMETRY_KEYS = ("thickness", "noise", "hurst", "smoothness", "coverage", "coverage_scale",
                 "rect", "spots", "n_spots", "spot_radius", "edge")
MIN_CELLS = 3     # the 3x3 stencils (gradients, corrosion neighbourhoods) need at least 3x3


@dataclass(frozen=True)
class LayerGeometry:
    """How one layer's thickness map is generated."""

    thickness: float = 1.0
    noise: float = 0.0
    hurst: float = 0.7
    smoothness: float = 1.0
    coverage: float = 1.0
    coverage_scale: float = 6.0
    rect: tuple[float, float, float, float] | None = None
    spots: tuple[tuple[float, float, float], ...] = ()
    n_spots: int = 0
    spot_radius: float = 0.08
    edge: float = 1.0


def _num(d: Mapping[str, Any], key: str, where: str, lo: float | None = None,
         hi: float | None = None, default: float = 0.0) -> float:
    v = d.get(key, default)
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not np.isfinite(v):
        raise InputError(f"{where}: {key} must be a finite number, got {v!r}")
    if (lo is not None and v < lo) or (hi is not None and v > hi):
        rng = f"[{lo if lo is not None else '-inf'}, {hi if hi is not None else 'inf'}]"
        raise InputError(f"{where}: {key} must be in {rng}, got {v}")
    return float(v)


def parse_layers(specs: Sequence[Any], where: str = "layers") -> tuple[MaterialTable, list[LayerGeometry]]:
    """Split recipe layer specs into a MaterialTable and per-layer geometry (bottom first)."""
    table, geo_dicts = split_layer_specs(specs, GEOMETRY_KEYS, where)
    return table, [_geometry(g, f"{where}[{i}] ({m.name})")
                   for i, (g, m) in enumerate(zip(geo_dicts, table.materials))]


def _geometry(d: Mapping[str, Any], where: str) -> LayerGeometry:
    rect = d.get("rect")
    if rect is not None:
        if not (isinstance(rect, (list, tuple)) and len(rect) == 4):
            raise InputError(f"{where}: rect must be [x0, y0, x1, y1] fractions, got {rect!r}")
        rect = tuple(_num({"v": v}, "v", f"{where}: rect", 0.0, 1.0) for v in rect)
        if rect[2] <= rect[0] or rect[3] <= rect[1]:
            raise InputError(f"{where}: rect {list(rect)} is empty (need x1 > x0 and y1 > y0)")
    spots = d.get("spots", ())
    if not isinstance(spots, (list, tuple)) or any(
            not isinstance(s, (list, tuple)) or len(s) != 3 for s in spots):
        raise InputError(f"{where}: spots must be a list of [x, y, r] fractions, got {spots!r}")
    spots = tuple(tuple(_num({"v": v}, "v", f"{where}: spots", 0.0, 1.0) for v in s) for s in spots)
    n_spots = d.get("n_spots", 0)
    if isinstance(n_spots, bool) or not isinstance(n_spots, int) or n_spots < 0:
        raise InputError(f"{where}: n_spots must be an integer >= 0, got {n_spots!r}")
    return LayerGeometry(
        thickness=_num(d, "thickness", where, 0.0, None, 1.0),
        noise=_num(d, "noise", where, 0.0, None, 0.0),
        hurst=_num(d, "hurst", where, 0.01, 1.0, 0.7),
        smoothness=_num(d, "smoothness", where, 0.0, None, 1.0),
        coverage=_num(d, "coverage", where, 0.0, 1.0, 1.0),
        coverage_scale=_num(d, "coverage_scale", where, 0.0, None, 6.0),
        rect=rect, spots=spots, n_spots=n_spots,
        spot_radius=_num(d, "spot_radius", where, 0.0, 1.0, 0.08),
        edge=_num(d, "edge", where, 0.0, None, 1.0))


def layer_mask(geo: LayerGeometry, shape: tuple[int, int], rng: np.random.Generator,
               periodic: bool = False) -> np.ndarray:
    """Where the layer exists, in [0, 1] (soft edges): rect AND (spots OR coverage patches)."""
    ny, nx = shape
    yy, xx = np.mgrid[0:ny, 0:nx]
    fx, fy = (xx + 0.5) / nx, (yy + 0.5) / ny
    mask = np.ones(shape, dtype=bool)
    if geo.rect is not None:
        x0, y0, x1, y1 = geo.rect
        mask &= (fx >= x0) & (fx < x1) & (fy >= y0) & (fy < y1)
    spots = list(geo.spots)
    if geo.n_spots:
        pos = rng.uniform(0.1, 0.9, (geo.n_spots, 2))
        spots += [(float(p[0]), float(p[1]), geo.spot_radius) for p in pos]
    if spots:
        r_unit = min(nx, ny)
        inside = np.zeros(shape, dtype=bool)
        for sx, sy, sr in spots:    # a handful of spots: one vectorised disc test each
            dx, dy = xx + 0.5 - sx * nx, yy + 0.5 - sy * ny
            if periodic:            # the nearest copy of the spot on the torus
                dx = dx - nx * np.round(dx / nx)
                dy = dy - ny * np.round(dy / ny)
            inside |= dx ** 2 + dy ** 2 <= (sr * r_unit) ** 2
        mask &= inside
    if geo.coverage < 1.0:
        patches = rank_normalise(smooth(rng.standard_normal(shape), geo.coverage_scale, periodic))
        mask &= patches >= 1.0 - geo.coverage
    m = mask.astype(float)
    return np.clip(smooth(m, geo.edge, periodic), 0.0, 1.0) if geo.edge > 0 else m


def layer_thickness(geo: LayerGeometry, shape: tuple[int, int], rng: np.random.Generator,
                    periodic: bool = False) -> np.ndarray:
    """Nominal thickness + smoothed fBm noise, times the mask, clipped at 0."""
    t = np.full(shape, geo.thickness)
    if geo.noise > 0:
        t += geo.noise * smooth(midpoint_displacement(shape, geo.hurst, rng, periodic), geo.smoothness, periodic)
    t *= layer_mask(geo, shape, rng, periodic)
    t = np.maximum(t, 0.0)
    t[t < 1e-9 * max(geo.thickness, 1e-12)] = 0.0     # no dust-thin films from soft edges
    return t


def base_surface(kind: str, shape: tuple[int, int], spacing: float, rng: np.random.Generator, *,
                 amplitude: float = 0.0, hurst: float = 0.8, smoothness: float = 1.0,
                 tilt_deg: float = 0.0, periodic: bool = False) -> np.ndarray:
    """The substrate the layers sit on: 'flat', 'tilt' (plane falling towards +y... i.e. downhill
    to low y), 'fbm' (fractal relief) or 'mountain' (fBm on a radial dome, peaks inland).
    ``periodic``: a tileable fBm ('tilt' and 'mountain' do not tile: refused)."""
    if periodic and (kind in ("tilt", "mountain") or tilt_deg):
        raise InputError(f"base surface: {kind!r}{' with a tilt' if tilt_deg else ''} does not tile "
                         "(periodic needs base = 'flat' or 'fbm' and no tilt)")
    ny, nx = shape
    yy, xx = np.mgrid[0:ny, 0:nx].astype(float)
    z = np.zeros(shape)
    if kind == "tilt" or tilt_deg:
        z += math.tan(math.radians(tilt_deg)) * (yy + 0.5) * spacing  # high at the top row (max y)
    if kind in ("fbm", "mountain"):
        f = smooth(midpoint_displacement(shape, hurst, rng, periodic), smoothness, periodic)
        if kind == "mountain":
            r = np.hypot((xx + 0.5) / nx - 0.5, (yy + 0.5) / ny - 0.5) / 0.5
            dome = portable.exp(-(r / 0.55) ** 2)      # smooth: no ring where a clipped dome ends
            f = dome * (1.0 + 0.5 * f) + 0.12 * f
            f = f - f.min()
            f = f / f.max() if f.max() > 0 else f
        z += amplitude * f
    elif kind not in ("flat", "tilt"):
        raise InputError(f"base surface: unknown kind {kind!r} (flat, tilt, fbm, mountain)")
    return z


def check_grid(shape: tuple[int, int], where: str) -> None:
    if min(shape) < MIN_CELLS:
        raise InputError(f"{where}: grid {shape[0]}x{shape[1]} is too small for the 3x3 stencil "
                         f"(need at least {MIN_CELLS}x{MIN_CELLS})")
