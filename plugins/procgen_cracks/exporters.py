"""Exporters of cracked surfaces: textured OBJ/GLB/PNG with the lower layer showing through the
cracks, and crack polylines with their widths as SVG (3DSCA thesis 5.2.5, plates 5.4, 5.8-5.11).

The texture atlas holds one texel per micro-cell.  Each texel blends the cell's colour through
its whole stack with the colour through the layers *under* the cracked one, by the micro-cell's
crack coverage; the crack-mirror shadow and highlight bands change the lower layer's colour,
seen through the glaze with that layer's share of the light (procgen_layers.light, App. B 1.2).
Geometry, atlas packing and the OBJ/GLB writing are procgen_surface's (``build_export``).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from procgen import Exporter, InputError, Polylines
from procgen.exchange.svg import finish, fmt_number, new_drawing, path_data

from procgen_layers.light import layer_weights, through_layers
from procgen_layers.stack import load_table

from procgen_surface.relief import relief_shading

THICKNESS = "layers__thickness"
#: the partial-peeling elevation of cracks.peel (thesis 5.3.3, Figure 5.30), drawn as relief
LIFT = "peel__lift"
#: default direction towards the light for the baked lift shading (above, front left)
LIGHT = (-0.4, -0.5, 0.77)


def _surface(domain: Any, fmt: str):
    from procgen_surface.domain import SurfaceCells

    if not isinstance(domain, SurfaceCells):
        raise InputError(f"{fmt}: expected a SurfaceCells domain, got {domain.kind}")
    if "crack__coverage" not in domain:
        raise InputError(f"{fmt}: the cells have no crack__coverage (run cracks.render first)")
    return domain


def texel_colors(sc: Any, *, layer: int = -1, shadow: float = 0.7, highlight: float = 0.6,
                 light: tuple[float, ...] = LIGHT, lift_relief: float = 1.0,
                 lift_rim: float = 0.5) -> np.ndarray:
    """(n, k, k, 3) albedo of every micro-cell: stack colour, cracks opening on the layers below.

    ``shadow`` / ``highlight``: how much a full crack-mirror band darkens / lightens the layer
    under the cracked one (before the glaze above it filters the change).  Cells lifted by partial
    peeling (``peel__lift``, thesis Figure 5.30) are shaded as a relief (procgen_surface.relief:
    ``light`` towards the light, ``lift_relief`` slope exaggeration, ``lift_rim`` darkest rim),
    since the texture is baked once for every view.
    """
    lv = np.asarray(light, float)
    if lv.shape != (3,) or not np.linalg.norm(lv) > 0 or lift_relief < 0 or not 0.0 <= lift_rim <= 1.0:
        raise InputError(f"crack export: need a non-zero 3-vector light (towards the light), "
                         f"lift_relief >= 0 and lift_rim in [0, 1]; got {light}, {lift_relief}, {lift_rim}")
    lift = np.asarray(sc[LIFT], float) if LIFT in sc else None
    lit = relief_shading(sc, lift, light=lv, slope=lift_relief, rim=lift_rim)
    table = load_table(sc, "crack export")
    t = np.asarray(sc[THICKNESS], float)
    n_layers = t.shape[1]
    if not -n_layers <= layer < n_layers:
        raise InputError(f"crack export: layer {layer} is not a layer of the {n_layers}-layer stack")
    layer %= n_layers
    col = table.array("color")                                   # (L, 3) bottom first
    opac = table.array("opacity")
    lc = np.broadcast_to(col[::-1], t.shape + (3,))              # top first
    full = through_layers(lc, t[:, ::-1], opac[::-1])
    t_under = t.copy()
    t_under[:, layer:] = 0.0
    under = through_layers(lc, t_under[:, ::-1], opac[::-1], empty=col[0] * 0.15)
    cov = np.asarray(sc["crack__coverage"], np.float32)
    k = cov.shape[1]
    rgb = np.broadcast_to(full[:, None, None, :], cov.shape + (3,)).copy()
    if layer > 0 and "crack__shadow" in sc:
        sh = np.asarray(sc["crack__shadow"], np.float32)
        hl = np.asarray(sc["crack__highlight"], np.float32)
        if sh.shape != cov.shape or hl.shape != cov.shape:
            raise InputError(f"crack export: crack__shadow/highlight have {sh.shape[1]} micro-cells "
                             f"per side, crack__coverage {k}: render both with the same k")
        w_low = layer_weights(t[:, ::-1], opac[::-1])[:, n_layers - layer]      # the layer below
        low = col[layer - 1]
        delta = -shadow * sh[..., None] * low + highlight * hl[..., None] * (1.0 - low)
        rgb += w_low[:, None, None, None] * delta
    c = cov[..., None]
    rgb = (1.0 - c) * rgb + c * under[:, None, None, :]
    if lit is not None:
        rgb *= lit[:, None, None, None]
    return np.clip(rgb, 0.0, 1.0)


def _build(sc: Any, *, cells_per_segment: float, exaggerate: float, max_triangles: int,
           lift_scale: float, **texels: Any):
    """Mesh and atlas; the lifted paint also raised as geometry (``lift_scale`` times peel__lift,
    its rim already in the texels)."""
    from procgen_surface.exporters import build_export

    rgb = texel_colors(sc, **texels)
    return build_export(sc, color_by="layers", cells_per_segment=cells_per_segment,
                        exaggerate=exaggerate, max_triangles=max_triangles, texel_rgb=rgb,
                        relief=LIFT if LIFT in sc else "", relief_scale=lift_scale, relief_rim=0.0,
                        fmt="crack export")


def crack_obj(domain: Any, *, stem: str, provenance: dict | None = None, layer: int = -1,
              shadow: float = 0.7, highlight: float = 0.6, cells_per_segment: float = 4.0,
              exaggerate: float = 0.02, max_triangles: int = 1_500_000,
              light: tuple[float, ...] = LIGHT, lift_relief: float = 1.0, lift_rim: float = 0.5,
              lift_scale: float = 1.0) -> dict[str, bytes]:
    """OBJ + MTL + PNG atlas (one texel per micro-cell): the lower layer shows through cracks."""
    from procgen_surface.export_mesh import obj_files

    sc = _surface(domain, "crack_obj")
    mesh, atlas = _build(sc, layer=layer, shadow=shadow, highlight=highlight,
                         cells_per_segment=cells_per_segment, exaggerate=exaggerate,
                         max_triangles=max_triangles, light=light, lift_relief=lift_relief,
                         lift_rim=lift_rim, lift_scale=lift_scale)
    return obj_files(mesh, atlas, name=stem.rsplit("/", 1)[-1], provenance=provenance)


def crack_glb(domain: Any, *, stem: str = "", provenance: dict | None = None, layer: int = -1,
              shadow: float = 0.7, highlight: float = 0.6, cells_per_segment: float = 4.0,
              exaggerate: float = 0.02, max_triangles: int = 1_500_000,
              light: tuple[float, ...] = LIGHT, lift_relief: float = 1.0, lift_rim: float = 0.5,
              lift_scale: float = 1.0) -> bytes:
    """Binary glTF of the same textured mesh."""
    from procgen_surface.export_mesh import glb_bytes

    sc = _surface(domain, "crack_glb")
    mesh, atlas = _build(sc, layer=layer, shadow=shadow, highlight=highlight,
                         cells_per_segment=cells_per_segment, exaggerate=exaggerate,
                         max_triangles=max_triangles, light=light, lift_relief=lift_relief,
                         lift_rim=lift_rim, lift_scale=lift_scale)
    return glb_bytes(mesh, atlas, provenance)


def crack_png(domain: Any, *, stem: str = "", provenance: dict | None = None, layer: int = -1,
              shadow: float = 0.7, highlight: float = 0.6, width: int = 640, height: int = 480,
              azimuth: float = 35.0, elevation: float = 25.0, up: str = "z", lit: bool = True,
              cells_per_segment: float = 4.0, exaggerate: float = 0.02,
              max_triangles: int = 400_000, light: tuple[float, ...] = LIGHT,
              lift_relief: float = 1.0, lift_rim: float = 0.5, lift_scale: float = 1.0) -> bytes:
    """Fixed-camera preview of the textured mesh, the texture sampled per pixel (micro-cells)."""
    from procgen.exchange.glb import mesh_for_export
    from procgen.exchange.preview import render_mesh_png
    from procgen_surface.export_mesh import as_trimesh

    sc = _surface(domain, "crack_png")
    if up not in ("x", "y", "z"):
        raise InputError(f"crack_png: up must be x, y or z, got {up!r}")
    mesh, atlas = _build(sc, layer=layer, shadow=shadow, highlight=highlight,
                         cells_per_segment=cells_per_segment, exaggerate=exaggerate,
                         max_triangles=max_triangles, light=light, lift_relief=lift_relief,
                         lift_rim=lift_rim, lift_scale=lift_scale)
    tm = mesh_for_export(as_trimesh(mesh, atlas), uv_field="surface__uv", texture_field="surface__texture")
    return render_mesh_png(tm, (width, height), azimuth=azimuth, elevation=elevation, up=up, lit=lit)


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
    dwg, group, px = new_drawing((x0 - pad, x1 + pad, y0 - pad, y1 + pad), width, background)
    w = np.asarray(domain["crack__width"], float)
    layer = np.asarray(domain["crack__layer"])
    hair = fmt_number(max(px, 1e-9))
    for i in range(domain.n_lines):                # one SVG element per line/segment: text output
        s, e = domain.offsets[i], domain.offsets[i + 1]
        if layer[i] < 0:
            group.add(dwg.path(d=path_data(pts[s:e], bool(domain.closed[i])), fill="none",
                               stroke=outline, stroke_width=hair, stroke_linejoin="round"))
            continue
        for j in range(s, e - 1):
            sw = 0.5 * (w[j] + w[j + 1])
            group.add(dwg.path(d=path_data(pts[j:j + 2], False), fill="none", stroke=color,
                               stroke_width=fmt_number(sw), stroke_linecap="round"))
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
