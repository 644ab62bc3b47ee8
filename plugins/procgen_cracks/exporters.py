"""Exporters of cracked surfaces: textured OBJ/GLB/PNG with the lower layer showing through the
cracks, and crack polylines with their widths as SVG (3DSCA thesis 5.2.5, plates 5.4, 5.8-5.11).

The meshes serialise what ``cracks.bake`` baked per micro-cell (procgen_cracks.bake) and, when a
recipe packed it, the one atlas of ``surface.bake``; a recipe without ``cracks.bake`` gets the
same maps baked for the export from the options below.  Geometry and the OBJ/GLB writing are
procgen_surface's (``build_export``).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from procgen import Exporter, InputError, Polylines
from procgen.exchange import UpAxis
from procgen.exchange.svg import box_decimals, finish, fmt_number, new_drawing, paths_data

from .bake import LIFT, LIGHT, _check, crack_maps, texel_colors  # noqa: F401  (texel_colors: API)


def _build(sc: Any, *, cells_per_segment: float, exaggerate: float, max_triangles: int,
           lift_scale: float, **texels: Any):
    """Mesh and atlas; the lifted paint also raised as geometry (``lift_scale`` times peel__lift,
    its rim already in the texels)."""
    from procgen_surface.exporters import build_export
    baked = None if "bake__texels" in sc else crack_maps(sc, **texels)
    return build_export(sc, cells_per_segment=cells_per_segment, exaggerate=exaggerate,
                        max_triangles=max_triangles, relief=LIFT if LIFT in sc else "",
                        relief_scale=lift_scale, relief_rim=0.0, fmt="crack export", baked=baked)


def crack_obj(domain: Any, *, stem: str, provenance: dict | None = None, layer: int = -1,
              shadow: float = 0.7, highlight: float = 0.6, cells_per_segment: float = 4.0,
              exaggerate: float = 0.02, max_triangles: int = 1_500_000,
              light: tuple[float, ...] = LIGHT, lift_relief: float = 1.0, lift_rim: float = 0.5,
              lift_scale: float = 1.0, normal_convention: str = "opengl") -> dict[str, bytes]:
    """OBJ + MTL + PNG maps (one texel per micro-cell): the lower layer shows through cracks;
    ORM, normal (``normal_convention`` opengl or directx) and 16-bit height maps beside."""
    from procgen_surface.export_mesh import obj_files
    sc = _check(domain, "crack_obj")
    if normal_convention not in ("opengl", "directx"):
        raise InputError(f"crack_obj: normal_convention must be opengl or directx, got {normal_convention!r}")
    mesh, atlas = _build(sc, layer=layer, shadow=shadow, highlight=highlight,
                         cells_per_segment=cells_per_segment, exaggerate=exaggerate,
                         max_triangles=max_triangles, light=light, lift_relief=lift_relief,
                         lift_rim=lift_rim, lift_scale=lift_scale)
    return obj_files(mesh, atlas, name=stem.rsplit("/", 1)[-1], provenance=provenance,
                     directx=normal_convention == "directx")


def crack_glb(domain: Any, *, stem: str = "", provenance: dict | None = None, layer: int = -1,
              shadow: float = 0.7, highlight: float = 0.6, cells_per_segment: float = 4.0,
              exaggerate: float = 0.02, max_triangles: int = 1_500_000,
              light: tuple[float, ...] = LIGHT, lift_relief: float = 1.0, lift_rim: float = 0.5,
              lift_scale: float = 1.0, up: UpAxis = "z") -> bytes:
    """Binary glTF of the same textured mesh (glTF metallic-roughness: colour, ORM, normal maps);
    ``up`` is the model's up axis (as for ``crack_png``), turned to glTF's +Y."""
    from procgen_surface.export_mesh import glb_bytes
    sc = _check(domain, "crack_glb")
    mesh, atlas = _build(sc, layer=layer, shadow=shadow, highlight=highlight,
                         cells_per_segment=cells_per_segment, exaggerate=exaggerate,
                         max_triangles=max_triangles, light=light, lift_relief=lift_relief,
                         lift_rim=lift_rim, lift_scale=lift_scale)
    return glb_bytes(mesh, atlas, provenance, up=up)


def crack_png(domain: Any, *, stem: str = "", provenance: dict | None = None, layer: int = -1,
              shadow: float = 0.7, highlight: float = 0.6, width: int = 640, height: int = 480,
              azimuth: float = 35.0, elevation: float = 25.0, up: UpAxis = "z", lit: bool = True,
              cells_per_segment: float = 4.0, exaggerate: float = 0.02,
              max_triangles: int = 400_000, light: tuple[float, ...] = LIGHT,
              lift_relief: float = 1.0, lift_rim: float = 0.5, lift_scale: float = 1.0) -> bytes:
    """Fixed-camera preview of the textured mesh, the texture sampled per pixel (micro-cells)."""
    from procgen.exchange.glb import mesh_for_export
    from procgen.exchange.preview import ArrayTexture, render_mesh_png
    from procgen_surface.export_mesh import as_trimesh
    sc = _check(domain, "crack_png")
    if up not in ("x", "y", "z"):
        raise InputError(f"crack_png: up must be x, y or z, got {up!r}")
    mesh, atlas = _build(sc, layer=layer, shadow=shadow, highlight=highlight,
                         cells_per_segment=cells_per_segment, exaggerate=exaggerate,
                         max_triangles=max_triangles, light=light, lift_relief=lift_relief,
                         lift_rim=lift_rim, lift_scale=lift_scale)
    tm = mesh_for_export(as_trimesh(mesh, atlas), uv_field="surface__uv",        # the atlas sampled
                         texture_field="surface__texture", image=ArrayTexture)   # as is, not via Pillow
    return render_mesh_png(tm, (width, height), azimuth=azimuth, elevation=elevation, up=up, lit=lit,
                           provenance=provenance)


def crack_svg(domain: Any, *, stem: str = "", provenance: dict | None = None, width: int = 1000,
              color: str = "#1a1a1a", outline: str = "#9a9a9a", background: str | None = "#ffffff",
              title: str = "") -> bytes:
    """Crack sheet (``cracks.sheet``) as SVG: one path per crack segment, stroke width = crack
    width (the mean of its two ends, in model units, round caps), panel outlines as hairlines."""
    if not isinstance(domain, Polylines) or "crack__width" not in domain or "crack__layer" not in domain:
        raise InputError("crack_svg: expected the Polylines sheet of cracks.sheet "
                         "(point field crack__width, line field crack__layer)")
    pts = np.asarray(domain.points, float)
    if len(pts) == 0:
        raise InputError("crack_svg: the sheet is empty")
    x0, y0 = pts.min(axis=0)
    x1, y1 = pts.max(axis=0)
    pad = 0.03 * max(x1 - x0, y1 - y0, 1e-9)
    bounds = (x0 - pad, x1 + pad, y0 - pad, y1 + pad)
    dwg, group, px = new_drawing(bounds, width, background)
    w = np.asarray(domain["crack__width"], float)
    layer = np.asarray(domain["crack__layer"])
    hair = fmt_number(max(px, 1e-9))
    pieces: list[tuple[np.ndarray, bool, dict]] = []   # one SVG element per line/segment: text output
    for i in range(domain.n_lines):
        s, e = domain.offsets[i], domain.offsets[i + 1]
        if layer[i] < 0:
            pieces.append((pts[s:e], bool(domain.closed[i]), dict(stroke=outline, stroke_width=hair,
                                                                   stroke_linejoin="round")))
            continue
        for j in range(s, e - 1):
            sw = 0.5 * (w[j] + w[j + 1])
            pieces.append((pts[j:j + 2], False,
                           dict(stroke=color, stroke_width=fmt_number(sw), stroke_linecap="round")))
    ds = paths_data([p for p, _, _ in pieces], [c for _, c, _ in pieces], box_decimals(bounds))
    for d, (_, _, style) in zip(ds, pieces):
        group.add(dwg.path(d=d, fill="none", **style))
    return finish(dwg, provenance, title)


EXPORTERS = [
    Exporter(name="crack_obj", kinds=("SurfaceCells",), suffix=".obj", func=crack_obj,
             doc="OBJ + MTL + PNG atlas of cracked cells (micro-cell texels, lower layer in the cracks)"),
    Exporter(name="crack_glb", kinds=("SurfaceCells",), suffix=".glb", func=crack_glb,
             doc="GLB of cracked cells (micro-cell texture, lower layer in the cracks)"),
    Exporter(name="crack_png", kinds=("SurfaceCells",), suffix=".png", func=crack_png,
             doc="fixed-camera preview PNG of the cracked, textured cells"),
    Exporter(name="crack_svg", kinds=("Polylines",), suffix=".svg", func=crack_svg,
             doc="crack sheet as SVG: one path per crack segment with its width as stroke width"),
]
