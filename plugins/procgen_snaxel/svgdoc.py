"""SVG pages as vector artists and plotters use them: y-down, viewBox from 0 0, real units, layers.

The model is y-up (the thesis's screen). The core's generic SVG writer flips a group with
``scale(1,-1)``, so Inkscape shows flipped node coordinates and a plotter sees a transform; here
the flip is applied to the coordinates themselves instead: x' = x - x0, y' = y1 - y, so the
viewBox is ``0 0 W H`` in domain units and ``width``/``height`` carry the physical size (px or
mm). Every drawing group is an Inkscape layer (``inkscape:groupmode="layer"``) with a label,
which Inkscape lists in its Layers panel and vpype reads as one layer each.
"""
from __future__ import annotations

from typing import Any

import numpy as np
import svgwrite

from procgen import InputError, Polylines
from procgen.exchange.svg import fmt_number, paths_data, svg_decimals

INKSCAPE_NS = "http://www.inkscape.org/namespaces/inkscape"
UNITS = ("px", "mm")


class Page:
    """One SVG document over a model box (x0, x1, y0, y1) with y-down coordinates."""

    def __init__(self, box: tuple[float, float, float, float], width: float, units: str = "px") -> None:
        if units not in UNITS:
            raise InputError(f"svg units = {units!r}: expected one of {', '.join(UNITS)}")
        if not width > 0:
            raise InputError(f"svg width = {width!r}: expected a number > 0")
        x0, x1, y0, y1 = box
        self.box = box
        self.w, self.h = float(x1 - x0), float(y1 - y0)
        height = width * self.h / self.w
        self.dwg = svgwrite.Drawing(size=(f"{fmt_number(width)}{units}", f"{fmt_number(height)}{units}"),
                                    profile="full", debug=False)
        self.dwg["viewBox"] = f"0 0 {fmt_number(self.w)} {fmt_number(self.h)}"
        self.dwg.attribs["xmlns:inkscape"] = INKSCAPE_NS
        self.unit = self.w / width       # domain units per output unit (px or mm)
        #: the page's path precision, declared once: 1/10000 of its larger side (issue 34)
        self.decimals = svg_decimals(max(self.w, self.h))
        self._layers = 0

    def xy(self, pts: np.ndarray) -> np.ndarray:
        """Model (y-up) points -> page (y-down) points."""
        x0, _, _, y1 = self.box
        return np.column_stack([pts[:, 0] - x0, y1 - pts[:, 1]])

    def d(self, pts: np.ndarray, closed: bool = True) -> str:
        """Path data of model points at the page's precision."""
        return self.ds([pts], closed)[0]

    def ds(self, lines: list[np.ndarray], closed: bool | list[bool] = True, *, page: bool = False) -> list[str]:
        """Path data of many lines in one formatting pass (model points, or page points with ``page``)."""
        return paths_data(lines if page else [self.xy(p) for p in lines], closed, self.decimals)

    def layer(self, label: str, **attrs: Any) -> svgwrite.container.Group:
        """A new top-level Inkscape layer (drawn above the previous ones)."""
        self._layers += 1
        g = self.dwg.g(id=f"layer{self._layers}", **attrs)
        g["inkscape:groupmode"] = "layer"
        g["inkscape:label"] = label
        self.dwg.add(g)
        return g

    def sublayer(self, parent: svgwrite.container.Group, label: str, ident: str) -> svgwrite.container.Group:
        """A layer nested in ``parent`` (Inkscape lists it under the parent in its Layers panel)."""
        g = parent.add(self.dwg.g(id=ident))
        g["inkscape:groupmode"] = "layer"
        g["inkscape:label"] = label
        return g

    def sky(self, colour: str | None) -> None:
        """An optional background rectangle on a layer of its own ("sky")."""
        if colour:
            self.layer("sky").add(self.dwg.rect(insert=(0, 0), size=(fmt_number(self.w), fmt_number(self.h)),
                                                fill=colour))


def curve_pieces(pts: np.ndarray, cv: np.ndarray) -> list[tuple[int, np.ndarray]]:
    """(curve id, points) of each curve of a closed contour, each including the joint to the next."""
    n = len(pts)
    starts = np.flatnonzero(cv != np.roll(cv, 1))
    if len(starts) == 0:
        starts = np.array([0])
    out = []
    for k, s in enumerate(starts):
        e = starts[(k + 1) % len(starts)]
        idx = np.arange(s, (e if e > s else e + n) + 1) % n
        out.append((int(cv[s]), pts[idx]))
    return out


def need(domain: Any, what: str, field: str | None = None) -> Polylines:
    """The Polylines a snaxel rule made (with ``field``), else a one-line InputError."""
    if not isinstance(domain, Polylines):
        raise InputError(f"{what}: expected the Polylines a snaxel rule made, got {domain.kind}")
    if field is not None and field not in domain:
        raise InputError(f"{what}: domain has no field {field!r} (export the snaxel.grow/cloudscape output)")
    return domain


def domain_box(domain: Polylines) -> tuple[float, float, float, float]:
    """The page box (x0, x1, y0, y1): the domain's bounds, else its points' box."""
    if domain.bounds is not None:
        return domain.bounds
    (x0, y0), (x1, y1) = domain.points.min(0), domain.points.max(0)
    return (float(x0), float(x1), float(y0), float(y1))


def mix(a: str, b: str, t: float) -> str:
    """Colour a moved by t (0..1) towards colour b (#rrggbb)."""
    ca = np.array([int(a[i:i + 2], 16) for i in (1, 3, 5)], float)
    cb = np.array([int(b[i:i + 2], 16) for i in (1, 3, 5)], float)
    c = np.clip(np.round((1 - t) * ca + t * cb), 0, 255).astype(int)
    return "#%02x%02x%02x" % tuple(c)
