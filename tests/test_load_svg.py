"""The SVG reader against analytic positions on a drawing in the shape Inkscape 1.x writes."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.spatial import cKDTree

from procgen.errors import InputError
from procgen.exchange.svg_read import read_svg, svg_polylines

FIXTURE = Path(__file__).parent / "data" / "inkscape_layers.svg"


def _cubic(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    t = t[:, None]
    return ((1 - t) ** 3 * p[0] + 3 * (1 - t) ** 2 * t * p[1] + 3 * (1 - t) * t ** 2 * p[2]
            + t ** 3 * p[3])


def _dist_to_curve(q: np.ndarray, dense: np.ndarray) -> np.ndarray:
    return cKDTree(dense).query(q)[0]


def _by_kind(lines):
    """(bezier stroke, circle, rect) from the fixture, told apart by shape not by order."""
    opened = [p for p, c in lines if not c]
    rings = sorted((p for p, c in lines if c), key=len)
    assert len(opened) == 1 and len(rings) == 2
    return opened[0], rings[1], rings[0]


def test_layers_transforms_arcs_and_beziers_land_where_the_geometry_says():
    tol = 0.01
    drawing = read_svg(FIXTURE, tolerance=tol)
    assert drawing.viewbox == (0.0, 0.0, 100.0, 60.0)
    assert drawing.mm_per_unit == pytest.approx(1.0)
    assert len(drawing.polylines) == 3            # the display:none layer is not drawn
    stroke, circle, rect = _by_kind(drawing.polylines)

    # Bezier "m 30,40 c 10,-10 30,10 40,0" under the layer's translate(-20,-30)
    ctrl = np.array([[10.0, 10.0], [20.0, 0.0], [40.0, 20.0], [50.0, 10.0]])
    dense = _cubic(ctrl, np.linspace(0, 1, 200001))
    np.testing.assert_allclose(stroke[0], ctrl[0], atol=1e-9)
    np.testing.assert_allclose(stroke[-1], ctrl[3], atol=1e-9)
    assert _dist_to_curve(stroke, dense).max() < 1e-3          # vertices lie on the curve
    mids = 0.5 * (stroke[1:] + stroke[:-1])
    assert _dist_to_curve(mids, dense).max() <= tol            # chords stay within tolerance
    assert len(stroke) > 5

    # four arcs drawing a circle of radius 10 at (80, 60) - (20, 30)
    r = np.linalg.norm(circle - [60.0, 30.0], axis=1)
    np.testing.assert_allclose(r, 10.0, atol=1e-9)
    ring = np.vstack([circle, circle[:1]])
    sag = 10.0 - np.linalg.norm(0.5 * (ring[1:] + ring[:-1]) - [60.0, 30.0], axis=1)
    assert sag.max() <= tol and sag.max() > tol / 4           # flattened no finer than needed
    ang = np.unwrap(np.arctan2(circle[:, 1] - 30.0, circle[:, 0] - 60.0))
    assert ang[-1] - ang[0] > 0                                 # y-down file order kept (clockwise on paper)

    # rect 10 x 4 in a sub-layer with matrix(0,1,-1,0,50,60), inside translate(-20,-30)
    expect = {(30.0, 30.0), (30.0, 40.0), (26.0, 40.0), (26.0, 30.0)}
    assert {tuple(np.round(p, 9)) for p in rect} == expect and len(rect) == 4


def test_tolerance_sets_the_chord_count_like_the_sagitta_bound():
    coarse = _by_kind(svg_polylines(FIXTURE, tolerance=0.1))[1]
    fine = _by_kind(svg_polylines(FIXTURE, tolerance=0.001))[1]
    # sagitta r(1 - cos(theta/2)) ~ r theta^2 / 8: n grows like 1/sqrt(tol)
    assert len(fine) / len(coarse) == pytest.approx(np.sqrt(100.0), rel=0.15)


def test_bytes_and_file_give_the_same_lines():
    a = svg_polylines(FIXTURE, tolerance=0.05)
    b = svg_polylines(FIXTURE.read_bytes(), tolerance=0.05)
    assert len(a) == len(b)
    for (pa, ca), (pb, cb) in zip(a, b):
        assert ca == cb and np.array_equal(pa, pb)


def test_units_and_viewbox_scale():
    doc = (b'<svg xmlns="http://www.w3.org/2000/svg" width="4in" height="2in" viewBox="-100 0 400 200">'
           b'<circle cx="0" cy="100" r="50"/><path d="M -100 0 H 300" transform="scale(1 2)"/></svg>')
    d = read_svg(doc, tolerance=0.01)
    assert d.viewbox == (-100.0, 0.0, 400.0, 200.0)
    assert d.mm_per_unit == pytest.approx(4 * 25.4 / 400)
    circle = next(p for p, c in d.polylines if c)
    np.testing.assert_allclose(np.linalg.norm(circle - [0.0, 100.0], axis=1), 50.0, atol=1e-9)
    line = next(p for p, c in d.polylines if not c)
    np.testing.assert_allclose(line, [[-100.0, 0.0], [300.0, 0.0]], atol=1e-9)
    # lengths with units inside the drawing are CSS px in user space: 1in = 96 user units
    px = read_svg(b'<svg xmlns="http://www.w3.org/2000/svg"><rect width="1in" height="10mm"/></svg>')
    rect = px.polylines[0][0]
    np.testing.assert_allclose(rect.max(axis=0), [96.0, 96.0 / 25.4 * 10], rtol=1e-6)
    assert px.mm_per_unit is None
    np.testing.assert_allclose(px.viewbox, [0.0, 0.0, 96.0, 96.0 / 25.4 * 10], rtol=1e-6)


def test_not_svg_is_one_line_naming_the_file(tmp_path):
    bad = tmp_path / "logo.svg"
    bad.write_bytes(b"\x89PNG\r\n\x1a\n not an svg")
    with pytest.raises(InputError, match=r"logo\.svg") as e:
        read_svg(bad)
    assert "\n" not in str(e.value)
    with pytest.raises(InputError, match="not found"):
        read_svg(tmp_path / "missing.svg")
