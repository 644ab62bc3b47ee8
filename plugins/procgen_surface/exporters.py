"""Exporters of the surface family: textured displaced OBJ/GLB, preview PNG, coverage plot.

They serialise fields and name no phenomenon: colours come from a cell field (``color_by``), the
baked base colour and PBR properties of bake rules (``bake__*``: ``layers.shade`` and every
layers rule for a stack, ``cracks.bake`` per micro-cell), the lit preview of a stack from its
baked Phong lobes (``shade__*``), and the packed maps from ``surface.bake`` (``atlas__*``) when
a recipe packed them once for every format (docs/fields.md, "Baked appearance").
"""
from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np

from procgen import Exporter, FieldName, InputError, Polylines
from procgen.exchange import UpAxis, png_bytes
from procgen.lighting import light_direction

from .domain import SurfaceCells
from .relief import check_relief_options, relief_shading, relief_values
from .shading import label_colors, lobe_colors
from .export_mesh import (Atlas, DisplacedMesh, displaced_mesh, glb_bytes, obj_files, pack_atlas,
                          subdivision_level)
from procgen.exchange.preview import camera_basis

#: ``color_by`` names that are not fields: the cells' own grid, the core CA's Voronoi labels,
#: a stack's baked colour
NAMED = ("cells", "voronoi", "layers")
DEFAULT = "surface__color"


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
    """Colours per cell: an (n, 3) field, an integer label field (distinct colours), 'cells'
    (the per-triangle grids), 'voronoi' (the core ca.voronoi's ``voronoi__label``) or 'layers'
    (``bake__color``, a stack's unlit colour)."""
    if field == "cells":
        # checkerboard of the per-triangle grids; PART-IN cells darker, triangles tinted
        checker = (sc.ij.sum(axis=1) + sc.face) % 2
        base = label_colors(sc.face % 12 + 1, seed=3)
        rgb = base * np.where(checker, 1.0, 0.75)[:, None]
        return rgb * np.where(sc.comp_in, 1.0, 0.55)[:, None]
    name = {"voronoi": "voronoi__label", "layers": "bake__color"}.get(field, field)
    if name in sc:
        arr = np.asarray(sc[name])
        if arr.shape == (sc.n_cells,) and np.issubdtype(arr.dtype, np.integer):
            return label_colors(arr)
        if arr.shape != (sc.n_cells, 3):
            raise InputError(f"surface export: field {name!r} must be (n_cells, 3) colours or "
                             f"integer labels, got {arr.shape}")
        return np.clip(arr.astype(float), 0, 1)
    if field == DEFAULT:
        return np.clip(np.asarray(sc["bake__color"], float), 0, 1) if "bake__color" in sc \
            else np.full((sc.n_cells, 3), 0.7)
    raise InputError(f"surface export: no field {name!r} (color_by is a field or one of "
                     f"{', '.join(NAMED)})")


def _field(sc: SurfaceCells, *names: str, baked: dict[str, np.ndarray] | None = None) -> np.ndarray | None:
    """The first of ``names`` in ``baked`` (arrays a plugin baked for this export) or the cells."""
    for n in names:
        if baked and n in baked:
            return np.asarray(baked[n])
        if n in sc:
            return np.asarray(sc[n])
    return None


def stored_atlas(sc: SurfaceCells) -> Atlas | None:
    """The atlas ``surface.bake`` packed once for every output (None if no rule packed one)."""
    if "atlas__color" not in sc:
        return None
    k = int(np.asarray(sc["atlas__texels"]))
    height = _field(sc, "atlas__height")
    flat = height is None or not np.any(height)             # no relief: no height or normal map
    return Atlas(image=np.asarray(sc["atlas__color"]), origin=np.asarray(sc["atlas__origin"], np.int64),
                 texels=k, orm=_field(sc, "atlas__orm"), height=None if flat else height,
                 texel_size=float(sc.size) / k, normal=None if flat else _field(sc, "atlas__normal"))


def bake_atlas(sc: SurfaceCells, rgb: np.ndarray, *, texels: int, rim: np.ndarray | None = None,
               relief: np.ndarray | None = None, per_texel: bool = True,
               baked: dict[str, np.ndarray] | None = None, pbr: bool = False) -> Atlas:
    """Pack the cells' colours (or the baked micro-cell texels) and PBR fields into one atlas.

    ``per_texel``: use ``bake__texels`` / ``bake__texel_*`` when the cells carry them; ``rim``
    (n,) darkens colours beside raised cells; ``relief`` (n,) the height map, else the baked
    ``bake__texel_relief`` / ``bake__relief``.  ``baked``: such arrays given directly (they win
    over the cells' fields), e.g. a family's exporter baking on demand for a recipe that did not.
    ``pbr``: an ORM map even without baked metallic/roughness (the defaults: dielectric, 0.8).
    """
    texel_rgb = _field(sc, "bake__texels", baked=baked) if per_texel else None
    colour = rgb if texel_rgb is None else texel_rgb.astype(np.float32)
    if rim is not None:
        colour = colour * (rim[:, None] if colour.ndim == 2 else rim[:, None, None, None])
    tex = (lambda n: _field(sc, f"bake__texel_{n}", f"bake__{n}", baked=baked)) if texel_rgb is not None \
        else (lambda n: _field(sc, f"bake__{n}", baked=baked))
    height = tex("relief") if relief is None else relief
    if height is not None and not np.any(height):
        height = None                      # a flat relief: no height or normal map at all
    metallic, roughness = tex("metallic"), tex("roughness")
    if pbr and metallic is None:
        metallic = np.zeros(sc.n_cells)
    return pack_atlas(sc, np.clip(colour, 0, 1), sc.alive(),
                      texels=texels if texel_rgb is None else texel_rgb.shape[1],
                      metallic=metallic, roughness=roughness, relief=height)


def build_export(sc: SurfaceCells, *, color_by: str = DEFAULT, texels: int = 2,
                 cells_per_segment: float = 4.0, exaggerate: float = 0.02,
                 max_triangles: int = 1_500_000, textured: bool = True, relief: str = "",
                 relief_scale: float = 1.0, relief_rim: float = 0.5, fmt: str = "surface export",
                 baked: dict[str, np.ndarray] | None = None):
    """(DisplacedMesh, Atlas | None) of a SurfaceCells domain.

    The atlas is the one ``surface.bake`` stored when the colours are the default ones, else
    packed here (from ``baked`` arrays too, see :func:`bake_atlas`).  ``relief``: a cell field (length) moving each cell's surface along its normal
    by ``relief_scale`` times the field, with the rim beside raised cells baked into the colours
    (procgen_surface.relief) and the field as the height/normal map.
    """
    if texels < 1 or texels > 16:
        raise InputError(f"{fmt}: texels must be in 1..16, got {texels}")
    if cells_per_segment <= 0:
        raise InputError(f"{fmt}: cells_per_segment must be > 0")
    check_relief_options(fmt, relief_scale, relief_rim)
    lift = relief_values(sc, relief, fmt)
    rgb = _colors(sc, color_by)
    rim = relief_shading(sc, lift, light=None, slope=0.0, rim=relief_rim)
    atlas = None
    if textured:
        atlas = stored_atlas(sc) if color_by == DEFAULT and baked is None else None
        if atlas is None:
            per_texel = color_by == DEFAULT
            atlas = bake_atlas(sc, rgb, texels=texels, rim=rim, per_texel=per_texel, baked=baked,
                               relief=None if lift is None or (per_texel and _field(
                                   sc, "bake__texel_relief", baked=baked) is not None)
                               else relief_scale * lift)
    if rim is not None:
        rgb = rgb * rim[:, None]
    level = subdivision_level(sc, cells_per_segment, max_triangles)
    mesh = displaced_mesh(sc, _heights(sc, exaggerate, lift, relief_scale), rgb, sc.alive(), atlas,
                          level=level)
    return mesh, atlas


def surface_obj(domain: Any, *, stem: str, provenance: dict | None = None,
                color_by: str = "surface__color", texels: int = 2, cells_per_segment: float = 4.0,
                exaggerate: float = 0.02, vertex_colors: bool = False,
                textured: bool = True, max_triangles: int = 1_500_000, relief: FieldName = "",
                relief_scale: float = 1.0, relief_rim: float = 0.5, normal_strength: float = 1.0,
                normal_convention: str = "opengl") -> dict[str, bytes]:
    """OBJ + MTL + PNG maps of the cells, displaced by the stacked layer thickness (and a
    ``relief`` cell field, see procgen_surface.relief): base colour, and with baked PBR fields
    ORM / roughness / metallic, a normal map (``normal_convention`` opengl or directx, slopes
    times ``normal_strength``) and a 16-bit height map."""
    sc = _check(domain, "surface_obj")
    mesh, atlas = build_export(sc, color_by=color_by, texels=texels, cells_per_segment=cells_per_segment,
                               exaggerate=exaggerate, max_triangles=max_triangles, textured=textured,
                               relief=relief, relief_scale=relief_scale, relief_rim=relief_rim,
                               fmt="surface_obj")
    if normal_convention not in ("opengl", "directx"):
        raise InputError(f"surface_obj: normal_convention must be opengl or directx, got {normal_convention!r}")
    name = stem.rsplit("/", 1)[-1]
    return obj_files(mesh, atlas, name=name, provenance=provenance, vertex_colors=vertex_colors,
                     normal_strength=normal_strength, directx=normal_convention == "directx")


def surface_glb(domain: Any, *, stem: str = "", provenance: dict | None = None,
                color_by: str = "surface__color", texels: int = 2, cells_per_segment: float = 4.0,
                exaggerate: float = 0.02, textured: bool = True,
                max_triangles: int = 1_500_000, relief: FieldName = "", relief_scale: float = 1.0,
                relief_rim: float = 0.5, normal_strength: float = 1.0, up: UpAxis = "z") -> bytes:
    """Binary glTF of the same displaced mesh: a glTF 2.0 metallic-roughness material with the
    base colour, ORM and normal maps (vertex colours if not textured); ``up`` is the model's up
    axis (as for ``surface_png``), turned to glTF's +Y so the file stands upright in Blender."""
    sc = _check(domain, "surface_glb")
    mesh, atlas = build_export(sc, color_by=color_by, texels=texels, cells_per_segment=cells_per_segment,
                               exaggerate=exaggerate, max_triangles=max_triangles, textured=textured,
                               relief=relief, relief_scale=relief_scale, relief_rim=relief_rim,
                               fmt="surface_glb")
    return glb_bytes(mesh, atlas, provenance, normal_strength=normal_strength, up=up)


def surface_png(domain: Any, *, stem: str = "", provenance: dict | None = None,
                color_by: str = "layers", width: int = 640, height: int = 480,
                azimuth: float = 35.0, elevation: float = 25.0, up: UpAxis = "z",
                light_azimuth: float | None = None, light_elevation: float = 50.0,
                cells_per_segment: float = 4.0, exaggerate: float = 0.02,
                max_triangles: int = 400_000, background: list[int] | None = None,
                antialias: int = 1, relight: bool = True, relief: FieldName = "",
                relief_scale: float = 1.0, relief_rim: float = 0.5, relief_slope: float = 1.0) -> bytes:
    """Preview PNG from a fixed camera, coloured per pixel by the cell under it.

    ``color_by='layers'`` is the thesis rendering: Phong per layer (eye = the camera) then light
    through the layers, per cell, from the lobes the stack baked (``shade__*``, procgen_layers.bake;
    cells without them are drawn as the default colours); holes cut out.  ``voronoi``/``status``/``cells``/a field name:
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
    lobes = color_by == "layers" and "shade__ambient" in sc
    if lobes:
        if light_azimuth is None:
            light = 0.5 * right + 0.6 * sup + 0.6 * eye
            light /= np.linalg.norm(light)
        else:
            light = light_direction(light_azimuth, light_elevation)
        rgb = lobe_colors(sc, light=light, eye=eye)
        lambert = None
    else:           # flat colours (a 'layers' preview of cells no stack was baked on: the default)
        rgb = _colors(sc, DEFAULT if color_by == "layers" else color_by)
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
    return encode_image(img / len(shifts) ** 2, (width, height), provenance)


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
    fig.canvas.draw()
    rgb = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
    plt.close(fig)
    return png_bytes(rgb, provenance)


EXPORTERS = [
    Exporter(name="surface_obj", kinds=("SurfaceCells",), suffix=".obj", func=surface_obj,
             doc="OBJ + MTL + PNG maps (base colour, ORM, normal, 16-bit height) of 3DSCA cells"),
    Exporter(name="surface_glb", kinds=("SurfaceCells",), suffix=".glb", func=surface_glb,
             doc="GLB of 3DSCA cells: glTF metallic-roughness material with colour, ORM, normal maps"),
    Exporter(name="surface_png", kinds=("SurfaceCells",), suffix=".png", func=surface_png,
             doc="fixed-camera preview PNG of 3DSCA cells (Phong through layers)"),
    Exporter(name="coverage_png", kinds=("Polylines",), suffix=".png", func=coverage_png,
             doc="coverage curve plot of a surface CA run (thesis Figs 4.4 / 4.9)"),
]
