"""Cloud SVG as artists and plotters use it: y-down pages from 0 0, real units, named Inkscape
layers, and a stroke-only plotter file that vpype reads with the expected paths and layers."""
from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest
from _svg_path import d_points

from procgen import InputError, Polylines

SVG = "{http://www.w3.org/2000/svg}"
INK = "{http://www.inkscape.org/namespaces/inkscape}"


def ring(cx: float, cy: float, rx: float, ry: float, n: int = 60) -> np.ndarray:
    t = np.linspace(0, 2 * np.pi, n, endpoint=False)
    return np.column_stack([cx + rx * np.cos(t), cy + ry * np.sin(t)])


def history() -> Polylines:
    """Five nested contours (a growing cloud) as snaxel.grow's {cloud}_history holds them."""
    lines = [ring(60, 40, 5 + 8 * k, 4 + 6 * k) for k in range(5)]
    dom = Polylines.from_list(lines, closed=True, bounds=(0.0, 120.0, 0.0, 80.0))
    dom.add_field("snapshot__step", np.arange(5) * 10, at="line")
    dom.add_field("snaxel__curve", np.tile(np.repeat(np.arange(6), 10), 5), at="point")
    return dom


def layers(root: ET.Element) -> list[str]:
    return [g.get(INK + "label") for g in root.findall(SVG + "g") if g.get(INK + "groupmode") == "layer"]


def test_cloud_svg_is_y_down_from_zero_in_real_units():
    from procgen_snaxel.exporters import cloud_svg

    dom = history()
    root = ET.fromstring(cloud_svg(dom, width=150, units="mm"))
    assert root.get("viewBox") == "0 0 120 80" and root.get("width") == "150mm" and root.get("height") == "100mm"
    assert layers(root) == ["sky", "cloud"]
    assert not any(el.get("transform") for el in root.iter())
    d = [p for p in root.iter(SVG + "path")][-1].get("d")
    first = list(d_points(d)[0])
    # the last contour's model point (60 + 37, 40) (y up, box top at 80) sits at page (97, 40) (y down)
    assert first == pytest.approx([97.0, 80.0 - 40.0])
    no_sky = ET.fromstring(cloud_svg(dom, background=None))
    assert layers(no_sky) == ["cloud"] and not list(no_sky.iter(SVG + "rect"))
    with pytest.raises(InputError, match="units"):
        cloud_svg(dom, units="furlong")


def test_process_figure_has_a_named_layer_per_contour():
    from procgen_snaxel.exporters import process_svg

    root = ET.fromstring(process_svg(history(), background=None, fill=None))
    assert layers(root) == [f"contour step {10 * k}" for k in range(5)]


def test_plotter_svg_strokes_only_and_vpype_reads_paths_and_layers(tmp_path):
    import vpype as vp     # in the test extra
    from procgen_snaxel.exporters import plot_order, plotter_svg

    dom = history()
    one = tmp_path / "outline.svg"
    one.write_bytes(plotter_svg(dom))
    both = tmp_path / "pens.svg"
    both.write_bytes(plotter_svg(dom, process=True, width=120, units="mm"))
    root = ET.fromstring(both.read_bytes())
    assert root.get("width") == "120mm" and layers(root) == ["outline", "process"]
    assert not list(root.iter(SVG + "rect"))
    for g in root.findall(SVG + "g"):
        assert g.get("fill") == "none" and g.get("stroke")
    doc = vp.read_multilayer_svg(str(one), 0.05)
    assert len(doc.layers) == 1 and sum(len(lc) for lc in doc.layers.values()) == 1
    doc = vp.read_multilayer_svg(str(both), 0.05)
    assert len(doc.layers) == 2 and sorted(len(lc) for lc in doc.layers.values()) == [1, 4]
    # 120 mm for 120 units: vpype's pixels (1/96 in) give the outline's true width in mm
    outline = next(lc for lc in doc.layers.values() if len(lc) == 1)
    x0, y0, x1, y1 = outline.bounds()
    assert (x1 - x0) / 96 * 25.4 == pytest.approx(2 * 37, rel=0.01)
    # pen-up travel: the ordered file travels less than drawing lines in the given order
    lines = [dom.line(i) for i in (4, 0, 3, 1, 2)]
    ordered = plot_order(lines, [True] * 5, np.zeros(2))
    naive = [np.vstack([p, p[:1]]) for p in lines]
    travel = lambda ps: sum(np.hypot(*(b[0] - a[-1])) for a, b in zip(ps, ps[1:]))  # noqa: E731
    assert travel(ordered) < 0.5 * travel(naive)
    with pytest.raises(InputError, match="history"):
        plotter_svg(Polylines.from_list([ring(5, 5, 2, 2)], closed=True), process=True)


def test_cloudscape_one_layer_per_cloud_with_lobe_gradients():
    from procgen_snaxel.exporters import cloudscape_svg

    lines = [ring(40, 60, 20, 10), ring(100, 40, 30, 18)]
    dom = Polylines.from_list(lines, closed=True, bounds=(0.0, 150.0, 0.0, 90.0))
    dom.add_field("cloud__depth", np.array([0, 1]), at="line")
    dom.add_field("snaxel__curve", np.concatenate([np.repeat(np.arange(6), 10)] * 2), at="point")
    root = ET.fromstring(cloudscape_svg(dom))
    assert layers(root) == ["sky", "cloud 1 (depth 0)", "cloud 2 (depth 1)"]
    assert {g.get("id").split("-")[0] for g in root.iter(SVG + "radialGradient")} == {"lobe0", "lobe1"}
    lobes = [c for c in root.iter(SVG + "circle") if not c.get("filter")]
    assert len(lobes) == 12                                               # one lobe per curve
    bare = ET.fromstring(cloudscape_svg(dom, sky=False))
    assert layers(bare)[0] == "cloud 1 (depth 0)"


def test_cloudscape_bases_lie_on_one_receding_plane():
    """With a horizon, each cloud's base is moved to horizon + s (base_level - horizon) for its
    drawing scale s: the near cloud's base floats higher than the far one's, both as computed."""
    import re

    from procgen_snaxel.exporters import cloudscape_svg

    lines = [ring(40, 60, 20, 10), ring(100, 20, 30, 18), ring(60, 40, 15, 9)]
    dom = Polylines.from_list(lines, closed=True, bounds=(0.0, 150.0, 0.0, 90.0))
    dom.add_field("cloud__depth", np.array([0, 2, 1]), at="line")
    root = ET.fromstring(cloudscape_svg(dom, horizon=0.1, base_level=0.5, perspective=0.4))
    ty = {}
    for g in root.findall(SVG + "g"):
        m = re.match(r"translate\(([-\d.e]+),([-\d.e]+)\) scale\(([-\d.e]+),", g.get("transform") or "")
        if m:
            ty[g.get(INK + "label")] = (float(m.group(2)), float(m.group(3)))
    for label, depth in (("cloud 1 (depth 0)", 0), ("cloud 2 (depth 2)", 2), ("cloud 3 (depth 1)", 1)):
        y, s = ty[label]
        assert s == pytest.approx(1.0 - 0.4 * (1.0 - depth / 2.0))
        assert y == pytest.approx(90.0 * (1.0 - 0.1 - s * 0.4), abs=1e-3)      # page y-down
    with pytest.raises(InputError, match="horizon"):
        cloudscape_svg(dom, horizon=0.6, base_level=0.5)


def test_detail_figure_magnifies_the_neck_and_the_fringe():
    """Figure 4.4 / 4.8 pages: the whole cloud plus one framed, magnified window per detail; the
    neck window sits on the thin bar of a dumbbell, the fringe windows on its crinkled edge."""
    from shapely.geometry import Point, Polygon, box

    from procgen_snaxel.exporters import detail_svg, detail_windows

    bell = Point(50, 20).buffer(20).union(Point(50, 90).buffer(20)).union(box(46, 30, 54, 80))
    xy = np.asarray(bell.exterior.coords)[:-1]
    (cx, cy, side), = detail_windows(xy, "neck", 0.08)
    assert 40 <= cy <= 70 and abs(cx - 50) < 2 and 16 <= side <= 40
    t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    rad = 40 + np.where(np.cos(t) > 0.7, 3 * np.sin(60 * t), 0.0)          # bumps on the right only
    crinkled = np.column_stack([60 + rad * np.cos(t), 60 + rad * np.sin(t)])
    wins = detail_windows(crinkled, "fringe", 0.1)
    assert len(wins) == 2 and all(x > 80 for x, _, _ in wins)
    dom = Polylines.from_list([crinkled], closed=True, bounds=(0.0, 120.0, 0.0, 120.0))
    root = ET.fromstring(detail_svg(dom, focus="fringe", size=0.1))
    names = layers(root)
    assert names[:2] == ["sky", "whole cloud"] and len(names) == 4
    assert all(n.startswith("detail ") and float(n.split("x")[-1]) > 2.0 for n in names[2:])
    assert Polygon(crinkled).is_valid
    with pytest.raises(InputError, match="focus"):
        detail_svg(dom, focus="middle")
