"""SVG output (svgwrite): filled/stroked paths from Polylines, wireframes from 2-D meshes.

Coordinates keep the model's y-up convention: the drawing is flipped with a transform so that
Inkscape shows what the model computed, and the viewBox is the domain's bounds.

Path data is compact (issue 34: snaxel process figures were 14 MB): the precision is a property
of the drawing (:func:`svg_decimals` of its viewBox, 1/10000 of its larger side), the first point
is absolute and the rest relative moves taken from the rounded absolute coordinates (no drift),
with implicit command repetition and minimal separators, formatted in numpy (:func:`paths_data`).
"""
from __future__ import annotations

from typing import Any, Sequence
from xml.sax.saxutils import escape

import numpy as np
import svgwrite

from ..domains import Domain, PointSet, Polylines, TriMesh
from ..errors import InputError
from .provenance import provenance_json


#: path data resolution as a share of the drawing's larger side (issue 34): 1/10000 keeps a
#: unit-square domain at 4 decimals and writes a 700-unit cloud page with 2
RESOLUTION = 1e-4


def fmt_number(v: float, decimals: int = 4) -> str:
    """A coordinate as SVG text: ``decimals`` decimals, no trailing zeros, no '-0' (deterministic output)."""
    s = f"{v:.{max(0, int(decimals))}f}"
    if "." in s:
        s = s.rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def svg_decimals(extent: float) -> int:
    """Decimals for path data of a drawing whose viewBox's larger side is ``extent``: the
    fewest that resolve :data:`RESOLUTION` of it (1 -> 4, 700 -> 2, 5000 -> 1, 50000 -> 0). Computed once per
    drawing, so every path of it keeps the same visible precision whatever its units."""
    extent = float(extent)
    if not np.isfinite(extent) or extent <= 0:
        return 4
    return int(min(12, max(0, np.ceil(-np.log10(RESOLUTION * extent) - 1e-9))))


def _number_text(q: np.ndarray, decimals: int, lead: np.ndarray) -> tuple[str, np.ndarray]:
    """Integers ``q`` (the values times 10**decimals) as one SVG number text, built in numpy:
    no '0' before '.', no trailing zeros, no '-0'; each number is preceded by the byte ``lead``
    (0: none), a separator ',' or ' ' being dropped before a '-' (the sign separates). Returns
    the text and each number's character count (to cut it into paths)."""
    n = len(q)
    neg = q < 0
    a = np.abs(q)
    scale = 10 ** decimals
    ip, fp = a // scale, a % scale
    width = max(1, len(str(int(ip.max())))) if n else 1
    cols = 2 + width + (1 + decimals if decimals else 0)
    chars = np.zeros((n, cols), np.uint8)
    keep = np.zeros((n, cols), bool)
    chars[:, 0] = lead
    keep[:, 0] = (lead != 0) & ~(neg & ((lead == ord(",")) | (lead == ord(" "))))
    chars[:, 1] = ord("-")
    keep[:, 1] = neg
    for k in range(width):                       # integer digits, most significant first
        p = width - 1 - k
        chars[:, 2 + k] = 48 + (ip // 10 ** p) % 10
        keep[:, 2 + k] = ip >= 10 ** p
    keep[:, 1 + width] |= fp == 0                # a whole number keeps its units digit ("0" too)
    if decimals:
        dot = 2 + width
        chars[:, dot] = ord(".")
        keep[:, dot] = fp != 0
        for r in range(1, decimals + 1):         # fraction digits, dropped after the last non-zero
            place = 10 ** (decimals - r)
            chars[:, dot + r] = 48 + (fp // place) % 10
            keep[:, dot + r] = fp % (place * 10) != 0
    return chars[keep].tobytes().decode("ascii"), keep.sum(axis=1)


def paths_data(lines: Sequence[np.ndarray], closed: bool | Sequence[bool], decimals: int) -> list[str]:
    """SVG path ``d`` of each line, all formatted in one numpy pass: "M" and the first point
    absolute, then relative "l" moves (SVG repeats the command implicitly), "z" if closed.

    The moves are differences of the absolute coordinates rounded to integers of 10**-decimals,
    so every decoded point is within half a resolution step of its input however long the line
    (no rounding error accumulates)."""
    decimals = int(decimals)
    closed_flags = [bool(closed)] * len(lines) if isinstance(closed, (bool, np.bool_)) else [bool(c) for c in closed]
    arrays = [np.asarray(p, float).reshape(len(p), -1)[:, :2] if len(p) else np.zeros((0, 2)) for p in lines]
    counts = np.array([len(p) for p in arrays], np.int64)
    if counts.sum() == 0:
        return [""] * len(arrays)
    xy = np.concatenate([p for p in arrays if len(p)]) * 10.0 ** decimals
    if not np.isfinite(xy).all():
        raise InputError("svg: a path has a coordinate that is not a finite number")
    if np.abs(xy).max() >= 2.0 ** 62:
        raise InputError(f"svg: a path coordinate is too large to write with {decimals} decimals")
    q = np.rint(xy).astype(np.int64)
    starts = np.concatenate([[0], np.cumsum(counts)[:-1]])[counts > 0]
    rel = q.copy()
    rel[1:] -= q[:-1]
    rel[starts] = q[starts]                      # each line's first point stays absolute
    lead = np.empty(q.shape, np.uint8)           # byte before each number: x ' ', y ','
    lead[:, 0], lead[:, 1] = ord(" "), ord(",")
    lead[starts, 0] = ord("M")
    second = starts[counts[counts > 0] > 1] + 1
    lead[second, 0] = ord("l")
    text, lengths = _number_text(rel.ravel(), decimals, lead.ravel())
    ends = np.concatenate([[0], np.cumsum(lengths)])[2 * np.cumsum(counts)]
    begins = np.concatenate([[0], ends[:-1]])
    return [text[b:e] + ("z" if c and e > b else "") for b, e, c in zip(begins.tolist(), ends.tolist(), closed_flags)]


def path_data(points: np.ndarray, closed: bool, decimals: int = 4) -> str:
    """SVG path ``d`` for one line (see :func:`paths_data`); ``decimals`` is the drawing's
    precision, :func:`svg_decimals` of its viewBox."""
    if len(points) == 0:
        return ""
    return paths_data([points], closed, decimals)[0]


def box_decimals(bounds: tuple[float, float, float, float]) -> int:
    """The path decimals of a drawing over ``bounds`` (x0, x1, y0, y1): :func:`svg_decimals`
    of its larger side."""
    x0, x1, y0, y1 = bounds
    return svg_decimals(max(x1 - x0, y1 - y0))


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
    keep = [i for i in range(domain.n_lines) if domain.offsets[i + 1] - domain.offsets[i] >= 2]
    ds = paths_data([domain.line(i) for i in keep], [bool(domain.closed[i]) for i in keep], box_decimals(bounds))
    for i, d in zip(keep, ds):
        closed = bool(domain.closed[i])
        kw: dict[str, Any] = {"d": d}
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
    dec = box_decimals(bounds)
    if len(edges):
        segs = np.stack([pts[edges[:, 0], :2], pts[edges[:, 1], :2]], axis=1)
        d = "".join(paths_data(list(segs), False, dec))
        group.add(dwg.path(d=d, fill="none", stroke=stroke, stroke_width=fmt_number(stroke_width * px)))
    if point_color:
        dots = dwg.g(fill=point_color)
        r = fmt_number(point_radius * px)
        for x, y in pts[:, :2]:
            dots.add(dwg.circle(center=(fmt_number(x, dec), fmt_number(y, dec)), r=r))
        group.add(dots)
    return finish(dwg, provenance, title)
