"""Cloud pictures: silhouette SVG, process figure, Figure 1.2 view, animations, cloudscape.

Exporters are pure: they take a Polylines domain made by the snaxel rules and return bytes.
SVG drawing, path text and provenance reuse the core's svg helpers (model y-up, viewBox = the
domain bounds).
"""
from __future__ import annotations

import colorsys
import io
from typing import Any, Sequence

import numpy as np

from procgen import InputError, Polylines
from procgen.builtin.lines import chaikin
from procgen.exchange.svg import fmt_number, finish, new_drawing, path_data, polylines_svg


def _need(domain: Any, what: str, field: str | None = None) -> Polylines:
    if not isinstance(domain, Polylines):
        raise InputError(f"{what}: expected the Polylines a snaxel rule made, got {domain.kind}")
    if field is not None and field not in domain:
        raise InputError(f"{what}: domain has no field {field!r} (export the snaxel.grow/cloudscape output)")
    return domain


def _box(domain: Polylines) -> tuple[float, float, float, float]:
    if domain.bounds is not None:
        return domain.bounds
    (x0, y0), (x1, y1) = domain.points.min(0), domain.points.max(0)
    return (float(x0), float(x1), float(y0), float(y1))


def curve_colour(cid: int) -> str:
    """A distinct, deterministic colour per curve id (golden-ratio hue walk)."""
    h = (int(cid) * 0.6180339887) % 1.0
    r, g, b = colorsys.hsv_to_rgb(h, 0.75, 0.85)
    return "#%02x%02x%02x" % (int(r * 255), int(g * 255), int(b * 255))


def _mix(a: str, b: str, t: float) -> str:
    ca = np.array([int(a[i:i + 2], 16) for i in (1, 3, 5)], float)
    cb = np.array([int(b[i:i + 2], 16) for i in (1, 3, 5)], float)
    c = np.clip(np.round((1 - t) * ca + t * cb), 0, 255).astype(int)
    return "#%02x%02x%02x" % tuple(c)


# -- the cloud itself ---------------------------------------------------------------------------
def cloud_svg(domain: Any, *, stem: str = "", provenance: dict | None = None, fill: str = "#ffffff",
              stroke: str | None = None, stroke_width: float = 1.0, gradient: Sequence[str] | None = None,
              smooth: int = 0, background: str | None = "#8fb8e0", width: int = 800, title: str = "",
              crop: bool = False) -> bytes:
    """The outline as one filled closed path; smoothing (Chaikin passes) is off by default
    because it softens the sharp detail the thesis claims over earlier systems. The viewBox is
    the domain, or the cloud's own box (plus 4%) with ``crop``."""
    dom = _need(domain, "cloud_svg")
    if not 0 <= int(smooth) <= 6:
        raise InputError(f"cloud_svg: smooth = {smooth} passes, expected 0..6")
    lines = [chaikin(dom.line(i), bool(dom.closed[i]), int(smooth)) for i in range(dom.n_lines)]
    out = Polylines.from_list(lines, closed=dom.closed, bounds=_crop_box(dom, 0.04) if crop else _box(dom))
    return polylines_svg(out, provenance=provenance, fill=fill, stroke=stroke, stroke_width=stroke_width,
                         gradient=gradient, background=background, width=width, margin=0.0,
                         title=title or "snaxel cloud")


# -- process figure (nested contours, one colour per curve) -------------------------------------
def _crop_box(dom: Polylines, pad: float) -> tuple[float, float, float, float]:
    """The lines' bounding box grown by ``pad`` of its size, kept inside the domain."""
    (x0, y0), (x1, y1) = dom.points.min(0), dom.points.max(0)
    size = max(x1 - x0, y1 - y0)
    bx0, bx1, by0, by1 = _box(dom)
    return (max(bx0, x0 - pad * size), min(bx1, x1 + pad * size), max(by0, y0 - pad * size), min(by1, y1 + pad * size))


def process_svg(domain: Any, *, stem: str = "", provenance: dict | None = None, width: int = 800,
                background: str | None = "#ffffff", fill: str | None = "#eef2f7", stroke_width: float = 0.9,
                crop: bool = True, title: str = "") -> bytes:
    """Earlier snake positions as nested contours, each curve in its own colour (Figs 3.11-3.22);
    ``crop`` frames the cloud instead of the whole domain."""
    dom = _need(domain, "cloud_process_svg", "snaxel__curve")
    dwg, group, px = new_drawing(_crop_box(dom, 0.04) if crop else _box(dom), width, background)
    curve = dom["snaxel__curve"]
    if fill and dom.n_lines:
        group.add(dwg.path(d=path_data(dom.line(dom.n_lines - 1), True), fill=fill, stroke="none"))
    sw = fmt_number(stroke_width * px)
    for i in range(dom.n_lines):
        a, b = dom.offsets[i], dom.offsets[i + 1]
        pts, cv = dom.points[a:b], curve[a:b]
        n = len(pts)
        if n < 2:
            continue
        starts = np.flatnonzero(cv != np.roll(cv, 1))
        if len(starts) == 0:
            starts = np.array([0])
        for k, s in enumerate(starts):
            e = starts[(k + 1) % len(starts)]
            idx = np.arange(s, (e if e > s else e + n) + 1) % n      # include the joint to the next curve
            group.add(dwg.path(d=path_data(pts[idx], False), fill="none", stroke=curve_colour(int(cv[s])),
                               stroke_width=sw, stroke_linejoin="round"))
    return finish(dwg, provenance, title or "snaxel growth process")


# -- Figure 1.2 ----------------------------------------------------------------------------------
def view_svg(domain: Any, *, stem: str = "", provenance: dict | None = None, width: int = 800,
             background: str | None = "#ffffff", title: str = "") -> bytes:
    """Tessellation (grey edges, blue vertices), snake segments red, snaxels yellow (Figure 1.2)."""
    dom = _need(domain, "cloud_view_svg", "view__kind")
    kind = dom["view__kind"]
    dwg, group, px = new_drawing(_box(dom), width, background)
    edges = [dom.line(i) for i in np.flatnonzero(kind == 0)]
    if edges:
        group.add(dwg.path(d=" ".join(path_data(e, False) for e in edges), fill="none",
                           stroke="#9aa4b4", stroke_width=fmt_number(1.2 * px)))
        verts = np.unique(np.round(np.vstack(edges), 9), axis=0)
        dots = dwg.g(fill="#2451c8")
        for x, y in verts:
            dots.add(dwg.circle(center=(fmt_number(x), fmt_number(y)), r=fmt_number(4.0 * px)))
        group.add(dots)
    for i in np.flatnonzero(kind == 1):
        snake = dom.line(i)
        group.add(dwg.path(d=path_data(snake, True), fill="none", stroke="#d42020",
                           stroke_width=fmt_number(2.5 * px), stroke_linejoin="round"))
        dots = dwg.g(fill="#ffd21f", stroke="#6a5500", stroke_width=fmt_number(0.8 * px))
        x0, x1, y0, y1 = _box(dom)
        inside = (snake[:, 0] > x0 - 1) & (snake[:, 0] < x1 + 1) & (snake[:, 1] > y0 - 1) & (snake[:, 1] < y1 + 1)
        for x, y in snake[inside]:
            dots.add(dwg.circle(center=(fmt_number(x), fmt_number(y)), r=fmt_number(5.0 * px)))
        group.add(dots)
    return finish(dwg, provenance, title or "snaxels on a tessellation")


# -- animations ----------------------------------------------------------------------------------
def anim_svg(domain: Any, *, stem: str = "", provenance: dict | None = None, width: int = 600,
             background: str | None = "#8fb8e0", fill: str = "#ffffff", frame_seconds: float = 0.12,
             hold_seconds: float = 1.5, crop: bool = True, title: str = "") -> bytes:
    """The growth as an animated SVG (SMIL, discrete frames); browsers play it in a loop."""
    dom = _need(domain, "cloud_anim_svg")
    n = dom.n_lines
    if n == 0:
        raise InputError("cloud_anim_svg: the history has no contour")
    dwg, group, px = new_drawing(_crop_box(dom, 0.06) if crop else _box(dom), width, background)
    total = n * frame_seconds + hold_seconds
    for i in range(n):
        t0 = i * frame_seconds / total
        t1 = ((i + 1) * frame_seconds if i < n - 1 else total) / total
        p = dwg.path(d=path_data(dom.line(i), True), fill=fill, visibility="hidden")
        keys = [0.0, t0, t1, 1.0] if t1 < 1.0 else [0.0, t0, 1.0]
        vals = ["hidden", "visible", "hidden", "hidden"] if t1 < 1.0 else ["hidden", "visible", "visible"]
        if t0 == 0.0:
            keys, vals = keys[1:], vals[1:]
        p.add(dwg.animate(attributeName="visibility", values=";".join(vals),
                          keyTimes=";".join(fmt_number(k) for k in keys), dur=f"{fmt_number(total)}s",
                          calcMode="discrete", repeatCount="indefinite"))
        group.add(p)
    return finish(dwg, provenance, title or "snaxel cloud growth")


def rasterise(lines: list[np.ndarray], box: tuple[float, float, float, float], width: int,
              background: str, fill: str, outline: str | None = None) -> Any:
    """Filled polygons on a PIL image (model y-up flipped to image rows)."""
    from PIL import Image, ImageDraw

    x0, x1, y0, y1 = box
    height = max(1, int(round(width * (y1 - y0) / (x1 - x0))))
    img = Image.new("RGB", (width, height), background)
    draw = ImageDraw.Draw(img)
    s = width / (x1 - x0)
    for pts in lines:
        if len(pts) >= 3:
            xy = [(float((x - x0) * s), float((y1 - y) * s)) for x, y in pts]
            draw.polygon(xy, fill=fill, outline=outline)
    return img


def anim_gif(domain: Any, *, stem: str = "", provenance: dict | None = None, width: int = 400,
             background: str = "#8fb8e0", fill: str = "#ffffff", frame_ms: int = 100, hold_ms: int = 1500,
             crop: bool = True) -> bytes:
    """The growth as a looping GIF, one frame per recorded contour (framed on the cloud)."""
    dom = _need(domain, "cloud_gif")
    if dom.n_lines == 0:
        raise InputError("cloud_gif: the history has no contour")
    box = _crop_box(dom, 0.06) if crop else _box(dom)
    frames = [rasterise([dom.line(i)], box, width, background, fill).quantize(colors=16, dither=0)
              for i in range(dom.n_lines)]
    buf = io.BytesIO()
    durations = [frame_ms] * (len(frames) - 1) + [hold_ms]
    frames[0].save(buf, format="GIF", save_all=True, append_images=frames[1:], duration=durations, loop=0)
    return buf.getvalue()


# -- cloudscape ----------------------------------------------------------------------------------
def _opened(pts: np.ndarray, r: float) -> list[np.ndarray]:
    """Morphological opening of the outline (shapely buffers): the shading layers follow the
    lobes, not the fine fringe, so shifting them does not streak."""
    from shapely.geometry import Polygon

    shape = Polygon(pts).buffer(-r, quad_segs=4).buffer(r, quad_segs=4)
    parts = getattr(shape, "geoms", [shape])
    return [np.asarray(p.exterior.coords)[:-1] for p in parts if not p.is_empty and p.area > 0]


def cloudscape_svg(domain: Any, *, stem: str = "", provenance: dict | None = None, width: int = 1000,
                   sky_top: str = "#3f78c0", sky_horizon: str = "#c9def2", lit: str = "#ffffff",
                   shade: str = "#aeb8c8", layers: int = 14, shift: float = 0.22, perspective: float = 0.35,
                   title: str = "") -> bytes:
    """Clouds composited back to front with layered shading.

    Each cloud is filled with its shade colour, then ``layers`` copies of its outline, shifted
    upwards by growing amounts and clipped to the cloud, are filled with lighter colours: points
    with much cloud below them (lobe tops) end up lit, lobe undersides stay in shade. Far
    clouds (low cloud__depth) are drawn smaller about their base (``perspective``) and mixed
    towards the horizon colour (aerial perspective). The outlines themselves are not changed.
    """
    dom = _need(domain, "cloudscape_svg", "cloud__depth")
    if not 1 <= int(layers) <= 40:
        raise InputError(f"cloudscape_svg: layers = {layers}, expected 1..40")
    box = _box(dom)
    x0, x1, y0, y1 = box
    dwg, group, px = new_drawing(box, width, None)
    sky = dwg.linearGradient(start=(0, 0), end=(0, 1), id="sky")
    sky.add_stop_color(0, sky_top)
    sky.add_stop_color(1, sky_horizon)
    dwg.defs.add(sky)
    group.add(dwg.rect(insert=(x0, y0), size=(x1 - x0, y1 - y0), fill="url(#sky)",
                       transform=f"translate(0,{fmt_number(y0 + y1)}) scale(1,-1)"))
    depth = dom["cloud__depth"]
    n = max(int(depth.max()) + 1, 1)
    for i in np.argsort(depth, kind="stable"):
        far = 1.0 - (float(depth[i]) / (n - 1) if n > 1 else 1.0)
        pts = dom.line(int(i))
        cx, by = float(pts[:, 0].mean()), float(pts[:, 1].min())
        sc = 1.0 - perspective * far
        dy = shift * (float(pts[:, 1].max()) - by) / layers      # total shift: a fraction of the height
        d = path_data(pts, True)
        clip = dwg.defs.add(dwg.clipPath(id=f"cloud{i}"))
        clip.add(dwg.path(d=d))
        top = _mix(lit, sky_horizon, 0.4 * far)
        bottom = _mix(shade, sky_horizon, 0.5 * far)
        outer = dwg.g(transform=f"translate({fmt_number(cx)},{fmt_number(by)}) scale({fmt_number(sc)}) translate({fmt_number(-cx)},{fmt_number(-by)})")
        g = dwg.g(clip_path=f"url(#cloud{i})")
        g.add(dwg.path(d=d, fill=bottom))
        soft = " ".join(path_data(ring, True) for ring in _opened(pts, 0.07 * (float(pts[:, 1].max()) - by)))
        for k in range(1, int(layers) + 1):
            g.add(dwg.path(d=soft, fill=_mix(bottom, top, (k / layers) ** 0.6),
                           transform=f"translate(0,{fmt_number(dy * k)})"))
        outer.add(g)
        group.add(outer)
    return finish(dwg, provenance, title or "snaxel cloudscape")


EXPORTERS: list[tuple[str, str, Any, str]] = [
    ("cloud_svg", ".svg", cloud_svg, "cloud outline as one filled closed SVG path (stroke, gradient, smooth)"),
    ("cloud_process_svg", ".svg", process_svg, "nested earlier contours, one colour per curve"),
    ("cloud_view_svg", ".svg", view_svg, "Figure 1.2: tessellation, snake segments and snaxels"),
    ("cloud_anim_svg", ".svg", anim_svg, "animated SVG of the growth (from {cloud}_history)"),
    ("cloud_gif", ".gif", anim_gif, "animated GIF of the growth (from {cloud}_history)"),
    ("cloudscape_svg", ".svg", cloudscape_svg, "several clouds back to front with layered shading"),
]
