"""Sketch mode (thesis section 3.5.3): strokes mark tessellation triangles the snake engulfs first.

Strokes come from the recipe (flat [x0, y0, x1, y1, ...] lists in domain units) or from the
paths of an SVG file (Inkscape); the SVG's viewBox is mapped onto the domain, y flipped.
Marked = the corners of every triangle a stroke passes through, dilated by c_t mean edge
lengths (ambiguity A21: c_t = 1 adds about one ring of vertices).
"""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np

from .topology import Topology

_CMD = re.compile(r"([MmLlHhVvCcSsQqTtAaZz])|([-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)")


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


def _bezier(p: np.ndarray, n: int = 16) -> np.ndarray:
    t = np.linspace(0.0, 1.0, n + 1)[1:, None]
    if len(p) == 3:
        return (1 - t) ** 2 * p[0] + 2 * (1 - t) * t * p[1] + t ** 2 * p[2]
    return (1 - t) ** 3 * p[0] + 3 * (1 - t) ** 2 * t * p[1] + 3 * (1 - t) * t ** 2 * p[2] + t ** 3 * p[3]


def parse_path_d(d: str) -> list[np.ndarray]:
    """SVG path data -> polylines (curves sampled, arcs as chords); one polyline per subpath."""
    tokens = [(m.group(1), m.group(2)) for m in _CMD.finditer(d)]
    out: list[list[np.ndarray]] = []
    cur = np.zeros(2)
    start = np.zeros(2)
    last_ctrl = None
    i, cmd = 0, None

    def take(k: int) -> list[float]:
        nonlocal i
        vals = []
        while len(vals) < k:
            if i >= len(tokens) or tokens[i][0]:
                raise ValueError(f"SVG path: command {cmd} needs {k} numbers")
            vals.append(float(tokens[i][1]))
            i += 1
        return vals

    while i < len(tokens):
        if tokens[i][0]:
            cmd = tokens[i][0]
            i += 1
            if cmd in "Zz":
                if out and len(out[-1]):
                    out[-1].append(start.copy())
                cur = start.copy()
                continue
        elif cmd is None:
            raise ValueError("SVG path: data does not start with a command")
        rel = cmd.islower()
        c = cmd.upper()
        base = cur if rel else np.zeros(2)
        if c == "M":
            cur = base + take(2)
            start = cur.copy()
            out.append([cur.copy()])
            cmd = "l" if rel else "L"
            continue
        if not out:
            out.append([cur.copy()])
        pts = out[-1]
        if c == "L":
            cur = base + take(2)
            pts.append(cur.copy())
        elif c == "H":
            x = take(1)[0]
            cur = np.array([cur[0] + x if rel else x, cur[1]])
            pts.append(cur.copy())
        elif c == "V":
            y = take(1)[0]
            cur = np.array([cur[0], cur[1] + y if rel else y])
            pts.append(cur.copy())
        elif c in "CSQT":
            k = {"C": 6, "S": 4, "Q": 4, "T": 2}[c]
            v = np.asarray(take(k)).reshape(-1, 2) + base
            if c in "ST":
                refl = 2 * cur - last_ctrl if last_ctrl is not None else cur.copy()
                v = np.vstack([refl, v])
            ctrl = np.vstack([cur, v])
            pts.extend(_bezier(ctrl))
            last_ctrl = ctrl[-2]
            cur = ctrl[-1].copy()
            continue
        elif c == "A":
            v = take(7)
            cur = base + v[5:7]
            pts.append(cur.copy())
        last_ctrl = None
    return [np.asarray(p) for p in out if len(p) >= 2]


def strokes_from_svg(path: str | Path, bounds: tuple[float, float, float, float]) -> list[np.ndarray]:
    """Every <path>, <polyline>, <line> of an SVG file, mapped from its viewBox to the domain."""
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"sketch_svg: file {str(path)!r} not found")
    try:
        root = ET.parse(p).getroot()
    except ET.ParseError as exc:
        raise ValueError(f"sketch_svg: {p.name} is not valid XML ({exc})") from None
    strokes: list[np.ndarray] = []
    for el in root.iter():
        tag = el.tag.rsplit("}", 1)[-1]
        if tag == "path" and el.get("d"):
            strokes += parse_path_d(el.get("d", ""))
        elif tag == "polyline" and el.get("points"):
            nums = [float(x) for x in re.split(r"[\s,]+", el.get("points", "").strip()) if x]
            if len(nums) >= 4:
                strokes.append(np.asarray(nums[: len(nums) // 2 * 2]).reshape(-1, 2))
        elif tag == "line":
            strokes.append(np.array([[float(el.get(a, 0)) for a in ("x1", "y1")],
                                     [float(el.get(a, 0)) for a in ("x2", "y2")]]))
    if not strokes:
        raise ValueError(f"sketch_svg: {p.name} has no path, polyline or line to use as a stroke")
    vb = root.get("viewBox")
    if vb:
        vx, vy, vw, vh = (float(x) for x in re.split(r"[\s,]+", vb.strip()))
    else:
        vx, vy = 0.0, 0.0
        vw = float(re.sub(r"[a-z]+$", "", root.get("width", "0")) or 0)
        vh = float(re.sub(r"[a-z]+$", "", root.get("height", "0")) or 0)
        if vw <= 0 or vh <= 0:
            allp = np.vstack(strokes)
            vx, vy = allp.min(0)
            vw, vh = np.maximum(allp.max(0) - allp.min(0), 1e-9)
    x0, x1, y0, y1 = bounds
    return [np.column_stack([x0 + (s[:, 0] - vx) / vw * (x1 - x0), y1 - (s[:, 1] - vy) / vh * (y1 - y0)])
            for s in strokes]


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
