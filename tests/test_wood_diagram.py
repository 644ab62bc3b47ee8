"""The labelled one-triangle diagram (thesis Figs 3.20-3.23): every grid square of APQR marked
Cell_In / Cell_Part / Cell_Out as an independent geometric test says, and the thesis's labels."""
from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import shapely

from procgen_surface.domain import SurfaceCells
from procgen_wood.diagram import triangle_svg

NS = "{http://www.w3.org/2000/svg}"


def test_marks_and_labels_of_the_triangle_grid():
    v = np.array([[0, 0, 0], [0.35, 1, 0], [1, 0.3, 0]], float)       # rules/weathering/triangle.obj
    s = 0.0833
    sc = SurfaceCells.from_mesh(v, np.array([[0, 1, 2]]), cell_size=s)
    root = ET.fromstring(triangle_svg(sc))
    circles = root.findall(f".//{NS}circle")
    filled = sum(c.get("fill") == "#1b1b1b" for c in circles)
    open_ = sum(c.get("fill") == "white" for c in circles)
    crossed = sum(c.get("fill") == "none" for c in circles)
    # independent reference in the triangle's own frame: A = (0, 0), AB along +y, C to the right
    c2 = sc.corners2d[0]
    tri = shapely.Polygon(c2)
    nx, ny = int(sc.nx[0]), int(sc.ny[0])
    assert (nx, ny) == (int(np.ceil(c2[:, 0].max() / s)), int(np.ceil(c2[:, 1].max() / s)))   # APQR covers ABC
    squares = [shapely.box(i * s, j * s, (i + 1) * s, (j + 1) * s) for i in range(nx) for j in range(ny)]
    inside = np.array([tri.contains(sq.centroid) for sq in squares])
    overlaps = np.array([tri.intersection(sq).area > 1e-12 for sq in squares])
    assert filled == inside.sum() > 0
    assert open_ == (overlaps & ~inside).sum() > 0
    assert crossed == (~overlaps).sum() > 0 and filled + open_ + crossed == nx * ny
    words = [t.text for t in root.iter(f"{NS}text")]
    for name in ("A", "B", "C", "L", "P", "Q", "R", "Y00", "Y01", "Y10", "l_cell"):
        assert name in words
    legend = words[-1]
    assert f"({filled})" in legend and f"({open_})" in legend and f"({crossed})" in legend
