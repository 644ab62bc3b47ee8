"""Bring your own rasters: grid.load (heightmaps, DEMs), grid.image_field and mesh.image_field.

Why: erosion and weathering are most useful on the user's own terrain, painted masks and
textures. The file is probed at check time (``validate``), so a colour image given as heights,
a file that is not an image, a DEM counted in degrees or a raster bigger than memory fails in
one line naming the file before anything runs. Reading is procgen.exchange.raster_read.

Conventions: a Grid's row 0 is its south edge (smallest y) while images and DEMs store the
north row first, so rasters are flipped on the way in (and the exporters flip them back).
Nodata cells (GeoTIFF nodata, NaN in NPY, transparent pixels) are *filled* by linear
interpolation from the cells around each hole, so every rule sees finite, smooth heights, and
*marked* in the cell field ``surface__nodata`` (1 = no data in the file) so outputs can mask
them again.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np
from scipy import ndimage

from .. import portable
from ..data import builtin_rules_dir
from ..domains import Grid, TriMesh
from ..errors import InputError, MissingExtra
from ..exchange.input_files import refuse_special
from ..exchange.raster_read import Raster, RasterInfo, metres_per_degree, probe_raster, read_raster, sidecar_of
from ..fields import FieldSpec
from ..params import param
from ..rules import RuleBase
from ..state import State

#: the shipped 16-bit heightmap the examples and the contract suite load
SAMPLE_HEIGHTMAP = "data/mesa-png16.png"


def resolve_data_path(path: str, base_dir: Path | None) -> Path:
    """Absolute path, relative to the recipe's folder or the working folder, or a file shipped
    under the built-in rules folder (``data/...``)."""
    p = Path(path).expanduser()
    candidates = [p] if p.is_absolute() else \
        ([base_dir / p] if base_dir else []) + [Path.cwd() / p, builtin_rules_dir() / p]
    for c in candidates:
        refuse_special(c, path)
        if c.is_file():
            return c
    places = list(dict.fromkeys(str(c.parent) for c in candidates[:-1])) + ["the shipped samples"] \
        if not p.is_absolute() else [str(p.parent)]
    raise InputError(f"file {path!r} not found (looked in: {', '.join(places)})")


def resample(values: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Cell-centred linear resampling of a (rows, cols[, bands]) raster to ``shape``.

    Shrinking first low-passes with a Gaussian of sigma (factor - 1) / 2 cells so that
    detail finer than the new cells averages out instead of aliasing.
    """
    a = np.asarray(values, np.float64)
    if a.shape[:2] == tuple(shape):
        return a.copy()
    factor = (shape[0] / a.shape[0], shape[1] / a.shape[1])
    sigma = [max(0.0, (1.0 / f - 1.0) / 2.0) for f in factor] + [0.0] * (a.ndim - 2)
    if any(sigma):
        a = portable.gaussian_filter(a, sigma, mode="nearest")
    zoom = list(factor) + [1.0] * (a.ndim - 2)
    out = ndimage.zoom(a, zoom, order=1, mode="nearest", grid_mode=True)
    return out[: shape[0], : shape[1]]


def fill_nodata(values: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Holes filled by linear interpolation from the cells on their rim (scipy's Delaunay-based
    griddata), so a filled lake or cloud gap is a smooth surface, not nearest-cell terraces;
    cells outside the rim's convex hull (a hole touching the edge) take the nearest rim value."""
    if valid.all():
        return values
    from scipy.interpolate import griddata
    from scipy.spatial import QhullError

    rim = valid & ndimage.binary_dilation(~valid, structure=np.ones((3, 3), bool))
    holes = np.nonzero(~valid)
    pts = np.column_stack(np.nonzero(rim)).astype(np.float64)
    at = np.column_stack(holes).astype(np.float64)
    out = values.copy()
    try:
        fill = griddata(pts, values[rim], at, method="linear")
    except QhullError:             # a rim in one line (a hole along a whole edge): no triangles
        fill = np.full(len(at), np.nan)
    gap = ~np.isfinite(fill)
    if gap.any():
        fill[gap] = griddata(pts, values[rim], at[gap], method="nearest")
    out[holes] = fill
    return out


def target_shape(rows: int, cols: int, width: float, height: float, nx: int, ny: int,
                 square: bool) -> tuple[tuple[int, int], float]:
    """(ny, nx) and the square cell size covering a ``width`` x ``height`` extent.

    nx and ny 0 keep the file's cells (when they are square); one of them given, the other
    follows the aspect ratio; both given, they must describe square cells within 1 %.
    """
    if nx == 0 and ny == 0:
        if square:
            return (rows, cols), width / cols
        s = min(width / cols, height / rows)
        nx = max(1, round(width / s))
    if nx and ny:
        s = width / nx
        if abs(height / ny - s) > 0.01 * s:
            raise ValueError(f"nx = {nx}, ny = {ny} give cells of {s:g} x {height / ny:g}; Grid cells are "
                             f"square: give only one of them (the other follows the {width:g} x {height:g} extent)")
        return (ny, nx), s
    if nx:
        s = width / nx
        return (max(1, round(height / s)), nx), s
    s = height / ny
    return (ny, max(1, round(width / s))), s


@dataclass(kw_only=True)
class LoadGrid(RuleBase):
    """A Grid from a heightmap file: 8/16-bit greyscale PNG (with procgen's sidecar), NPY, GeoTIFF DEM.

    Heights go to ``surface__height``. A PNG written by the ``heightmap_png16`` (or NPY by
    ``npy``) exporter comes back with its heights, spacing and origin from the JSON sidecar
    beside it (within one 16-bit quantisation step). A GeoTIFF (extra ``geo``) gives cell size,
    origin, CRS, scale/offset and nodata; the CRS is kept in the domain field ``geo__crs`` and the
    map from grid to CRS coordinates in ``geo__to_crs`` so the ``geotiff`` exporter writes the
    result back in place. Nodata cells are filled by interpolation from the data around them and
    marked in ``surface__nodata``.
    """

    name: ClassVar[str] = "grid.load"
    example: ClassVar[tuple[dict, ...]] = ({"rule": "grid.load", "params": {"file": SAMPLE_HEIGHTMAP, "nx": 40}},)
    creates: ClassVar[dict[str, str]] = {"{grid}": "Grid"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("surface__height", "{grid}", "cell", "out", units="length", doc="height from the file"),
        FieldSpec("surface__nodata", "{grid}", "cell", "out", units="1", doc="1 = no data in the file (filled)"),
    )

    file: str = param(doc="heightmap: .png (8/16-bit grey), .npy or .tif/.tiff; absolute, relative to "
                          "the recipe, or shipped (data/mesa-png16.png)")
    grid: str = param("terrain", doc="name of the Grid to create")
    nx: int = param(0, ge=0, le=16384, units="cells", doc="resample to this many cells across (0 = the file's)")
    ny: int = param(0, ge=0, le=16384, units="cells", doc="resample to this many cells down (0 = the file's)")
    spacing: float | None = param(None, gt=0.0, units="length",
                                  doc="size of one file pixel (None = from the sidecar or GeoTIFF, else 1)")
    z_min: float | None = param(None, units="length", doc="height of black in a PNG (None = sidecar's, else 0)")
    z_max: float | None = param(None, units="length", doc="height of white in a PNG (None = sidecar's, else 1)")
    band: int = param(1, ge=1, doc="GeoTIFF band holding the heights")
    geographic: bool = param(False, doc="accept a DEM in degrees: cells become metres at its centre latitude")

    def validate(self) -> None:
        info = self._probe(self.recipe_dir)
        if info.bands != 1 and info.format != "geotiff":
            raise ValueError(f"{info.path.name}: a colour image ({info.bands} channels) given as heights; "
                             "save it as greyscale, or load it as a field with grid.image_field")
        if info.format == "geotiff" and self.band > info.bands:
            raise ValueError(f"{info.path.name}: band {self.band} does not exist (the file has {info.bands})")
        if info.geographic and not self.geographic:
            raise ValueError(f"{info.path.name}: CRS counts in degrees, not a length; reproject it "
                             "(gdalwarp -t_srs EPSG:...) or set geographic = true")
        if info.max_value is None and (self.z_min is not None or self.z_max is not None):
            raise ValueError(f"{info.path.name}: z_min/z_max scale integer images; this file holds heights")
        rows, cols = info.shape
        if info.format != "geotiff":
            try:
                side = sidecar_of(info.path)
            except InputError as exc:
                raise ValueError(str(exc)) from None
            if side and list(side["shape"]) != [rows, cols]:
                raise ValueError(f"{info.path.name}: sidecar shape {side['shape']} does not match the "
                                 f"file's {[rows, cols]}; remove the stale .json")
        target_shape(rows, cols, float(cols), float(rows), self.nx, self.ny, True)
        from ..recipes import memory_limit_bytes

        need, limit = self._bytes(rows, cols), memory_limit_bytes()
        if need > limit:
            raise ValueError(f"{info.path.name}: a {cols} x {rows} raster needs about {need / 2**30:.1f} GiB to load, "
                             f"more than the {limit / 2**30:.1f} GiB this machine can give; crop or downsample "
                             "the file first (gdal_translate -srcwin / -outsize)")

    def _bytes(self, rows: int, cols: int) -> int:
        """Reading, filling and resampling: about six float64 copies of the file and of the grid."""
        return int(8 * 6 * (rows * cols + (self.nx or cols) * (self.ny or rows)))

    def _probe(self, base_dir: Path | None) -> RasterInfo:
        try:
            return probe_raster(resolve_data_path(self.file, base_dir))
        except MissingExtra:
            raise
        except InputError as exc:
            raise ValueError(str(exc)) from None

    def memory_estimate(self) -> int:
        return self._bytes(*self._probe(self.recipe_dir).shape)

    def step(self, state: State) -> bool:
        r = read_raster(resolve_data_path(self.file, state.base_dir), self.band)
        grid = self.build(r)
        state.add_domain(self.grid, grid)
        state.report(f"{self.grid}.loaded", {"file": r.info.path.name, "shape": list(grid.shape),
                                             "spacing": grid.spacing, "crs_units": r.info.crs_units,
                                             "nodata_cells": int(grid["surface__nodata"].sum())})
        return True

    def build(self, r: Raster) -> Grid:
        """The Grid the raster describes (heights scaled, nodata filled, resampled)."""
        name = r.info.path.name
        if not r.valid.any():
            raise InputError(f"{name}: every cell is nodata")
        side = r.sidecar or {}
        if side and list(side["shape"]) != list(r.info.shape):
            raise InputError(f"{name}: sidecar shape {side['shape']} does not match the "
                             f"image {list(r.info.shape)}; remove the stale .json")
        h = r.values
        if r.info.max_value is not None:
            lo = self.z_min if self.z_min is not None else float(side.get("z_min", 0.0))
            hi = self.z_max if self.z_max is not None else float(side.get("z_max", 1.0))
            h = lo + h / r.info.max_value * (hi - lo)
        rows, cols = r.info.shape
        to_crs = np.eye(3)
        if r.pixel is not None and r.origin is not None:        # GeoTIFF
            dx, dy = r.pixel
            x0, y0 = r.origin
            if r.info.geographic:
                ex, ny_ = metres_per_degree(y0 + rows * dy / 2.0)
                to_crs = np.array([[1.0 / ex, 0.0, x0], [0.0, 1.0 / ny_, y0], [0.0, 0.0, 1.0]])
                dx, dy, x0, y0 = dx * ex, dy * ny_, 0.0, 0.0
        else:
            dx = dy = float(side.get("spacing", 1.0))
            x0, y0 = (float(v) for v in side.get("origin", (0.0, 0.0)))
        if self.spacing is not None:
            k = self.spacing / dx
            to_crs = to_crs @ np.array([[1 / k, 0.0, x0 - x0 / k], [0.0, 1 / k, y0 - y0 / k], [0.0, 0.0, 1.0]])
            dx, dy = dx * k, dy * k
        square = math.isclose(dx, dy, rel_tol=1e-6)
        try:
            shape, s = target_shape(rows, cols, cols * dx, rows * dy, self.nx, self.ny, square)
        except ValueError as exc:
            raise InputError(f"{name}: {exc}") from None
        # whole cells cannot always cover the extent exactly: map the grid onto the file's footprint
        sx, sy = cols * dx / (shape[1] * s), rows * dy / (shape[0] * s)
        to_crs = to_crs @ np.array([[sx, 0.0, x0 - sx * x0], [0.0, sy, y0 - sy * y0], [0.0, 0.0, 1.0]])
        h = resample(fill_nodata(h, r.valid), shape)
        missing = resample((~r.valid).astype(np.float64), shape) > 0.5 if not r.valid.all() \
            else np.zeros(shape, bool)
        g = Grid(shape, s, (x0, y0))
        g.add_field("surface__height", np.flipud(h), at="cell", units="length", doc=f"height from {name}")
        g.add_field("surface__nodata", np.flipud(missing).astype(np.float64), at="cell", units="1",
                    doc="1 = no data in the file (filled from the nearest cell with data)")
        if r.info.crs is not None:
            g.add_field("geo__crs", np.array(r.info.crs), at="domain", doc="CRS of the source (WKT)")
        if r.info.format == "geotiff":
            g.add_field("geo__to_crs", to_crs, at="domain", doc="affine: grid (x, y, 1) -> CRS coordinates")
        return g


def _grey(values: np.ndarray) -> np.ndarray:
    """Luma (ITU-R BT.601) of an RGB raster; a grey raster as it is."""
    return values @ np.array([0.299, 0.587, 0.114]) if values.ndim == 3 else values


@dataclass(kw_only=True)
class ImageFieldParams(RuleBase):
    """Parameters the two image-field rules share (declared once here)."""

    file: str = param(doc="image (.png, .jpg...) or .npy: absolute, relative to the recipe, or shipped")
    field: str = param("image__value", doc="name of the field to write")
    channels: str = param("grey", choices=("grey", "rgb"), doc="one grey value (luma) or three RGB values")
    vmin: float = param(0.0, doc="field value of black")
    vmax: float = param(1.0, doc="field value of white")
    units: str = param("1", doc="units of the field")

    def validate(self) -> None:
        try:
            info = probe_raster(resolve_data_path(self.file, self.recipe_dir))
        except InputError as exc:
            raise ValueError(str(exc)) from None
        if info.format == "geotiff":
            raise ValueError(f"{info.path.name}: a GeoTIFF is a height raster; load it with grid.load")
        if self.channels == "rgb" and info.bands != 3:
            raise ValueError(f"{info.path.name}: channels = 'rgb' but the image is greyscale")

    def memory_estimate(self, sizes: object = None) -> int:
        """Decoding, scaling and resampling: about four float64 copies of the image's bands."""
        try:
            info = probe_raster(resolve_data_path(self.file, self.recipe_dir))
        except InputError:
            return 0                # validate has refused the file in one line already
        rows, cols = info.shape
        return int(8 * 4 * rows * cols * max(info.bands, 1))

    def image(self, state: State) -> tuple[np.ndarray, np.ndarray, str]:
        """(values scaled to [vmin, vmax], north-up; valid mask; file name)."""
        r = read_raster(resolve_data_path(self.file, state.base_dir))
        v = r.values / (r.info.max_value or 1.0)
        v = _grey(v) if self.channels == "grey" else v
        return self.vmin + v * (self.vmax - self.vmin), r.valid, r.info.path.name


@dataclass(kw_only=True)
class GridImageField(ImageFieldParams):
    """A greyscale or RGB image as a cell field on an existing Grid (a painted weak map, a rain mask).

    The picture is stretched over the whole grid (top row of the image = north edge), resampled
    cell-centred; black maps to ``vmin`` and white to ``vmax`` (luma for ``channels = 'grey'``).
    """

    name: ClassVar[str] = "grid.image_field"
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "grid.noise", "params": {"nx": 24, "ny": 16}},
        {"rule": "grid.image_field", "params": {"file": "data/weak-map.png", "field": "corrosion__weak"}})
    uses: ClassVar[dict[str, str]] = {"{grid}": "Grid"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("{field}", "{grid}", "cell", "out", doc="image values"),)

    grid: str = param("terrain", doc="Grid to paint")

    def step(self, state: State) -> bool:
        g = state.get(self.grid, Grid)
        v, _, name = self.image(state)
        g.add_field(self.field, np.flipud(resample(v, g.shape)), at="cell", units=self.units, doc=f"from {name}")
        return True


def sample_bilinear(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Texture lookup: ``image`` row 0 = top (v = 1), uv in [0, 1] repeating, bilinear."""
    rows, cols = image.shape[:2]
    x = np.mod(uv[:, 0], 1.0) * cols - 0.5
    y = (1.0 - np.mod(uv[:, 1], 1.0)) * rows - 0.5
    x0, y0 = np.floor(x).astype(np.int64), np.floor(y).astype(np.int64)
    fx, fy = x - x0, y - y0
    if image.ndim == 3:
        fx, fy = fx[:, None], fy[:, None]

    def at(r: np.ndarray, c: np.ndarray) -> np.ndarray:
        return image[np.clip(r, 0, rows - 1), np.mod(c, cols)]

    return ((1 - fy) * ((1 - fx) * at(y0, x0) + fx * at(y0, x0 + 1))
            + fy * ((1 - fx) * at(y0 + 1, x0) + fx * at(y0 + 1, x0 + 1)))


@dataclass(kw_only=True)
class MeshImageField(ImageFieldParams):
    """An image as a face field of a TriMesh, through its UVs or a planar projection.

    ``projection = 'uv'`` reads the mesh's UV field (vertex (n, 2) or face corners (m, 3, 2),
    v = 1 at the image's top row, repeating; ``mesh.load`` keeps an OBJ's UVs as ``mesh__uv``); 'xy', 'xz' or 'yz' project the image onto the
    mesh's bounding box seen along the missing axis (a decal on an extruded outline). Each face
    takes the value at its UV centroid.
    """

    name: ClassVar[str] = "mesh.image_field"
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "plane"}},
        {"rule": "mesh.image_field", "params": {"file": "data/weak-map.png", "projection": "xy"}})
    uses: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("{field}", "{mesh}", "face", "out", doc="image values"),)

    mesh: str = param("mesh", doc="TriMesh to paint")
    projection: str = param("uv", choices=("uv", "xy", "xz", "yz"), doc="mesh UVs, or a planar projection")
    uv_field: str = param("mesh__uv", doc="UV field when projection = 'uv' (vertex or face corners; "
                                          "mesh.load writes mesh__uv)")

    def uvs(self, m: TriMesh) -> np.ndarray:
        """(n, 2) vertex UVs or (m, 3, 2) corner UVs."""
        if self.projection != "uv":
            axes = {"xy": (0, 1), "xz": (0, 2), "yz": (1, 2)}[self.projection]
            v = m.vertices[:, axes] if m.vertices.shape[1] > max(axes) else None
            if v is None:
                raise InputError(f"projection {self.projection!r} needs 3-D vertices")
            lo, span = v.min(axis=0), np.ptp(v, axis=0)
            return (v - lo) / np.where(span > 0, span, 1.0)
        if self.uv_field not in m:
            raise InputError(f"mesh {self.mesh!r} has no UV field {self.uv_field!r}; "
                             "use a planar projection ('xy', 'xz', 'yz')")
        return np.asarray(m[self.uv_field], np.float64)

    def step(self, state: State) -> bool:
        m = state.get(self.mesh, TriMesh)
        uv = self.uvs(m)
        uv = uv[m.faces].mean(axis=1) if uv.ndim == 2 else uv.mean(axis=1)
        v, _, name = self.image(state)
        m.add_field(self.field, sample_bilinear(v, uv), at="face", units=self.units, doc=f"from {name}")
        return True
