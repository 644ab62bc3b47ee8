"""SVG output (svgwrite): filled/stroked paths from Polylines, wireframes from 2-D meshes.

Coordinates keep the model's y-up convention: the drawing is flipped with a transform so that
Inkscape shows what the model computed, and the viewBox is the domain's bounds.
"""
from __future__ import annotations

from typing import Any, Sequence
from xml.sax.saxutils import escape

import numpy as np
import svgwrite

from ..domains import Domain, PointSet, Polylines, TriMesh
from ..errors import InputError
from .provenance import provenance_json


def fmt_number(v: float) -> str:
    """A coordinate as SVG text: 4 decimals, no trailing zeros, no '-0' (deterministic output)."""
    s = f"{v:.4f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def path_data(points: np.ndarray, closed: bool) -> str:
    """SVG path ``d`` for one line, 4 decimals (deterministic text)."""
    if len(points) == 0:
        return ""
    body = " L".join(f"{fmt_number(x)},{fmt_number(y)}" for x, y in points[:, :2])
    return f"M{body}{' Z' if closed else ''}"


def _bounds(domain: Domain, pts: np.ndarray, margin: float) -> tuple[float, float, float, float]:
    b = getattr(domain, "bounds", None)
    if isinstance(b, tuple) and len(b) == 4:
        x0, x1, y0, y1 = b
    else:
        if len(pts) == 0:
            return (0.0, 1.0, 0.0, 1.0)
        x0, y0 = pts[:, :2].min(axis=0)
        x1, y1 = pts[:, :2].max(axis=0)
    w, h = max(x1 - x0, 1e-9), max(y1 - y0, 1e-9)
    return (x0 - margin * w, x1 + margin * w, y0 - margin * h, y1 + margin * h)


def new_drawing(bounds: tuple[float, float, float, float], width_px: int,
                background: str | None) -> tuple[svgwrite.Drawing, svgwrite.container.Group, float]:
    """A drawing whose viewBox is ``bounds`` and a y-flipped group to draw model coordinates in."""
    x0, x1, y0, y1 = bounds
    w, h = x1 - x0, y1 - y0
    height_px = max(1, int(round(width_px * h / w)))
    dwg = svgwrite.Drawing(size=(f"{width_px}px", f"{height_px}px"), profile="full", debug=False)
    dwg["viewBox"] = " ".join(fmt_number(v) for v in (x0, -y1, w, h))
    if background:
        dwg.add(dwg.rect(insert=(x0, -y1), size=(w, h), fill=background))
    group = dwg.g(transform="scale(1,-1)")
    dwg.add(group)
    return dwg, group, w / width_px


#: the RDF vocabulary Inkscape itself writes into <metadata> (Document Properties > Metadata)
RDF_NS = ('xmlns:rdf="http://www.w3.org/1999/02/22-rdf-syntax-ns#" xmlns:cc="http://creativecommons.org/ns#" '
          'xmlns:dc="http://purl.org/dc/elements/1.1/"')


def finish(dwg: svgwrite.Drawing, provenance: dict[str, Any] | None, title: str = "") -> bytes:
    """Serialise with provenance in <metadata> (no timestamps): an RDF ``cc:Work`` whose
    ``dc:description`` is the provenance JSON and ``dc:creator`` the program, the form Inkscape
    reads, keeps on save and shows in Document Properties (an element of our own namespace
    there made Inkscape warn "unknown type" on every open)."""
    text = dwg.tostring()
    version = (provenance or {}).get("versions", {}).get("procgen-rules", "")
    creator = f"procgen {version}".strip()
    work = ('<dc:format>image/svg+xml</dc:format>'
            '<dc:type rdf:resource="http://purl.org/dc/dcmitype/StillImage"/>'
            + (f"<dc:title>{escape(title)}</dc:title>" if title else "")
            + f"<dc:creator><cc:Agent><dc:title>{escape(creator)}</dc:title></cc:Agent></dc:creator>"
            + f"<dc:description>{escape(provenance_json(provenance))}</dc:description>")
    meta = f'<metadata><rdf:RDF {RDF_NS}><cc:Work rdf:about="">{work}</cc:Work></rdf:RDF></metadata>'
    if title:
        meta = f"<title>{escape(title)}</title>" + meta
    head_end = text.index(">", text.index("<svg")) + 1
    return ('<?xml version="1.0" encoding="utf-8"?>\n' + text[:head_end] + meta + text[head_end:]).encode()


def vertical_gradient(dwg: Any, colours: Sequence[str], ident: str, *, y_up: bool = False) -> str:
    """Add a top-to-bottom linear gradient over the filled shape's bounding box to ``dwg``'s
    defs (``y_up``: the shape is drawn in a y-flipped group) and return its fill reference."""
    grad = dwg.linearGradient(start=(0, 1 if y_up else 0), end=(0, 0 if y_up else 1), id=ident)
    for i, colour in enumerate(colours):
        grad.add_stop_color(i / (len(colours) - 1), colour)
    dwg.defs.add(grad)
    return f"url(#{ident})"


def polylines_svg(domain: Domain, *, stem: str = "", provenance: dict[str, Any] | None = None,
                  fill: str | None = "#ffffff", stroke: str | None = "#4a5a70", stroke_width: float = 1.5,
                  gradient: Sequence[str] | None = None, background: str | None = "#8fb8e0",
                  width: int = 800, margin: float = 0.02, color_field: str | None = None,
                  fill_opacity: float = 1.0, title: str = "") -> bytes:
    """Polylines as SVG paths: closed lines filled (optionally with a vertical gradient)."""
    if not isinstance(domain, Polylines):
        raise InputError(f"svg: expected Polylines, got {domain.kind}")
    bounds = _bounds(domain, domain.points, margin)
    dwg, group, px = new_drawing(bounds, width, background)
    fill_ref = fill
    if gradient:
        if len(gradient) < 2:
            raise InputError("svg: gradient needs at least two colours (top, bottom)")
        # the path lives in the y-flipped group: bounding-box y=1 is the top on screen
        fill_ref = vertical_gradient(dwg, gradient, "procgen-fill", y_up=True)
    colours = domain[color_field] if color_field else None
    for i in range(domain.n_lines):
        pts = domain.line(i)
        if len(pts) < 2:
            continue
        closed = bool(domain.closed[i])
        kw: dict[str, Any] = {"d": path_data(pts, closed)}
        line_stroke = stroke
        if colours is not None:
            c = np.clip(np.asarray(colours[i], float)[:3], 0, 1)
            line_stroke = "#%02x%02x%02x" % tuple(int(round(255 * v)) for v in c)
        kw["fill"] = fill_ref if (closed and fill_ref) else "none"
        if closed and fill_ref and fill_opacity < 1:
            kw["fill_opacity"] = fill_opacity
        if line_stroke:
            kw["stroke"] = line_stroke
            kw["stroke_width"] = fmt_number(stroke_width * px)
            kw["stroke_linejoin"] = "round"
        group.add(dwg.path(**kw))
    return finish(dwg, provenance, title)


def mesh_svg(domain: Domain, *, stem: str = "", provenance: dict[str, Any] | None = None,
             stroke: str = "#c03030", stroke_width: float = 0.7, point_color: str | None = "#2040c0",
             point_radius: float = 1.5, background: str | None = "#ffffff", width: int = 800,
             margin: float = 0.02, title: str = "") -> bytes:
    """A 2-D TriMesh as a wireframe (edges) with optional vertex dots; PointSet as dots."""
    if isinstance(domain, TriMesh):
        pts = domain.vertices
        edges = domain.edges
    elif isinstance(domain, PointSet):
        pts, edges = domain.points, np.zeros((0, 2), int)
    else:
        raise InputError(f"svg_mesh: expected a TriMesh or PointSet, got {domain.kind}")
    bounds = _bounds(domain, pts, margin)
    dwg, group, px = new_drawing(bounds, width, background)
    if len(edges):
        d = " ".join(f"M{fmt_number(a[0])},{fmt_number(a[1])} L{fmt_number(b[0])},{fmt_number(b[1])}"
                     for a, b in zip(pts[edges[:, 0]], pts[edges[:, 1]]))
        group.add(dwg.path(d=d, fill="none", stroke=stroke, stroke_width=fmt_number(stroke_width * px)))
    if point_color:
        dots = dwg.g(fill=point_color)
        r = fmt_number(point_radius * px)
        for x, y in pts[:, :2]:
            dots.add(dwg.circle(center=(fmt_number(x), fmt_number(y)), r=r))
        group.add(dots)
    return finish(dwg, provenance, title)
