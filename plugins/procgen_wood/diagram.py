"""Construction diagrams of the 3DSCA cells (thesis Figs 3.20-3.29).

``triangle_svg``: one triangle in its own 2-D frame, labelled as the thesis's Figs 3.20-3.23 are
(A at the origin, AB vertical, L the foot with CL parallel to AB and AL perpendicular to it, the
grid rectangle APQR, the first cell centres Y_00, Y_01, Y_10 and the cell size l_cell), every grid
square marked at its centre as Cell_In (filled dot: centre inside), Cell_Part (open circle: centre
outside, the triangle still covers part of the cell) or Cell_Out (circled cross: no cell).

``cells_svg``: a flat patch of triangles. Each triangle's square grid (COMP-IN cells light, PART-IN cells darker, as the thesis's filled and
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


def triangle_svg(domain: Any, *, stem: str = "", provenance: dict | None = None, face: int = 0,
                 width: float = 560.0, max_cells: int = 2500) -> bytes:
    """SVG of one triangle's cell grid with the thesis's labels and Cell_In/Part/Out marks."""
    import svgwrite

    if not isinstance(domain, SurfaceCells):
        raise InputError(f"triangle_svg: expected a SurfaceCells domain, got {domain.kind}")
    sc = domain
    if not 0 <= face < sc.n_faces or not sc.valid[face]:
        raise InputError(f"triangle_svg: face {face} is not a (non-degenerate) face of the mesh")
    lay, s = sc.layout, sc.size
    nx, ny = int(lay.nx[face]), int(lay.ny[face])
    if nx * ny > max_cells:
        raise InputError(f"triangle_svg: {nx * ny:,} grid squares is too many to label (max_cells = {max_cells:,})")
    c2 = lay.frames.corners2d[face]
    a_k = int(np.argmin(np.abs(c2).sum(axis=1)))               # A sits at (0, 0), B at (0, |AB|)
    b_k = int(np.argmin(np.where(np.arange(3) == a_k, np.inf, np.abs(c2[:, 0]))))
    A, B, C = c2[a_k], c2[b_k], c2[3 - a_k - b_k]
    P, R, Q, L = np.array([0.0, ny * s]), np.array([nx * s, 0.0]), np.array([nx * s, ny * s]), np.array([C[0], 0.0])
    pad, font = 46.0, 15
    scale = width / max(nx * s, ny * s)
    height = ny * s * scale + 2 * pad + 30

    def xy(p: np.ndarray) -> tuple[float, float]:
        return round(pad + float(p[0]) * scale, 2), round(height - pad - 30 - float(p[1]) * scale, 2)

    dwg = svgwrite.Drawing(size=(f"{width + 2 * pad:.0f}px", f"{height:.0f}px"), profile="full")
    dwg.add(dwg.rect((0, 0), (width + 2 * pad, height), fill="white"))
    grid = dwg.g(stroke="#9a8a78", stroke_width=0.7)
    for i in range(nx + 1):
        grid.add(dwg.line(xy(np.array([i * s, 0.0])), xy(np.array([i * s, ny * s]))))
    for j in range(ny + 1):
        grid.add(dwg.line(xy(np.array([0.0, j * s])), xy(np.array([nx * s, j * s]))))
    dwg.add(grid)
    dwg.add(dwg.polygon([xy(A), xy(P), xy(Q), xy(R)], fill="none", stroke="#2c6fbb", stroke_width=1.6,
                        stroke_dasharray="6,4"))
    dwg.add(dwg.polygon([xy(A), xy(B), xy(C)], fill="#f3e2c4", fill_opacity=0.55, stroke="#1b1b1b", stroke_width=2.2))
    dwg.add(dwg.line(xy(C), xy(L), stroke="#555", stroke_width=1.2, stroke_dasharray="3,3"))
    ii, jj = np.meshgrid(np.arange(nx), np.arange(ny), indexing="ij")
    cell = lay.cell_at(np.full(ii.size, face), ii.ravel(), jj.ravel())
    centre = (np.column_stack([ii.ravel(), jj.ravel()]) + 0.5) * s
    r = max(2.0, 0.18 * s * scale)
    marks = dwg.g(stroke="#1b1b1b", stroke_width=1.1)
    for (cx, cy), c in zip((xy(p) for p in centre), cell):
        if c >= 0 and sc.comp_in[c]:
            marks.add(dwg.circle((cx, cy), r, fill="#1b1b1b"))                       # Cell_In
        elif c >= 0:
            marks.add(dwg.circle((cx, cy), r, fill="white"))                         # Cell_Part
        else:
            marks.add(dwg.circle((cx, cy), r, fill="none", stroke="#b03a2e"))        # Cell_Out
            d = r * 0.7071
            marks.add(dwg.line((cx - d, cy - d), (cx + d, cy + d), stroke="#b03a2e"))
            marks.add(dwg.line((cx - d, cy + d), (cx + d, cy - d), stroke="#b03a2e"))
    dwg.add(marks)
    halo = dwg.g(font_family="sans-serif", fill="white", stroke="white", stroke_width=4)   # under the labels
    text = dwg.g(font_family="sans-serif", fill="#1b1b1b")

    def label(words: str, at: tuple[float, float], size: int, colour: str, bold: bool = False) -> None:
        for g in (halo, text):
            g.add(dwg.text(words, insert=at, font_size=size, font_weight="bold" if bold else "normal",
                           **({} if g is halo else {"fill": colour})))

    for name, p, (dx, dy) in (("A", A, (-16, 16)), ("B", B, (-18, 12)), ("C", C, (10, 5)), ("L", L, (4, 16)),
                              ("P", P, (-18, -8)), ("Q", Q, (6, -6)), ("R", R, (6, 16))):
        x, y = xy(p)
        label(name, (x + dx, y + dy), font, "#1b1b1b", bold=True)
    for name, (i, j) in (("Y00", (0, 0)), ("Y01", (0, 1)), ("Y10", (1, 0))):
        if i < nx and j < ny:
            x, y = xy((np.array([i, j]) + 0.5) * s)
            label(name, (x + r + 1, y - r - 1), font - 3, "#2c6fbb")
    x0, y0 = xy(np.array([0.0, 0.0]))
    x1, _ = xy(np.array([s, 0.0]))
    dwg.add(dwg.line((x0, y0 + 6), (x1, y0 + 6), stroke="#2c6fbb", stroke_width=1.2))
    label("l_cell", (x0, y0 + 20), font - 3, "#2c6fbb")
    dwg.add(halo)
    dwg.add(text)
    n_in, n_part = int(np.sum((cell >= 0) & sc.comp_in[np.maximum(cell, 0)])), int(np.sum(cell >= 0))
    legend = (f"\u25cf Cell_In: centre inside ({n_in})   \u25cb Cell_Part: overlaps ({n_part - n_in})   "
              f"\u2297 Cell_Out: no cell ({int(np.sum(cell < 0))})")
    dwg.add(dwg.text(legend, insert=(pad, height - 12), font_family="sans-serif", font_size=font - 2, fill="#1b1b1b"))
    return dwg.tostring().encode()


EXPORTERS = [Exporter(name="triangle_svg", kinds=("SurfaceCells",), suffix=".svg", func=triangle_svg,
                      doc="one triangle's cell grid labelled as the thesis's Figs 3.20-3.23 (A B C L P Q R, "
                          "Cell_In / Cell_Part / Cell_Out marks)"),
             Exporter(name="cells_svg", kinds=("SurfaceCells",), suffix=".svg", func=cells_svg,
                      doc="diagram of flat 3DSCA cell grids and cross-edge links (thesis Figs 3.20-3.29)")]
