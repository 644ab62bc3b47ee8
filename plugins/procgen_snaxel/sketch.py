"""Sketch mode (thesis section 3.5.3): strokes mark tessellation triangles the snake engulfs first.

Strokes come from the recipe (flat [x0, y0, x1, y1, ...] lists in domain units) or from any
SVG a user saves (Inkscape 1.x layers with transforms, arcs, Beziers, units), read by the core's
svgelements-based reader; the drawing's viewBox is mapped onto the domain, y flipped (SVG is
y-down, the model y-up). Marked = the corners of every triangle a stroke passes through,
dilated by c_t mean edge lengths (ambiguity A21: c_t = 1 adds about one ring of vertices).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from procgen import InputError
from procgen.exchange.svg_read import read_svg

from .topology import Topology


def strokes_from_lists(strokes: list[list[float]]) -> list[np.ndarray]:
    return [np.asarray(s, np.float64).reshape(-1, 2) for s in strokes]


def check_inside(strokes: list[np.ndarray], bounds: tuple[float, float, float, float]) -> None:
    """ValueError naming the first stroke point outside the domain (x0, x1, y0, y1)."""
    x0, x1, y0, y1 = bounds
    for i, s in enumerate(strokes):
        bad = np.flatnonzero((s[:, 0] < x0) | (s[:, 0] > x1) | (s[:, 1] < y0) | (s[:, 1] > y1))
        if len(bad):
            x, y = s[bad[0]]
            raise ValueError(f"sketch stroke {i} point ({x:g}, {y:g}) lies outside the domain "
                             f"[{x0:g}, {x1:g}] x [{y0:g}, {y1:g}]")


def strokes_from_svg(path: str | Path, bounds: tuple[float, float, float, float]) -> list[np.ndarray]:
    """Every drawn shape of an SVG file as a stroke, mapped from its viewBox to the domain."""
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"sketch_svg: file {str(path)!r} not found")
    try:
        drawing = read_svg(p)
    except InputError as exc:
        raise ValueError(f"sketch_svg: {exc}") from None
    lines = [np.vstack([pts, pts[:1]]) if closed else pts for pts, closed in drawing.polylines if len(pts) >= 2]
    if not lines:
        raise ValueError(f"sketch_svg: {p.name} has no stroke (no path, line or shape with two points)")
    vx, vy, vw, vh = drawing.viewbox
    x0, x1, y0, y1 = bounds
    return [np.column_stack([x0 + (s[:, 0] - vx) / vw * (x1 - x0), y1 - (s[:, 1] - vy) / vh * (y1 - y0)])
            for s in lines]


def mark_vertices(topo: Topology, strokes: list[np.ndarray], c_t: float) -> np.ndarray:
    """Boolean mask of the vertices the snake must engulf before normal growth."""
    import matplotlib.tri as mtri
    from scipy.spatial import cKDTree

    step = 0.25 * topo.min_edge
    samples = []
    for s in strokes:
        seg = np.diff(s, axis=0)
        for a, d in zip(s[:-1], seg):
            n = max(1, int(np.ceil(np.hypot(*d) / step)))
            samples.append(a + np.linspace(0.0, 1.0, n + 1)[:, None] * d)
    pts = np.vstack(samples)
    tri = mtri.Triangulation(topo.points[:, 0], topo.points[:, 1], topo.faces)
    hit = tri.get_trifinder()(pts[:, 0], pts[:, 1])
    marked = np.zeros(topo.n_vertices, bool)
    marked[topo.faces[hit[hit >= 0]].ravel()] = True
    if c_t > 0:
        near = cKDTree(topo.points).query_ball_point(pts, c_t * topo.mean_edge)
        idx = np.fromiter((j for lst in near for j in lst), np.int64)
        marked[idx] = True
    return marked
