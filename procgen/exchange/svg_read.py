"""Reading SVG drawings (Inkscape, Illustrator, hand-written) into polylines.

Why: an outline drawn in a vector editor is the natural way to bring a shape into procgen
(extrude it, weather it, use it as sketch strokes). svgelements does the SVG work, nested
group transforms (Inkscape layers), arcs, Beziers, basic shapes, ``<use>``, CSS units and the
root viewBox, so procgen only flattens its exact segments to a chordal tolerance.

Coordinates come back in the root viewBox's user units, y down as the file has it; callers
that want y up flip them. ``SvgDrawing.mm_per_unit`` says how long one user unit is on paper.

A hostile or broken drawing is refused in one line before svgelements builds it: the file is
bounded in size (procgen.exchange.input_files), and a streaming pre-scan bounds the nesting
depth, refuses ``<use>`` loops and bounds what ``<use>`` copies expand to (elements and path
segments), and refuses an empty or negative root viewBox. Flattening is bounded too: the total
point count is summed from the chord counts before any point is made.
"""
from __future__ import annotations

import io
import math
import re
from dataclasses import dataclass
from pathlib import Path
from xml.etree.ElementTree import ParseError, iterparse

import numpy as np
import svgelements as se

from ..errors import InputError, printable
from .input_files import MAX_BYTES, read_input

#: deepest element nesting (``<use>`` copies included) a drawing may have
MAX_DEPTH = 128
#: most elements a drawing may have once every ``<use>`` is expanded
MAX_ELEMENTS = 200_000
#: most path segments (estimated from the coordinates given) once ``<use>`` is expanded; svgelements
#: builds about 40,000 segments a second
MAX_SEGMENTS = 250_000
#: most points the flattened drawing may have (at the tolerance asked for)
MAX_POINTS = 4_000_000

_NUMBER = re.compile(r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?")
_HREFS = ("href", "{http://www.w3.org/1999/xlink}href")

_PX_MM = 1.0 / float(se.Length("1mm").value(ppi=96.0))  # svgelements' px per mm (96 px to the inch)


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
    if isinstance(source, (bytes, bytearray)):
        name, data = "<svg bytes>", bytes(source)
        if len(data) > MAX_BYTES["SVG"]:
            raise InputError(f"{name}: {len(data):,} bytes, more than the "
                             f"{MAX_BYTES['SVG'] / 2**20:,.0f} MiB procgen reads from one SVG file")
    else:
        name = printable(str(source))
        data = read_input(source, "SVG", name)
    _prescan(data, name)
    try:
        doc = se.SVG.parse(io.BytesIO(data), reify=True)
    except (ParseError, ValueError, TypeError, IndexError, KeyError, AttributeError,
            ZeroDivisionError, OverflowError):
        raise InputError(f"{name}: not a readable SVG file (an attribute or style svg cannot hold)") from None
    if not isinstance(doc, se.SVG):
        raise InputError(f"{name}: not an SVG document (no <svg> root element)")
    try:
        to_px, viewbox, px_per_unit = _root_frame(doc)
        if not (np.all(np.isfinite(to_px)) and abs(np.linalg.det(to_px[:2, :2])) > 0):
            raise InputError(f"{name}: the root width/height and viewBox map the drawing to nothing")
        to_user = np.linalg.inv(to_px)
        tol = tolerance if tolerance is not None else 1e-3 * max(viewbox[2], viewbox[3])
        if not (tol > 0 and math.isfinite(tol)):
            raise InputError(f"{name}: flattening tolerance must be a number > 0, got {tol!r} "
                             "(the drawing has no size: give the <svg> a viewBox)")
        tol_px = tol * float(np.linalg.svd(to_px[:2, :2], compute_uv=False)[-1])
        budget = [MAX_POINTS]
        lines: list[tuple[np.ndarray, bool]] = []
        for element in doc.elements():
            if not isinstance(element, se.Shape) or isinstance(element, se.Text):
                continue
            path = se.Path(element)
            path.reify()  # a rotated rect keeps its matrix after parsing; bake it in
            for sub in path.as_subpaths():
                pts, closed = _flatten(list(sub), tol_px, budget, name, tol)
                if len(pts) < 2:
                    continue
                user = pts @ to_user[:2, :2].T + to_user[:2, 2]
                lines.append((user, closed))
    except (ValueError, TypeError, IndexError, KeyError, AttributeError, ZeroDivisionError,
            OverflowError, np.linalg.LinAlgError):
        raise InputError(f"{name}: not a readable SVG file (a shape or transform svg cannot hold)") from None
    return SvgDrawing(lines, viewbox, px_per_unit * _PX_MM if _absolute_size(doc) else None)


def _prescan(data: bytes, name: str) -> None:
    """Refuse, before svgelements builds anything, what would make it recurse without end or
    expand without bound: nesting deeper than MAX_DEPTH, a ``<use>`` that reaches itself, more
    than MAX_ELEMENTS elements or MAX_SEGMENTS path segments once every ``<use>`` is copied,
    and an empty or negative root viewBox/size."""
    own: dict[str, list[int]] = {}          # id -> [elements, segments, depth] of its subtree
    uses: dict[str, list[str]] = {}         # id -> ids its subtree's <use> elements copy
    stack: list[list] = []                  # open elements: [id, elements, segments, depth, uses]
    all_uses: list[str] = []
    total = [0, 0]
    try:
        for event, el in iterparse(io.BytesIO(data), events=("start", "end")):
            if event == "start":
                if len(stack) >= MAX_DEPTH:
                    raise InputError(f"{name}: elements nested more than {MAX_DEPTH} deep")
                if not stack:
                    _check_root(el, name)
                segs = _segments(el, MAX_SEGMENTS + 1 - total[1])
                href = next((el.get(k) for k in _HREFS if el.get(k)), None) \
                    if el.tag.rpartition("}")[2] == "use" else None
                refs = [href[1:].strip()] if href and href.startswith("#") else []
                all_uses += refs
                stack.append([el.get("id"), 1, segs, 1, refs])
                total[0] += 1
                total[1] += segs
                if total[0] > MAX_ELEMENTS or total[1] > MAX_SEGMENTS:
                    raise InputError(_too_many(name, *total))
                continue
            ident, n, segs, depth, refs = stack.pop()
            if ident:                       # a repeated id: count the larger, follow both
                was = own.get(ident, [0, 0, 0])
                own[ident] = [max(n, was[0]), max(segs, was[1]), max(depth, was[2])]
                uses[ident] = uses.get(ident, []) + refs
            if stack:
                parent = stack[-1]
                parent[1] += n
                parent[2] += segs
                parent[3] = max(parent[3], depth + 1)
                parent[4].extend(refs)
            el.clear()
    except ParseError as exc:
        line, col = getattr(exc, "position", (0, 0))
        raise InputError(f"{name}: not a readable SVG file (not well-formed XML at line {line}, "
                         f"column {col})") from None
    except (LookupError, ValueError) as exc:    # the XML parser: an unknown or multi-byte encoding
        if not isinstance(exc, LookupError) and "encoding" not in str(exc):
            raise
        declared = re.match(rb"\s*<\?xml[^>]*?encoding\s*=\s*[\"']([^\"']{0,40})", data)
        what = f"its encoding {printable(declared[1].decode('ascii', 'replace'))!r}" if declared else "its text encoding"
        raise InputError(f"{name}: not a readable SVG file ({what} is not one procgen reads; save it as UTF-8)") from None
    if not all_uses:
        return
    expanded = _expand(own, uses, name)
    n = total[0] + sum(expanded[r][0] for r in all_uses if r in expanded)
    segs = total[1] + sum(expanded[r][1] for r in all_uses if r in expanded)
    if n > MAX_ELEMENTS or segs > MAX_SEGMENTS:
        raise InputError(_too_many(name, n, segs))
    deepest = max((expanded[r][2] for r in all_uses if r in expanded), default=0)
    if deepest > MAX_DEPTH:
        raise InputError(f"{name}: elements nested more than {MAX_DEPTH} deep once <use> copies are made")


def _too_many(name: str, elements: int, segments: int) -> str:
    return (f"{name}: drawing too large: more than {MAX_ELEMENTS:,} elements or {MAX_SEGMENTS:,} path "
            f"segments, <use> copies counted (at least {elements:,} and {segments:,}); simplify it")


def _expand(own: dict[str, list[int]], uses: dict[str, list[str]], name: str) -> dict[str, list[int]]:
    """id -> [elements, segments, depth] of its subtree with every <use> inside it copied, found
    without recursion; InputError for a <use> that reaches its own subtree. Counts stop growing
    past the limits (only whether they pass them matters)."""
    done: dict[str, list[int]] = {}
    for start in uses:
        if start in done:
            continue
        path, open_ = [start], {start}
        todo = [iter(uses[start])]
        while todo:
            nxt = next(todo[-1], None)
            if nxt is None:
                todo.pop()
                ident = path.pop()
                open_.discard(ident)
                n, segs, depth = own[ident]
                for r in uses[ident]:
                    if r in done:
                        n, segs = min(n + done[r][0], MAX_ELEMENTS + 1), min(segs + done[r][1], MAX_SEGMENTS + 1)
                        depth = max(depth, own[ident][2] + done[r][2])
                done[ident] = [n, segs, depth]
                continue
            if nxt in open_:
                raise InputError(f"{name}: <use> of #{printable(nxt)[:40]} copies itself (a <use> loop)")
            if nxt in done or nxt not in uses:
                continue
            path.append(nxt)
            open_.add(nxt)
            todo.append(iter(uses[nxt]))
    return done


def _check_root(el, name: str) -> None:
    """The root's viewBox must be four numbers with width and height > 0, its width and height
    (when plain numbers) > 0: SVG renders nothing otherwise, and the scale is undefined."""
    vb = el.get("viewBox")
    if vb is not None and vb.strip():
        parts = vb.replace(",", " ").split()
        try:
            x, y, w, h = (float(p) for p in parts)
        except ValueError:
            raise InputError(f"{name}: viewBox {printable(vb)[:60]!r} is not four numbers") from None
        if not (all(map(math.isfinite, (x, y, w, h))) and w > 0 and h > 0):
            raise InputError(f"{name}: viewBox {printable(vb)[:60]!r} has no area (width and height must be > 0)")
    for key in ("width", "height"):
        m = _NUMBER.match((el.get(key) or "").strip())
        if m and not float(m.group()) > 0 and not (el.get(key) or "").strip().endswith("%"):
            raise InputError(f"{name}: <svg> {key} {printable(el.get(key))[:30]!r} must be > 0")


def _segments(el, cap: int) -> int:
    """Path segments an element draws, estimated from its coordinates (half the numbers),
    counted no further than ``cap``."""
    tag = el.tag.rpartition("}")[2]
    text = el.get("d") if tag == "path" else el.get("points") if tag in ("polyline", "polygon") else None
    if text is None:
        return 1
    numbers = 0
    for numbers, _ in enumerate(_NUMBER.finditer(text), 1):
        if numbers > 2 * cap:
            break
    return 1 + numbers // 2


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


def _flatten(segments: list[se.PathSegment], tol: float, budget: list[int], name: str,
             user_tol: float) -> tuple[np.ndarray, bool]:
    """One subpath's segments -> points within ``tol`` of the curve (Wang's bound for Beziers,
    the sagitta bound for arcs), and whether it is closed. ``budget[0]`` is how many points the
    drawing may still have; InputError when a segment would pass it (or is not finite)."""
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
        pieces = _pieces(seg, tol)
        if pieces is None:
            raise InputError(f"{name}: a path has coordinates too large to be numbers")
        budget[0] -= pieces
        if budget[0] < 0:
            raise InputError(f"{name}: the drawing flattens to more than {MAX_POINTS:,} points at tolerance "
                             f"{user_tol:g} (huge or far-out coordinates?); raise the tolerance or simplify it")
        n = pieces
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


def _pieces(seg: se.PathSegment, tol: float) -> int | None:
    """How many chords keep ``seg`` within ``tol`` of its flattening (None: not finite)."""
    ends = np.array([[seg.start.x, seg.start.y], [seg.end.x, seg.end.y]], dtype=np.float64)
    if not np.all(np.isfinite(ends)):
        return None
    if isinstance(seg, se.CubicBezier):
        p = np.array([[q.x, q.y] for q in (seg.start, seg.control1, seg.control2, seg.end)])
        with np.errstate(over="ignore", invalid="ignore"):
            m = float(np.max(np.linalg.norm(p[:-2] - 2 * p[1:-1] + p[2:], axis=1)))
        return _ceil(math.sqrt(0.75 * m / tol) if math.isfinite(m) else m)
    if isinstance(seg, se.QuadraticBezier):
        p = np.array([[q.x, q.y] for q in (seg.start, seg.control, seg.end)])
        with np.errstate(over="ignore", invalid="ignore"):
            m = float(np.linalg.norm(p[0] - 2 * p[1] + p[2]))
        return _ceil(math.sqrt(0.25 * m / tol) if math.isfinite(m) else m)
    if isinstance(seg, se.Arc):
        r = max(abs(seg.rx), abs(seg.ry))
        if not (math.isfinite(r) and math.isfinite(seg.sweep)):
            return None
        if r <= 0 or not seg.sweep:
            return 1
        step = 2.0 * math.acos(max(1.0 - tol / r, -1.0))
        return _ceil(abs(seg.sweep) / step) if step > 0 else MAX_POINTS + 1
    return 1


def _ceil(x: float) -> int | None:
    """max(1, ceil(x)) for a finite x, None otherwise."""
    return max(1, math.ceil(x)) if math.isfinite(x) else None
