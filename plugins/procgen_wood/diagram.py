"""Construction diagram of the 3DSCA cells of a flat patch of triangles (thesis Figs 3.20-3.29).

Each triangle's square grid (COMP-IN cells light, PART-IN cells darker, as the thesis's filled and
open marks of Fig. 3.23b), the triangle edges, and every neighbour link that crosses a facet edge:
with ``neighbours = "pairs"`` the thesis's single nearest-projection partner per edge cell (Figs
3.26-3.29), with ``"unfold"`` the unfolded Moore slots.  Drawn in the mesh's x-y plane, so the
patch should lie flat (the diagram shows the projection otherwise).
"""
from __future__ import annotations

from typing import Any

import numpy as np

from procgen import Exporter, InputError
from procgen_surface.domain import SurfaceCells


def cells_svg(domain: Any, *, stem: str = "", provenance: dict | None = None, width: float = 640.0,
              max_cells: int = 20000) -> bytes:
    """SVG of the cell grids and cross-edge links of a (flat) SurfaceCells patch."""
    import svgwrite

    if not isinstance(domain, SurfaceCells):
        raise InputError(f"cells_svg: expected a SurfaceCells domain, got {domain.kind}")
    sc = domain
    if sc.n_cells > max_cells:
        raise InputError(f"cells_svg: {sc.n_cells:,} cells is too many to draw (max_cells = {max_cells:,})")
    lay = sc.layout
    poly, cnt = lay.cell_polygons()
    pts = [lay.frames.to_3d(np.full(int(k), f), p[:int(k)])[:, :2] for p, k, f in zip(poly, cnt, sc.face)]
    lo, hi = sc.vertices[:, :2].min(0), sc.vertices[:, :2].max(0)
    scale = width / max(float((hi - lo).max()), 1e-12)
    pad = 10.0
    height = float((hi - lo)[1]) * scale + 2 * pad

    def xy(p: np.ndarray) -> list[tuple[float, float]]:
        q = (np.atleast_2d(p) - lo) * scale
        return [(round(float(a) + pad, 2), round(height - pad - float(b), 2)) for a, b in q]

    dwg = svgwrite.Drawing(size=(f"{width + 2 * pad:.0f}px", f"{height:.0f}px"), profile="tiny")
    dwg.add(dwg.rect((0, 0), (width + 2 * pad, height), fill="white"))
    for p, inside in zip(pts, sc.comp_in):
        dwg.add(dwg.polygon(xy(p), fill="#e9d3b0" if inside else "#b98d5c", stroke="#7a5a3a",
                            stroke_width=0.4))
    for f in sc.faces:
        dwg.add(dwg.polygon(xy(sc.vertices[f][:, :2]), fill="none", stroke="#1b1b1b", stroke_width=1.6))
    g = sc.graph
    if g.cross is not None:
        pairs = np.unique(np.sort(np.column_stack([g.rows[g.cross], g.indices[g.cross]]), axis=1), axis=0)
        for a, b in pairs:                       # each link once, whether one-way or both ways
            dwg.add(dwg.line(*xy(sc.center3d[[a, b], :2]), stroke="#c0392b", stroke_width=0.9))
    return dwg.tostring().encode()


EXPORTERS = [Exporter(name="cells_svg", kinds=("SurfaceCells",), suffix=".svg", func=cells_svg,
                      doc="diagram of flat 3DSCA cell grids and cross-edge links (thesis Figs 3.20-3.29)")]
