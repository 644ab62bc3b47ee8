"""The colour map of a 2.5-D stack (Phong per layer, light through layers, wet look, drops film)
and the drops SVG exporter."""
from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np

from procgen import PointSet
from procgen.lighting import light_direction, phong
from procgen_layers.light import shade_stack
from procgen_layers.materials import PRESETS, parse_materials
from procgen_water.exporters import drops_svg


def render_layers(base, t, tab, *, azimuth=135.0, elevation=50.0, water_depth=None, **kw):
    """A flat 2.5-D stack seen from above, as layers.shade shades a Grid (every normal up)."""
    up = np.zeros(t.shape[:-1] + (3,))
    up[..., 2] = 1.0
    return shade_stack(up, t, tab, light=light_direction(azimuth, elevation), film=water_depth,
                       film_normals=up, film_material=PRESETS["water"], **kw)


def test_single_flat_layer_renders_its_lit_colour_and_holes_show_background():
    tab = parse_materials(["patina"])
    t = np.ones((6, 7, 1))
    rgb = render_layers(np.zeros((6, 7)), t, tab, azimuth=30, elevation=60)
    m = tab["patina"]
    expect = phong(np.array([0.0, 0.0, 1.0]), m.color, light=light_direction(30, 60), ambient=m.ambient,
                   diffuse=m.diffuse, specular=m.specular, exponent=m.exponent)
    assert np.allclose(rgb, np.clip(expect, 0, 1))
    hole = np.zeros((6, 7), bool)
    hole[2, 3] = True
    t[0, 0, 0] = 0.0                                   # no layer left there either
    rgb = render_layers(np.zeros((6, 7)), t, tab, hole=hole, background=(0.1, 0.2, 0.3))
    assert np.allclose(rgb[2, 3], [0.1, 0.2, 0.3]) and np.allclose(rgb[0, 0], [0.1, 0.2, 0.3])


def test_thin_top_layer_tints_and_wet_cells_darken_and_drops_look_blue():
    tab = parse_materials(["stone", {"preset": "patina", "opacity": 0.9}])
    t = np.zeros((4, 4, 2))
    t[..., 0] = 1.0
    t[:, 2:, 1] = 0.05                                 # a thin patina film on the right half
    rgb = render_layers(np.zeros((4, 4)), t, tab)
    assert rgb[0, 3, 1] > rgb[0, 0, 1] and rgb[0, 3, 0] < rgb[0, 0, 0]    # greener, less red
    held = np.zeros_like(t)
    held[0, 0, 0] = tab["stone"].capacity * 1.0        # saturated stone cell
    wet = render_layers(np.zeros((4, 4)), t, tab, held=held, wet_darkening=0.5)
    assert np.all(wet[0, 0] < rgb[0, 0]) and np.allclose(wet[1, 0], rgb[1, 0])
    water = np.zeros((4, 4))
    water[1, 1] = 2.0
    with_drops = render_layers(np.zeros((4, 4)), t, tab, water_depth=water)
    assert with_drops[1, 1, 2] - with_drops[1, 1, 0] > rgb[1, 1, 2] - rgb[1, 1, 0]


def test_drops_svg_draws_arrows_for_moving_and_domes_for_stabilised():
    ps = PointSet(np.array([[1.0, 1.0], [2.0, 3.0], [4.0, 1.5]]), bounds=(0.0, 5.0, 0.0, 4.0))
    ps.add_field("drop__moving", np.array([True, False, True]), at="point")
    ps.add_field("drop__velocity", np.array([[0.3, 0.0], [0.0, 0.0], [0.0, -0.2]]), at="point")
    ps.add_field("drop__volume", np.ones(3), at="point")
    root = ET.fromstring(drops_svg(ps, stem="d", scale=10.0))
    ns = "{http://www.w3.org/2000/svg}"
    lines, circles = root.findall(f"{ns}line"), root.findall(f"{ns}circle")
    assert len(lines) == 2 and len(circles) == 1
    assert float(circles[0].get("cx")) == 20.0 and float(circles[0].get("cy")) == 10.0   # north up
    first = lines[0]
    assert float(first.get("x2")) > float(first.get("x1"))                 # points along +x
