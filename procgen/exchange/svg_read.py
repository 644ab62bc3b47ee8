"""Reading SVG drawings (Inkscape, Illustrator, hand-written) into polylines.

Why: an outline drawn in a vector editor is the natural way to bring a shape into procgen
(extrude it, weather it, use it as sketch strokes). svgelements does the SVG work, nested
group transforms (Inkscape layers), arcs, Beziers, basic shapes, ``<use>``, CSS units and the
root viewBox, so procgen only flattens its exact segments to a chordal tolerance.

Coordinates come back in the root viewBox's user units, y down as the file has it; callers
that want y up flip them. ``SvgDrawing.mm_per_unit`` says how long one user unit is on paper.
"""
from __future__ import annotations

import io
import math
from dataclasses import dataclass
from pathlib import Path
from xml.etree.ElementTree import ParseError

import numpy as np
import svgelements as se

from ..errors import InputError

_PX_MM = 25.4 / 96.0  # CSS: 96 px to the inch


@dataclass(frozen=True)
class SvgDrawing:
    """Every path of a drawing flattened: ``polylines`` is ``[(points (k, 2), closed), ...]``.

    ``viewbox`` is (x, y, width, height) in user units: the root viewBox, else the root's
    width/height, else the drawing's bounding box. ``mm_per_unit`` is None when the root
    element has no absolute width and height (the drawing then has no physical size).
    """

    polylines: list[tuple[np.ndarray, bool]]
    viewbox: tuple[float, float, float, float]
    mm_per_unit: float | None


def read_svg(source: str | Path | bytes, tolerance: float | None = None) -> SvgDrawing:
    """Parse an SVG file (path) or document (bytes) and flatten every shape it draws.

    ``tolerance`` is the largest distance, in user units, between a curve and its chords
    (default: 1/1000 of the larger viewBox side). One polyline per subpath; ``closed`` when
    the subpath ends with Z (or is a closed shape: rect, circle, ellipse, polygon); the closing
    point is not repeated. Raises InputError naming the file for anything that is not SVG.
    """
    name = "<svg bytes>" if isinstance(source, (bytes, bytearray)) else str(source)
    stream = io.BytesIO(bytes(source)) if isinstance(source, (bytes, bytearray)) else str(source)
    if not isinstance(stream, io.BytesIO) and not Path(stream).is_file():
        raise InputError(f"{name}: SVG file not found")
    try:
        doc = se.SVG.parse(stream, reify=True)
    except (ParseError, ValueError, TypeError) as exc:
        raise InputError(f"{name}: not a readable SVG file ({str(exc).splitlines()[0]})") from None
    if not isinstance(doc, se.SVG):
        raise InputError(f"{name}: not an SVG document (no <svg> root element)")
    to_px, viewbox, px_per_unit = _root_frame(doc)
    to_user = np.linalg.inv(to_px)
    tol = tolerance if tolerance is not None else 1e-3 * max(viewbox[2], viewbox[3])
    if not tol > 0:
        raise InputError(f"{name}: flattening tolerance must be > 0, got {tol!r}")
    tol_px = tol * float(np.linalg.svd(to_px[:2, :2], compute_uv=False)[-1])
    lines: list[tuple[np.ndarray, bool]] = []
    for element in doc.elements():
        if not isinstance(element, se.Shape) or isinstance(element, se.Text):
            continue
        path = se.Path(element)
        path.reify()  # a rotated rect keeps its matrix after parsing; bake it in
        for sub in path.as_subpaths():
            pts, closed = _flatten(list(sub), tol_px)
            if len(pts) < 2:
                continue
            user = pts @ to_user[:2, :2].T + to_user[:2, 2]
            lines.append((user, closed))
    return SvgDrawing(lines, viewbox, px_per_unit * _PX_MM if _absolute_size(doc) else None)


def svg_polylines(source: str | Path | bytes,
                  tolerance: float | None = None) -> list[tuple[np.ndarray, bool]]:
    """``read_svg(source, tolerance).polylines``: the (points (k, 2), closed) list, user units, y down."""
    return read_svg(source, tolerance).polylines


def _root_frame(doc: se.SVG) -> tuple[np.ndarray, tuple[float, float, float, float], float]:
    """The root viewBox -> viewport (px) matrix svgelements applied, the viewBox, px per unit."""
    m = se.Matrix(doc.viewbox_transform) if doc.viewbox is not None else se.Matrix()
    to_px = np.array([[m.a, m.c, m.e], [m.b, m.d, m.f], [0.0, 0.0, 1.0]])
    if doc.viewbox is not None:
        vb = doc.viewbox
        box = (float(vb.x), float(vb.y), float(vb.width), float(vb.height))
    elif _absolute_size(doc):
        box = (0.0, 0.0, float(doc.width), float(doc.height))
    else:
        bb = doc.bbox()
        box = (0.0, 0.0, 1.0, 1.0) if bb is None else (bb[0], bb[1], bb[2] - bb[0], bb[3] - bb[1])
    return to_px, box, math.sqrt(abs(np.linalg.det(to_px[:2, :2])))


def _absolute_size(doc: se.SVG) -> bool:
    """True when the root element states width and height as lengths (not %, not absent)."""
    attrs = doc.values.get("attributes", {})
    return all(k in attrs and not str(attrs[k]).strip().endswith("%") for k in ("width", "height"))


def _flatten(segments: list[se.PathSegment], tol: float) -> tuple[np.ndarray, bool]:
    """One subpath's segments -> points within ``tol`` of the curve (Wang's bound for Beziers,
    the sagitta bound for arcs), and whether it is closed."""
    out: list[np.ndarray] = []
    closed = False
    for seg in segments:
        if isinstance(seg, se.Move):
            out.append(np.array([[seg.end.x, seg.end.y]]))
            continue
        if isinstance(seg, se.Close):
            closed = True
            continue
        if seg.start is None or seg.end is None:
            continue
        n = _pieces(seg, tol)
        t = np.linspace(0.0, 1.0, n + 1)[1:]
        pts = np.asarray(seg.npoint(t), dtype=np.float64).reshape(-1, 2)
        if not out:
            out.append(np.array([[seg.start.x, seg.start.y]]))
        out.append(pts)
    if not out:
        return np.zeros((0, 2)), False
    pts = np.concatenate(out)
    keep = np.ones(len(pts), bool)
    keep[1:] = np.any(np.abs(np.diff(pts, axis=0)) > 1e-12 * (1.0 + np.abs(pts[1:])), axis=1)
    pts = pts[keep]
    if closed and len(pts) > 1 and np.allclose(pts[0], pts[-1], rtol=0.0, atol=1e-9 * (1.0 + tol)):
        pts = pts[:-1]
    return pts, closed


def _pieces(seg: se.PathSegment, tol: float) -> int:
    """How many chords keep ``seg`` within ``tol`` of its flattening."""
    if isinstance(seg, se.CubicBezier):
        p = np.array([[q.x, q.y] for q in (seg.start, seg.control1, seg.control2, seg.end)])
        m = np.max(np.linalg.norm(p[:-2] - 2 * p[1:-1] + p[2:], axis=1))
        return max(1, math.ceil(math.sqrt(0.75 * m / tol)))
    if isinstance(seg, se.QuadraticBezier):
        p = np.array([[q.x, q.y] for q in (seg.start, seg.control, seg.end)])
        m = float(np.linalg.norm(p[0] - 2 * p[1] + p[2]))
        return max(1, math.ceil(math.sqrt(0.25 * m / tol)))
    if isinstance(seg, se.Arc):
        r = max(abs(seg.rx), abs(seg.ry))
        if r <= 0 or not seg.sweep:
            return 1
        step = 2.0 * math.acos(max(1.0 - tol / r, -1.0))
        return max(1, math.ceil(abs(seg.sweep) / step))
    return 1
