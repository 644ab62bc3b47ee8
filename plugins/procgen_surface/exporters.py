"""Exporters of the surface family: textured displaced OBJ/GLB, preview PNG, coverage plot."""
from __future__ import annotations

import io
from dataclasses import replace
from typing import Any

import numpy as np

from procgen import Exporter, FieldName, InputError, Polylines
from procgen.lighting import light_direction

from procgen_layers.rules import cell_stack_colors
from procgen_layers.stack import has_stack

from .domain import SurfaceCells
from .relief import check_relief_options, relief_shading, relief_values
from .shading import label_colors
from .export_mesh import (DisplacedMesh, displaced_mesh, glb_bytes, obj_files, pack_atlas,
                          subdivision_level)
from procgen.exchange.preview import camera_basis


def cell_colors(sc: SurfaceCells, color_by: str, *, lit: bool, light: np.ndarray,
                eye: np.ndarray) -> np.ndarray:
    """Per-cell colours by what the exporters are asked to show (labels, cells, state, layers)."""
    if color_by == "voronoi":
        return label_colors(np.asarray(sc["voronoi__label"]))
    if color_by == "cells":
        # checkerboard of the per-triangle grids; PART-IN cells darker, triangles tinted
        checker = (sc.ij.sum(axis=1) + sc.face) % 2
        base = label_colors(sc.face % 12 + 1, seed=3)
        rgb = base * np.where(checker, 1.0, 0.75)[:, None]
        return rgb * np.where(sc.comp_in, 1.0, 0.55)[:, None]
    if color_by == "status":
        pal = np.array([[0.80, 0.45, 0.25], [0.30, 0.68, 0.52], [0.05, 0.05, 0.05]])
        return pal[np.asarray(sc["corrosion__state"])]
    return cell_stack_colors(sc, lit=lit, light=light, eye=eye)


def _check(domain: Any, fmt: str) -> SurfaceCells:
    if not isinstance(domain, SurfaceCells):
        raise InputError(f"{fmt}: expected a SurfaceCells domain, got {domain.kind}")
    return domain


def _heights(sc: SurfaceCells, exaggerate: float, relief: np.ndarray | None = None,
             relief_scale: float = 1.0) -> np.ndarray:
    """Displacement per cell: ``exaggerate`` times the stacked thickness, plus the relief."""
    h = np.zeros(sc.n_cells)
    if "layers__thickness" in sc:
        h = exaggerate * np.asarray(sc["layers__thickness"], float).sum(axis=1)
    return h if relief is None else h + relief_scale * relief


def _colors(sc: SurfaceCells, field: str) -> np.ndarray:
    """Colours per cell: a field name (n, 3), or 'voronoi' / 'status' / 'cells' / 'layers'."""
    if field in ("voronoi", "status", "cells"):
        return cell_colors(sc, field, lit=False, light=np.zeros(3), eye=np.zeros(3))
    if field == "layers":
        return cell_colors(sc, "layers", lit=False, light=np.zeros(3), eye=np.zeros(3))
    if field in sc:
        rgb = np.asarray(sc[field], float)
        if rgb.shape != (sc.n_cells, 3):
            raise InputError(f"surface export: field {field!r} must be (n_cells, 3), got {rgb.shape}")
        return np.clip(rgb, 0, 1)
    if field != "surface__color":
        raise InputError(f"surface export: no field {field!r} (and not one of voronoi, status, "
                         "cells, layers)")
    if has_stack(sc):
        return cell_colors(sc, "layers", lit=False, light=np.zeros(3), eye=np.zeros(3))
    return np.full((sc.n_cells, 3), 0.7)


def build_export(sc: SurfaceCells, *, color_by: str = "surface__color", texels: int = 2,
                 cells_per_segment: float = 4.0, exaggerate: float = 0.02,
                 max_triangles: int = 1_500_000, textured: bool = True,
                 texel_rgb: np.ndarray | None = None, relief: str = "",
                 relief_scale: float = 1.0, relief_rim: float = 0.5, fmt: str = "surface export"):
    """(DisplacedMesh, Atlas | None) of a SurfaceCells domain.

    ``texel_rgb`` (n, t, t, 3): per-texel colours painted into the atlas instead of the cells'
    flat colours (t texels per cell side), e.g. the crack family's micro-cells.  ``relief``: a
    cell field (length) moving each cell's surface along its normal by ``relief_scale`` times
    the field, with the rim beside raised cells baked into the colours (procgen_surface.relief).
    """
    if texels < 1 or texels > 16:
        raise InputError(f"{fmt}: texels must be in 1..16, got {texels}")
    if cells_per_segment <= 0:
        raise InputError(f"{fmt}: cells_per_segment must be > 0")
    check_relief_options(fmt, relief_scale, relief_rim)
    lift = relief_values(sc, relief, fmt)
    rgb = _colors(sc, color_by)
    rim = relief_shading(sc, lift, light=None, slope=0.0, rim=relief_rim)
    if rim is not None:
        rgb = rgb * rim[:, None]
        if texel_rgb is not None:
            texel_rgb = texel_rgb * rim[:, None, None, None]
    alive = sc.alive()
    if texel_rgb is not None:
        atlas = pack_atlas(sc, texel_rgb, alive, texels=texel_rgb.shape[1])
    else:
        atlas = pack_atlas(sc, rgb, alive, texels=texels) if textured else None
    level = subdivision_level(sc, cells_per_segment, max_triangles)
    mesh = displaced_mesh(sc, _heights(sc, exaggerate, lift, relief_scale), rgb, alive, atlas,
                          level=level)
    return mesh, atlas


def surface_obj(domain: Any, *, stem: str, provenance: dict | None = None,
                color_by: str = "surface__color", texels: int = 2, cells_per_segment: float = 4.0,
                exaggerate: float = 0.02, vertex_colors: bool = False,
                textured: bool = True, max_triangles: int = 1_500_000, relief: FieldName = "",
                relief_scale: float = 1.0, relief_rim: float = 0.5) -> dict[str, bytes]:
    """OBJ + MTL + PNG atlas of the cells, displaced by the stacked layer thickness (and a
    ``relief`` cell field, see procgen_surface.relief)."""
    sc = _check(domain, "surface_obj")
    mesh, atlas = build_export(sc, color_by=color_by, texels=texels, cells_per_segment=cells_per_segment,
                               exaggerate=exaggerate, max_triangles=max_triangles, textured=textured,
                               relief=relief, relief_scale=relief_scale, relief_rim=relief_rim,
                               fmt="surface_obj")
    name = stem.rsplit("/", 1)[-1]
    return obj_files(mesh, atlas, name=name, provenance=provenance, vertex_colors=vertex_colors)


def surface_glb(domain: Any, *, stem: str = "", provenance: dict | None = None,
                color_by: str = "surface__color", texels: int = 2, cells_per_segment: float = 4.0,
                exaggerate: float = 0.02, textured: bool = True,
                max_triangles: int = 1_500_000, relief: FieldName = "", relief_scale: float = 1.0,
                relief_rim: float = 0.5) -> bytes:
    """Binary glTF of the same displaced, textured mesh (vertex colours if not textured)."""
    sc = _check(domain, "surface_glb")
    mesh, atlas = build_export(sc, color_by=color_by, texels=texels, cells_per_segment=cells_per_segment,
                               exaggerate=exaggerate, max_triangles=max_triangles, textured=textured,
                               relief=relief, relief_scale=relief_scale, relief_rim=relief_rim,
                               fmt="surface_glb")
    return glb_bytes(mesh, atlas, provenance)


def surface_png(domain: Any, *, stem: str = "", provenance: dict | None = None,
                color_by: str = "layers", width: int = 640, height: int = 480,
                azimuth: float = 35.0, elevation: float = 25.0, up: str = "z",
                light_azimuth: float | None = None, light_elevation: float = 50.0,
                cells_per_segment: float = 4.0, exaggerate: float = 0.02,
                max_triangles: int = 400_000, background: list[int] | None = None,
                antialias: int = 1, relight: bool = True, relief: FieldName = "",
                relief_scale: float = 1.0, relief_rim: float = 0.5, relief_slope: float = 1.0) -> bytes:
    """Preview PNG from a fixed camera, coloured per pixel by the cell under it.

    ``color_by='layers'`` is the thesis rendering: Phong per layer (eye = the camera) then light
    through the layers, per cell; holes cut out.  ``voronoi``/``status``/``cells``/a field name:
    flat cell colours with two-sided Lambert shading of the (displaced) facets, or as they are
    with ``relight = false`` (a field already lit, e.g. by ``layers.shade`` with its own lights).
    ``antialias = k``: the thesis's fake anti-aliasing (App. B 3, plate B.1): k x k renders with
    the camera moved by less than one pixel (so no point leaves its pixel, no blur) averaged,
    which softens the staircase of the cell borders.  ``relief``: a cell field (length) raising
    the cells along their normals (``relief_scale`` times it), drawn with the slope shading
    towards the preview's light (``relief_slope`` exaggerates) and the dark rim beside raised
    cells (``relief_rim``), as procgen_surface.relief describes.
    """
    from procgen.exchange.preview import encode_image, project

    sc = _check(domain, "surface_png")
    if up not in ("x", "y", "z"):
        raise InputError(f"surface_png: up must be x, y or z, got {up!r}")
    if not 1 <= int(antialias) <= 8:
        raise InputError(f"surface_png: antialias must be 1..8 (renders per axis), got {antialias!r}")
    check_relief_options("surface_png", relief_scale, relief_rim, relief_slope)
    lift = relief_values(sc, relief, "surface_png")
    eye, right, sup = camera_basis(azimuth, elevation, up)
    if color_by == "layers":
        if light_azimuth is None:
            light = 0.5 * right + 0.6 * sup + 0.6 * eye
            light /= np.linalg.norm(light)
        else:
            light = light_direction(light_azimuth, light_elevation)
        rgb = cell_colors(sc, "layers", lit=True, light=light, eye=eye)
        lambert = None
    else:
        rgb = _colors(sc, color_by)
        light = 0.45 * right + 0.6 * sup + 0.66 * eye
        light /= np.linalg.norm(light)
        lambert = light if relight else None
    shade = relief_shading(sc, lift, light=light, slope=relief_slope, rim=relief_rim)
    if shade is not None:
        rgb = rgb * shade[:, None]
    alive = sc.alive()
    if not alive.all():             # holes: triangles about one cell wide, so the far side shows
        cells_per_segment = min(cells_per_segment, 1.0)
    level = subdivision_level(sc, cells_per_segment, max_triangles)
    mesh: DisplacedMesh = displaced_mesh(sc, _heights(sc, exaggerate, lift, relief_scale), rgb,
                                         alive, None, level=level)
    proj = project(mesh.vertices, (width, height), azimuth=azimuth, elevation=elevation, up=up)
    bg = tuple(int(c) for c in (background or (255, 255, 255)))
    k = int(antialias)
    ss = proj.width / width                                  # supersampled pixels per pixel
    shifts = ((np.arange(k) + 0.5) / k - 0.5) * ss if k > 1 else np.zeros(1)
    img = sum(_render_pass(sc, mesh, replace(proj, px=proj.px + dx, py=proj.py + dy), rgb, alive, lambert, bg)
              for dx in shifts for dy in shifts)             # k^2 renders (k <= 8)
    return encode_image(img / len(shifts) ** 2, (width, height))


def _render_pass(sc: SurfaceCells, mesh: DisplacedMesh, proj: Any, rgb: np.ndarray, alive: np.ndarray,
                 lambert: np.ndarray | None, bg: tuple[int, int, int]) -> np.ndarray:
    """(H, W, 3) image of one camera position: each pixel the colour of the cell under it."""
    from .export_mesh import cell_under
    from procgen.exchange.preview import composite, face_id_buffer, pixel_barycentric

    ids = face_id_buffer(proj, mesh.faces)
    rows, cols, tri, bc = pixel_barycentric(proj, mesh.faces, ids)
    xy = np.einsum("nk,nkd->nd", bc, mesh.corner_xy[tri])
    cell = cell_under(sc, mesh.face_src[tri], xy)
    cell = np.where(cell >= 0, cell, mesh.face_cell[tri])
    pix = rgb[cell]
    hole = ~alive[cell]
    if lambert is not None:          # two-sided Lambert with the cell's rounded normal
        pix = pix * (0.35 + 0.65 * np.abs(sc.normal[cell] @ lambert))[:, None]
    ids[rows[hole], cols[hole]] = -1
    return composite(np.clip(pix[~hole], 0, 1), ids, bg)


def coverage_png(domain: Any, *, stem: str = "", provenance: dict | None = None,
                 title: str = "coverage", width: float = 6.0, height: float = 3.6) -> bytes:
    """Plot of a coverage log (line 0: cumulative %, line 1: % changed per step)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    if not isinstance(domain, Polylines) or domain.n_lines < 1:
        raise InputError("coverage_png: expected the Polylines coverage log of a surface rule")
    fig, ax = plt.subplots(figsize=(width, height), dpi=100)
    cum = domain.line(0)
    ax.plot(cum[:, 0], cum[:, 1], color="#1f6f4a", lw=2, label="cells changed (cumulative %)")
    ax.set_xlabel("step")
    ax.set_ylabel("% of cells")
    ax.set_ylim(0, 102)
    ax.grid(alpha=0.3)
    if domain.n_lines > 1:
        per = domain.line(1)
        ax2 = ax.twinx()
        ax2.plot(per[:, 0], per[:, 1], color="#b5651d", lw=1, alpha=0.8, label="changed this step (%)")
        ax2.set_ylabel("% changed per step", color="#b5651d")
    ax.set_title(title)
    ax.legend(loc="lower right", fontsize=8)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()


EXPORTERS = [
    Exporter(name="surface_obj", kinds=("SurfaceCells",), suffix=".obj", func=surface_obj,
             doc="OBJ + MTL + PNG atlas of 3DSCA cells, displaced by layer thickness"),
    Exporter(name="surface_glb", kinds=("SurfaceCells",), suffix=".glb", func=surface_glb,
             doc="GLB (trimesh) of 3DSCA cells, displaced and textured"),
    Exporter(name="surface_png", kinds=("SurfaceCells",), suffix=".png", func=surface_png,
             doc="fixed-camera preview PNG of 3DSCA cells (Phong through layers)"),
    Exporter(name="coverage_png", kinds=("Polylines",), suffix=".png", func=coverage_png,
             doc="coverage curve plot of a surface CA run (thesis Figs 4.4 / 4.9)"),
]
