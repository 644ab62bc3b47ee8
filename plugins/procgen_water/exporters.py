"""Exporters of the water family: drops as SVG (plate D-3: arrows vs half-spheres)."""
from __future__ import annotations

from typing import Any

import numpy as np

from procgen import Exporter, InputError, PointSet, portable


def drops_svg(domain: PointSet, *, stem: str = "", provenance: dict[str, Any] | None = None,
              scale: float = 4.0, arrow_gain: float = 6.0, max_drops: int = 20000,
              background: str = "#10141c") -> bytes:
    """Moving drops as velocity arrows, stabilised drops as shaded half-spheres (radius ~ V^1/3).

    ``scale`` is pixels per length unit; at most ``max_drops`` drops are drawn (every k-th, so
    the choice is deterministic).  North is up, as in the raster outputs.
    """
    if not isinstance(domain, PointSet) or "drop__moving" not in domain:
        raise InputError("drops_svg: expected the drops PointSet written by water.drops")
    if domain.bounds is None:
        raise InputError("drops_svg: the drops PointSet has no bounds")
    x0, x1, y0, y1 = domain.bounds
    w, h = (x1 - x0) * scale, (y1 - y0) * scale
    pts = domain.points[:, :2]
    k = max(1, int(np.ceil(len(pts) / max(max_drops, 1))))
    sel = np.arange(0, len(pts), k)
    px = (pts[sel, 0] - x0) * scale
    py = h - (pts[sel, 1] - y0) * scale
    mov = np.asarray(domain["drop__moving"], bool)[sel]
    vel = np.asarray(domain["drop__velocity"], float)[sel]
    vol = np.asarray(domain["drop__volume"], float)[sel]
    wet = vol > 0
    r = np.where(wet, portable.cbrt(np.where(wet, vol, 1.0) * 3 / (4 * np.pi)), 0.0) * scale * 0.8
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w:.0f}" height="{h:.0f}" '
           f'viewBox="0 0 {w:.2f} {h:.2f}">',
           "<defs><radialGradient id='dome' cx='35%' cy='35%' r='65%'>"
           "<stop offset='0%' stop-color='#ffffff'/><stop offset='35%' stop-color='#7fb2ff'/>"
           "<stop offset='100%' stop-color='#1d3f8c'/></radialGradient>"
           "<marker id='tip' viewBox='0 0 6 6' refX='5' refY='3' markerWidth='4' markerHeight='4' "
           "orient='auto'><path d='M0,0 L6,3 L0,6 z' fill='#ffd966'/></marker></defs>",
           f'<rect width="100%" height="100%" fill="{background}"/>']
    for i in np.flatnonzero(~mov):
        out.append(f'<circle cx="{px[i]:.2f}" cy="{py[i]:.2f}" r="{max(r[i], 0.6):.2f}" fill="url(#dome)"/>')
    ex = px + vel[:, 0] * scale * arrow_gain
    ey = py - vel[:, 1] * scale * arrow_gain
    for i in np.flatnonzero(mov):
        out.append(f'<line x1="{px[i]:.2f}" y1="{py[i]:.2f}" x2="{ex[i]:.2f}" y2="{ey[i]:.2f}" '
                   'stroke="#ffd966" stroke-width="0.8" marker-end="url(#tip)"/>')
    out.append("</svg>\n")
    return "\n".join(out).encode()


EXPORTERS = [Exporter(name="drops_svg", kinds=("PointSet",), suffix=".svg", func=drops_svg,
                      doc="water drops: arrows (moving) and half-spheres (stabilised)",
                      options=("scale", "arrow_gain", "max_drops", "background"))]
