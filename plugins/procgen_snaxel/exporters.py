"""Cloud pictures: silhouette SVG, process figure, Figure 1.2 view, animations, plotter pens.

Exporters are pure: they take a Polylines domain made by the snaxel rules and return bytes.
Pages are y-down with a viewBox from 0 0, real units and one Inkscape layer per group
(:mod:`.svgdoc`); path text and provenance come from the core's svg helpers.
"""
from __future__ import annotations

import colorsys
import io
from typing import Any, Sequence

import numpy as np

from procgen import InputError, Polylines
from procgen.builtin.lines import chaikin
from procgen.exchange.svg import finish, fmt_number, vertical_gradient

from .cloudscape_svg import cloudscape_svg
from .svgdoc import Page, curve_pieces, domain_box, need


def curve_colour(cid: int) -> str:
    """A distinct, deterministic colour per curve id (golden-ratio hue walk)."""
    h = (int(cid) * 0.6180339887) % 1.0
    r, g, b = colorsys.hsv_to_rgb(h, 0.75, 0.85)
    return "#%02x%02x%02x" % (int(r * 255), int(g * 255), int(b * 255))


# -- the cloud itself ---------------------------------------------------------------------------
def cloud_svg(domain: Any, *, stem: str = "", provenance: dict | None = None, fill: str = "#ffffff",
              stroke: str | None = None, stroke_width: float = 1.0, gradient: Sequence[str] | None = None,
              smooth: int = 0, background: str | None = "#8fb8e0", width: float = 800, units: str = "px",
              title: str = "", crop: bool = False) -> bytes:
    """The outline as one filled closed path on a "cloud" layer, over an optional "sky" layer.
    Smoothing (Chaikin passes) is off by default because it softens the sharp detail the thesis
    claims over earlier systems. The page is the domain, or the cloud's own box (plus 4%) with
    ``crop``; ``gradient`` lists colours from top to bottom."""
    dom = need(domain, "cloud_svg")
    if not 0 <= int(smooth) <= 6:
        raise InputError(f"cloud_svg: smooth = {smooth} passes, expected 0..6")
    page = Page(_crop_box(dom, 0.04) if crop else domain_box(dom), width, units)
    dwg = page.dwg
    page.sky(background)
    fill_ref = fill
    if gradient:
        if len(gradient) < 2:
            raise InputError("cloud_svg: gradient needs at least two colours (top, bottom)")
        fill_ref = vertical_gradient(dwg, gradient, "cloud-fill")
    layer = page.layer("cloud")
    for i in range(dom.n_lines):
        pts = chaikin(dom.line(i), bool(dom.closed[i]), int(smooth))
        kw: dict[str, Any] = {"d": page.d(pts, bool(dom.closed[i])), "fill": fill_ref}
        if stroke:
            kw.update(stroke=stroke, stroke_width=fmt_number(stroke_width * page.unit), stroke_linejoin="round")
        layer.add(dwg.path(**kw))
    return finish(dwg, provenance, title or "snaxel cloud")


# -- process figure (nested contours, one colour per curve) -------------------------------------
def _crop_box(dom: Polylines, pad: float) -> tuple[float, float, float, float]:
    """The lines' bounding box grown by ``pad`` of its size, kept inside the domain."""
    (x0, y0), (x1, y1) = dom.points.min(0), dom.points.max(0)
    size = max(x1 - x0, y1 - y0)
    bx0, bx1, by0, by1 = domain_box(dom)
    return (max(bx0, x0 - pad * size), min(bx1, x1 + pad * size), max(by0, y0 - pad * size), min(by1, y1 + pad * size))


def process_svg(domain: Any, *, stem: str = "", provenance: dict | None = None, width: float = 800,
                units: str = "px", background: str | None = "#ffffff", fill: str | None = "#eef2f7",
                stroke_width: float = 0.9, crop: bool = True, title: str = "") -> bytes:
    """Earlier snake positions as nested contours, each curve in its own colour (Figs 3.11-3.22),
    one layer per contour; ``crop`` frames the cloud instead of the whole domain."""
    dom = need(domain, "cloud_process_svg", "snaxel__curve")
    page = Page(_crop_box(dom, 0.04) if crop else domain_box(dom), width, units)
    dwg = page.dwg
    page.sky(background)
    curve = dom["snaxel__curve"]
    if fill and dom.n_lines:
        page.layer("silhouette").add(dwg.path(d=page.d(dom.line(dom.n_lines - 1)), fill=fill, stroke="none"))
    sw = fmt_number(stroke_width * page.unit)
    steps = dom["snapshot__step"] if "snapshot__step" in dom else np.arange(dom.n_lines)
    off = dom.offsets
    contours = [(i, curve_pieces(dom.points[off[i]:off[i + 1]], curve[off[i]:off[i + 1]]))
                for i in range(dom.n_lines) if off[i + 1] - off[i] >= 2]
    ds = iter(page.ds([piece for _, pieces in contours for _, piece in pieces], False))   # one formatting pass
    for i, pieces in contours:      # the shared style lives on the layer: a path carries its curve's colour only
        layer = page.layer(f"contour step {int(steps[i])}", fill="none", stroke_width=sw, stroke_linejoin="round")
        for cid, _ in pieces:
            layer.add(dwg.path(d=next(ds), stroke=curve_colour(cid)))
    return finish(dwg, provenance, title or "snaxel growth process")


# -- Figure 1.2 ----------------------------------------------------------------------------------
def view_svg(domain: Any, *, stem: str = "", provenance: dict | None = None, width: float = 800,
             units: str = "px", background: str | None = "#ffffff", title: str = "") -> bytes:
    """Tessellation (grey edges, blue vertices), snake segments red, snaxels yellow (Figure 1.2)."""
    dom = need(domain, "cloud_view_svg", "view__kind")
    kind = dom["view__kind"]
    box = domain_box(dom)
    page = Page(box, width, units)
    dwg, px = page.dwg, page.unit
    page.sky(background)
    edges = [dom.line(i) for i in np.flatnonzero(kind == 0)]
    if edges:
        tess = page.layer("tessellation")
        tess.add(dwg.path(d="".join(page.ds(edges, False)), fill="none",
                          stroke="#9aa4b4", stroke_width=fmt_number(1.2 * px)))
        verts = page.xy(np.unique(np.round(np.vstack(edges), 9), axis=0))
        dots = dwg.g(fill="#2451c8")
        for x, y in verts:
            dots.add(dwg.circle(center=(fmt_number(x, page.decimals), fmt_number(y, page.decimals)),
                                r=fmt_number(4.0 * px)))
        tess.add(dots)
    x0, x1, y0, y1 = box
    for i in np.flatnonzero(kind == 1):
        snake = dom.line(i)
        layer = page.layer("snake")
        layer.add(dwg.path(d=page.d(snake), fill="none", stroke="#d42020",
                           stroke_width=fmt_number(2.5 * px), stroke_linejoin="round"))
        dots = dwg.g(fill="#ffd21f", stroke="#6a5500", stroke_width=fmt_number(0.8 * px))
        inside = (snake[:, 0] > x0 - 1) & (snake[:, 0] < x1 + 1) & (snake[:, 1] > y0 - 1) & (snake[:, 1] < y1 + 1)
        for x, y in page.xy(snake[inside]):
            dots.add(dwg.circle(center=(fmt_number(x, page.decimals), fmt_number(y, page.decimals)),
                                r=fmt_number(5.0 * px)))
        layer.add(dots)
    return finish(dwg, provenance, title or "snaxels on a tessellation")


# -- animations ----------------------------------------------------------------------------------
def anim_svg(domain: Any, *, stem: str = "", provenance: dict | None = None, width: float = 600,
             units: str = "px", background: str | None = "#8fb8e0", fill: str = "#ffffff",
             frame_seconds: float = 0.12, hold_seconds: float = 1.5, crop: bool = True, title: str = "") -> bytes:
    """The growth as an animated SVG (SMIL, discrete frames); browsers play it in a loop."""
    dom = need(domain, "cloud_anim_svg")
    n = dom.n_lines
    if n == 0:
        raise InputError("cloud_anim_svg: the history has no contour")
    page = Page(_crop_box(dom, 0.06) if crop else domain_box(dom), width, units)
    dwg = page.dwg
    page.sky(background)
    group = page.layer("growth")
    total = n * frame_seconds + hold_seconds
    for i in range(n):
        t0 = i * frame_seconds / total
        t1 = ((i + 1) * frame_seconds if i < n - 1 else total) / total
        p = dwg.path(d=page.d(dom.line(i)), fill=fill, visibility="hidden")
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
    dom = need(domain, "cloud_gif")
    if dom.n_lines == 0:
        raise InputError("cloud_gif: the history has no contour")
    box = _crop_box(dom, 0.06) if crop else domain_box(dom)
    frames = [rasterise([dom.line(i)], box, width, background, fill).quantize(colors=16, dither=0)
              for i in range(dom.n_lines)]
    buf = io.BytesIO()
    durations = [frame_ms] * (len(frames) - 1) + [hold_ms]
    frames[0].save(buf, format="GIF", save_all=True, append_images=frames[1:], duration=durations, loop=0)
    return buf.getvalue()


# -- pen plotters ---------------------------------------------------------------------------------
def plot_order(lines: list[np.ndarray], closed: list[bool], start: np.ndarray) -> list[np.ndarray]:
    """Greedy nearest-neighbour path order from ``start``; a closed outline starts at its point
    nearest to the pen, an open line may be drawn backwards. Cuts pen-up travel (one numpy pass
    per line over the remaining lines' end points)."""
    todo = list(range(len(lines)))
    pen = np.asarray(start, float)
    out = []
    while todo:
        best, best_d, best_k, rev = -1, np.inf, 0, False
        for j in todo:
            p = lines[j]
            if closed[j]:
                dd = np.hypot(*(p - pen).T)
                k = int(np.argmin(dd))
                cand = (dd[k], k, False)
            else:
                d0, d1 = float(np.hypot(*(p[0] - pen))), float(np.hypot(*(p[-1] - pen)))
                cand = (d0, 0, False) if d0 <= d1 else (d1, 0, True)
            if cand[0] < best_d:
                best, (best_d, best_k, rev) = j, cand
        p = lines[best]
        if closed[best]:
            p = np.vstack([np.roll(p, -best_k, axis=0), p[best_k:best_k + 1]])
        elif rev:
            p = p[::-1]
        out.append(p)
        pen = p[-1]
        todo.remove(best)
    return out


def plotter_svg(domain: Any, *, stem: str = "", provenance: dict | None = None, width: float = 200,
                units: str = "mm", pen_width: float = 0.3, process: bool = False, smooth: int = 0,
                title: str = "") -> bytes:
    """Stroke-only outlines for a pen plotter: no fill, no background, paths ordered to cut
    pen-up travel. The final outlines (every cloud of a cloudscape, or the last contour of a
    ``{cloud}_history``) go on layer "outline"; with ``process`` the earlier contours of a
    history go on layer "process" (a second pen). ``pen_width`` is in ``units``."""
    dom = need(domain, "cloud_plotter_svg")
    if dom.n_lines == 0:
        raise InputError("cloud_plotter_svg: the domain has no line to plot")
    if not 0 <= int(smooth) <= 6:
        raise InputError(f"cloud_plotter_svg: smooth = {smooth} passes, expected 0..6")
    history = "snapshot__step" in dom
    if process and not history:
        raise InputError("cloud_plotter_svg: process = true needs a {cloud}_history domain (earlier contours)")
    final = [dom.n_lines - 1] if history else list(range(dom.n_lines))
    pens = [("outline", final)]
    if process:
        pens.append(("process", list(range(dom.n_lines - 1))))
    page = Page(domain_box(dom), width, units)
    dwg = page.dwg
    pen = np.zeros(2)
    for name, idx in pens:
        layer = page.layer(name, fill="none", stroke="#000000" if name == "outline" else "#1f5fbf",
                           stroke_width=fmt_number(pen_width * page.unit), stroke_linejoin="round",
                           stroke_linecap="round")
        lines = [page.xy(chaikin(dom.line(i), bool(dom.closed[i]), int(smooth))) for i in idx]
        ordered = plot_order(lines, [bool(dom.closed[i]) for i in idx], pen)
        for d in page.ds(ordered, False, page=True):
            layer.add(dwg.path(d=d))
        if ordered:
            pen = ordered[-1][-1]
    return finish(dwg, provenance, title or "snaxel cloud (plotter)")


# -- magnified details (Figures 4.4 and 4.8) -----------------------------------------------------
def _cut_width(poly: Any, y: float, x0: float, x1: float) -> tuple[float, float]:
    """Width of the widest piece of the silhouette on the horizontal line at ``y`` (the main
    body's width there) and that piece's middle."""
    from shapely.geometry import LineString

    cut = poly.intersection(LineString([(x0 - 1.0, y), (x1 + 1.0, y)]))
    if cut.is_empty:
        return 0.0, 0.5 * (x0 + x1)
    widest = max(getattr(cut, "geoms", [cut]), key=lambda g: g.length)
    return float(widest.length), float(widest.centroid.x)


def detail_windows(xy: np.ndarray, focus: str, size: float) -> list[tuple[float, float, float]]:
    """(x, y, side) of the windows a detail figure magnifies. ``fringe`` (Figure 4.8): the
    two windows (apart) holding the most outline length, where the fringe crowds; ``neck``
    (Figure 4.4): the narrowest horizontal cut of the body (its widest piece on the line) above
    the lower quarter with wider body above and below, a window 2 cut widths wide (at least
    ``size`` of the cloud's box)."""
    from shapely.geometry import Polygon

    (x0, y0), (x1, y1) = xy.min(0), xy.max(0)
    side = size * max(x1 - x0, y1 - y0)
    if focus == "fringe":       # the two most crinkled windows: most outline length per window
        seg = np.hypot(*(np.roll(xy, -1, 0) - xy).T)
        cand = xy[:: max(1, len(xy) // 200)]
        inside = np.all(np.abs(xy[None, :, :] - cand[:, None, :]) <= side / 2, axis=2)
        length = inside.astype(float) @ seg
        first = int(np.argmax(length))
        far = np.any(np.abs(cand - cand[first]) > side, axis=1)
        second = int(np.argmax(np.where(far, length, -1.0)))
        return [(float(cand[k, 0]), float(cand[k, 1]), side) for k in (first, second)]
    poly = Polygon(xy).buffer(0)
    ys = np.linspace(y0, y1, 61)[1:-1]
    cuts = np.array([_cut_width(poly, y, x0, x1) for y in ys])
    w = cuts[:, 0]
    above = np.maximum.accumulate(w[::-1])[::-1]
    below = np.maximum.accumulate(w)
    score = np.where((ys > y0 + 0.25 * (y1 - y0)) & (above > 1.3 * w) & (below > 1.3 * w) & (w > 0), w, np.inf)
    k = int(np.argmin(score)) if np.isfinite(score).any() else int(np.argmin(np.where(w > 0, w, np.inf)))
    return [(float(cuts[k, 1]), float(ys[k]), max(side, 2.0 * float(w[k])))]


def detail_svg(domain: Any, *, stem: str = "", provenance: dict | None = None, focus: str = "fringe",
               windows: Sequence[Sequence[float]] | None = None, size: float = 0.08, width: float = 900,
               units: str = "px", fill: str = "#ffffff", background: str | None = "#8fb8e0",
               title: str = "") -> bytes:
    """The whole cloud beside magnified windows of it (the thesis's Figures 4.4 and 4.8): each
    window framed on the overview and redrawn at its own scale (the factor is written on it),
    outline stroked so the detail reads. ``windows``: explicit [x, y, side] in model units;
    else ``focus`` = fringe | neck picks them (:func:`detail_windows`)."""
    dom = need(domain, "cloud_detail_svg")
    if focus not in ("fringe", "neck"):
        raise InputError(f"cloud_detail_svg: focus = {focus!r}, expected fringe or neck")
    xy = dom.line(dom.n_lines - 1)
    wins = [tuple(map(float, w)) for w in windows] if windows else detail_windows(xy, focus, size)
    if any(len(w) != 3 or not w[2] > 0 for w in wins):
        raise InputError("cloud_detail_svg: windows are [x, y, side] with side > 0")
    (x0, y0), (x1, y1) = xy.min(0), xy.max(0)
    pad = 0.04 * max(x1 - x0, y1 - y0)
    x0, y0, x1, y1 = x0 - pad, y0 - pad, x1 + pad, y1 + pad
    H = 100.0                                   # layout height; panels live in a y-up layout box
    ov = H / (y1 - y0)                          # overview scale
    ow = (x1 - x0) * ov
    gap = 4.0
    ph = (H - gap * (len(wins) - 1)) / len(wins)
    page = Page((0.0, ow + gap + ph, 0.0, H), width, units)
    dwg = page.dwg
    page.sky(background)
    sw = fmt_number(0.3)

    def place(pts: np.ndarray, scale: float, ox: float, oy: float, cx: float, cy: float) -> np.ndarray:
        return np.column_stack([ox + (pts[:, 0] - cx) * scale, oy + (pts[:, 1] - cy) * scale])

    over = page.layer("whole cloud")
    over.add(dwg.path(d=page.d(place(xy, ov, 0.0, 0.0, x0, y0)), fill=fill, stroke="#5a6b80", stroke_width=sw))
    for k, (cx, cy, side) in enumerate(wins):
        lo = place(np.array([[cx - side / 2, cy - side / 2], [cx + side / 2, cy + side / 2]]), ov, 0.0, 0.0, x0, y0)
        over.add(dwg.path(d=page.d(np.array([lo[0], [lo[1, 0], lo[0, 1]], lo[1], [lo[0, 0], lo[1, 1]]])),
                          fill="none", stroke="#c0392b", stroke_width=sw))
        py0 = H - (k + 1) * ph - k * gap
        box = np.array([[ow + gap, py0], [ow + gap + ph, py0], [ow + gap + ph, py0 + ph], [ow + gap, py0 + ph]])
        clip = dwg.defs.add(dwg.clipPath(id=f"detail{k}"))
        clip.add(dwg.path(d=page.d(box)))
        mag = ph / side
        layer = page.layer(f"detail {k + 1} x{mag / ov:.1f}")
        g = dwg.g(clip_path=f"url(#detail{k})")
        g.add(dwg.path(d=page.d(box), fill=background or "#ffffff"))
        g.add(dwg.path(d=page.d(place(xy, mag, ow + gap + ph / 2, py0 + ph / 2, cx, cy)), fill=fill,
                       stroke="#5a6b80", stroke_width=sw, stroke_linejoin="round"))
        layer.add(g)
        layer.add(dwg.path(d=page.d(box), fill="none", stroke="#c0392b", stroke_width=sw))
        tx, ty = page.xy(np.array([[ow + gap + 1.5, py0 + ph - 5.0]]))[0]
        layer.add(dwg.text(f"x{mag / ov:.1f}", insert=(fmt_number(tx), fmt_number(ty)), font_size=fmt_number(6.0),
                           fill="#c0392b", font_family="sans-serif"))
    return finish(dwg, provenance, title or "snaxel cloud, magnified details")


EXPORTERS: list[tuple[str, str, Any, str]] = [
    ("cloud_svg", ".svg", cloud_svg, "cloud outline as one filled closed path, y-down, sky and cloud layers"),
    ("cloud_process_svg", ".svg", process_svg, "nested earlier contours, one colour per curve, a layer each"),
    ("cloud_view_svg", ".svg", view_svg, "Figure 1.2: tessellation, snake segments and snaxels"),
    ("cloud_anim_svg", ".svg", anim_svg, "animated SVG of the growth (from {cloud}_history)"),
    ("cloud_gif", ".gif", anim_gif, "animated GIF of the growth (from {cloud}_history)"),
    ("cloudscape_svg", ".svg", cloudscape_svg, "illustrated cloudscape: lit lobes shading each other, silver linings, "
     "flat shaded bases, optional ground with cloud shadows, a layer per cloud"),
    ("cloud_plotter_svg", ".svg", plotter_svg, "stroke-only outlines for pen plotters, ordered, pens as layers"),
    ("cloud_detail_svg", ".svg", detail_svg, "the cloud beside magnified windows of its fringe or neck (Figs 4.4, 4.8)"),
]
