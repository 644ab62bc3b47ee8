"""Compact SVG path data (issue 34): relative moves from rounded absolute coordinates, decoded by
svgelements (the reader vpype and our own SVG loader use) back to the input within half the
drawing's resolution, with no drift along long lines; the text is minimal and deterministic."""
from __future__ import annotations

import re

import numpy as np
import pytest
from _svg_path import decode

from procgen import InputError
from procgen.exchange.svg import RESOLUTION, fmt_number, path_data, paths_data, svg_decimals


def test_decimals_follow_the_drawing_size():
    # a unit square keeps the 4 decimals it had; a 700-unit cloud page gets 2; always finer than 1/10000
    assert [svg_decimals(e) for e in (1.0, 10.0, 700.0, 726.9, 1000.0, 5000.0, 1e5)] == [4, 3, 2, 2, 1, 1, 0]
    for e in (0.013, 0.5, 1.0, 3.7, 99.0, 700.0, 2.5e4):
        k = svg_decimals(e)
        assert 10.0 ** -k <= RESOLUTION * e < 10.0 ** (1 - k)       # the fewest decimals that resolve it


@pytest.mark.parametrize("extent", [1.0, 726.9, 0.02])
def test_a_long_random_walk_decodes_without_drift(extent):
    """100,000 small steps round and round through negative and positive coordinates: every decoded point (the
    sum of all relative moves before it) is within half a resolution step of its input."""
    rng = np.random.default_rng(34)
    t = np.linspace(0.0, 6 * np.pi, 100_000)
    pts = 0.45 * extent * np.column_stack([np.cos(t), np.sin(1.3 * t)]) + rng.normal(0.0, 1e-4 * extent, (len(t), 2))
    assert (pts < 0).any() and (pts > 0).any()
    k = svg_decimals(extent)
    d = path_data(pts, False, k)
    (got, closed), = decode(d)
    assert not closed and got.shape == pts.shape
    assert np.abs(got - pts).max() <= 0.5 * 10.0 ** -k * (1 + 1e-6) + 1e-9 * extent
    # a relative writer that rounded each move instead would be off by far more at the end
    naive = np.cumsum(np.round(np.diff(pts, axis=0), k), axis=0)[-1] + np.round(pts[0], k)
    assert abs(naive - pts[-1]).max() > 10 * 10.0 ** -k


def test_many_lines_in_one_pass_match_one_at_a_time_and_decode():
    rng = np.random.default_rng(5)
    lines = [rng.uniform(-400, 700, (n, 2)) for n in (0, 1, 2, 7, 300)]
    closed = [False, True, False, True, False]
    batch = paths_data(lines, closed, 2)
    assert batch == [path_data(p, c, 2) for p, c in zip(lines, closed)]
    assert batch[0] == "" and batch[1].startswith("M") and batch[1].endswith("z")
    for p, c, d in zip(lines[1:], closed[1:], batch[1:]):
        (got, was_closed), = decode(d)
        assert was_closed == c and np.abs(got - p).max() <= 0.005 + 1e-9
    # joined subpaths (a wireframe) decode to the same lines: each starts with an absolute M
    joined = decode("".join(batch[2:]))
    assert [len(g) for g, _ in joined] == [2, 7, 300]


def test_text_is_minimal_and_deterministic():
    pts = np.array([[0.5, 0.25], [-0.1, 0.3], [12.0, -3.00004], [0.0, 0.0], [1e-5, -4e-5], [-0.00004, 2.0]])
    d = path_data(pts, True, 4)
    assert d == "M.5,.25l-.6,.05 12.1-3.3-12,3 0,0 0,2z"
    assert path_data(pts, True, 4) == d
    numbers = re.findall(r"-?\d*\.?\d+", d)
    assert not any(n in ("-0", "-.0") or re.match(r"-?0\d|-?0\.", n) or re.search(r"\.\d*0$", n) for n in numbers)
    assert d.count("l") == 1 and d.count("M") == 1 and "L" not in d and ", " not in d and " -" not in d
    # whole numbers and page-sized coordinates at 2 decimals
    assert path_data(np.array([[700.0, 0.004], [100.0, -0.004]]), False, 2) == "M700,0l-600,0"
    assert fmt_number(-0.00001) == "0" and fmt_number(2.5, 0) == "2" and fmt_number(3.14159, 2) == "3.14"


def test_non_finite_and_oversized_coordinates_are_refused():
    with pytest.raises(InputError, match="not a finite number"):
        path_data(np.array([[0.0, 0.0], [np.nan, 1.0]]), False, 2)
    with pytest.raises(InputError, match="too large"):
        path_data(np.array([[0.0, 0.0], [1e17, 1.0]]), False, 4)


def test_cloud_pages_write_two_decimals_and_decode_to_their_outline():
    """The snaxel page (y-down, viewBox from 0 0) declares its precision once and every path of
    the cloud SVG uses it; svgelements reads the outline back onto the model points."""
    import xml.etree.ElementTree as ET

    from procgen import Polylines
    from procgen_snaxel.exporters import cloud_svg
    from procgen_snaxel.svgdoc import Page

    t = np.linspace(0, 2 * np.pi, 2000, endpoint=False)
    r = 200 + 40 * np.sin(9 * t)
    ring = np.column_stack([350 + r * np.cos(t), 300 + r * np.sin(t)])
    dom = Polylines.from_list([ring], closed=True, bounds=(0.0, 700.0, 0.0, 600.0))
    page = Page(dom.bounds, 800)
    assert page.decimals == 2
    root = ET.fromstring(cloud_svg(dom, background=None))
    d = [p.get("d") for p in root.iter("{http://www.w3.org/2000/svg}path")][-1]
    assert re.search(r"\.\d{3}", d) is None
    (got, closed), = decode(d)
    assert closed and np.abs(got - page.xy(ring)).max() <= 0.005 + 1e-9
