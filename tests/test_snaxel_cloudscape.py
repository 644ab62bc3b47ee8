"""The illustrated cloudscape: lobes shading one another from the sun, silver linings, translucent
edges, ground shadows cast away from the sun, one layer per cloud; curve limits of varied size."""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from procgen import InputError, Polylines
from procgen_snaxel.cloudscape_svg import cloudscape_svg, occlusion
from procgen_snaxel.growth import CloudGrowth
from procgen_snaxel.tessellate import poisson_tessellation

from test_snaxel_engine import small_cfg

SVG = "{http://www.w3.org/2000/svg}"
INK = "{http://www.inkscape.org/namespaces/inkscape}"


def test_a_lobe_between_another_and_the_sun_shades_it():
    centres = np.array([[0.0, 5.0], [0.0, 0.0], [30.0, 0.0]])
    radii = np.array([6.0, 6.0, 6.0])
    up = occlusion(centres, radii, np.array([0.0, 1.0]))
    assert up[0] == 0.0 and up[2] == 0.0 and up[1] > 0.5          # the top lobe shades the one below only
    down = occlusion(centres, radii, np.array([0.0, -1.0]))
    assert down[1] == 0.0 and down[0] > 0.5                        # sun from below: roles swap
    side = occlusion(centres, radii, np.array([1.0, 0.0]))
    assert np.all(side == 0.0)                                     # side by side, nothing in between


def _scape(**kw) -> tuple[ET.Element, bytes]:
    """A near cloud of two lobes, one above the other (curve 0 the upper dome, curve 1 the lower
    one), and a far flat cloud; the near cloud's page x centre is 50."""
    t = np.linspace(0.0, np.pi, 16)
    upper = np.column_stack([50 + 12 * np.cos(t), 52 + 12 * np.sin(t)])         # right to left over the top
    lower = np.column_stack([50 - 12 * np.cos(t), 44 - 12 * np.sin(t)])         # left to right under the bottom
    a = np.linspace(0, 2 * np.pi, 24, endpoint=False)
    far = np.column_stack([110 + 20 * np.cos(a), 30 + 6 * np.sin(a)])
    dom = Polylines.from_list([far, np.vstack([upper, lower])], closed=True, bounds=(0.0, 150.0, 0.0, 90.0))
    dom.add_field("cloud__depth", np.array([0, 1]), at="line")
    dom.add_field("snaxel__curve", np.concatenate([np.repeat([0, 1], 12), np.repeat([0, 1], 16)]), at="point")
    raw = cloudscape_svg(dom, **kw)
    return ET.fromstring(raw), raw


def test_every_reference_resolves_and_each_cloud_keeps_its_layer():
    root, raw = _scape(horizon=0.2, base_level=0.5, ground="#6f8f4e")
    labels = [g.get(INK + "label") for g in root.findall(SVG + "g")]
    assert labels == ["sky", "ground", "cloud 1 (depth 0)", "cloud 2 (depth 1)"]
    ids = {e.get("id") for e in root.iter() if e.get("id")}
    refs = set(re.findall(rb"url\(#([^)]+)\)", raw))
    assert refs and {r.decode() for r in refs} <= ids               # gradients, clips, masks, filters exist
    kinds = {e.tag[len(SVG):] for e in root.iter(SVG + "defs").__next__()}
    assert {"radialGradient", "linearGradient", "clipPath", "mask", "filter"} <= kinds


def _rgb(hexcolour: str) -> float:
    return sum(int(hexcolour[k:k + 2], 16) for k in (1, 3, 5))


def test_the_shaded_lobe_is_darker_and_casts_nothing_on_the_sunward_one():
    root, _ = _scape(sun_x=0.0, sun_y=1.0, self_shadow=0.6)
    stops = {g.get("id"): g.findall(SVG + "stop")[0].get("stop-color") for g in root.iter(SVG + "radialGradient")}
    layer = [g for g in root.findall(SVG + "g") if g.get(INK + "label") == "cloud 2 (depth 1)"][0]
    discs = [c for c in layer.iter(SVG + "circle") if (c.get("fill") or "").startswith("url(#lobe")]
    assert len(discs) == 2
    cy = [float(c.get("cy")) for c in discs]
    fills = [c.get("fill")[5:-1] for c in discs]
    low, high = (0, 1) if cy[0] > cy[1] else (1, 0)                 # page y-down: larger cy is lower
    assert _rgb(stops[fills[low]]) < _rgb(stops[fills[high]])       # the lower lobe lies in the upper's shadow
    order = [c for c in layer.iter(SVG + "circle")]
    assert order[-1].get("fill") == f"url(#{fills[high]})"          # the sunward lobe is drawn last, unshadowed
    casts = [c for c in order if c.get("filter")]
    assert len(casts) == 2 and float(casts[1].get("cy")) > float(discs[high].get("cy"))   # cast away from the sun
    flat, _ = _scape(sun_x=0.0, sun_y=1.0, self_shadow=0.0)
    assert not [c for c in flat.iter(SVG + "circle") if c.get("filter")]        # no cast shadows
    assert len({g.findall(SVG + "stop")[0].get("stop-color") for g in flat.iter(SVG + "radialGradient")
                if g.get("id").startswith("lobe1-")}) == 1                      # one shade for every lobe


def test_silver_lining_faces_the_sun_and_edges_fade():
    root, _ = _scape(sun_x=-0.6, sun_y=0.8, silver=0.9, thin_edge=0.02)
    rims = [g for g in root.iter(SVG + "linearGradient") if g.get("id", "").startswith("rim")]
    assert len(rims) == 2
    for g in rims:
        x1, y1, x2, y2 = (float(g.get(k)) for k in ("x1", "y1", "x2", "y2"))
        assert x2 < x1 and y2 < y1                                   # bright end up-left, toward the sun (y-down)
        last = g.findall(SVG + "stop")[-1]
        assert float(last.get("stop-opacity")) == pytest.approx(0.9)
    masks = list(root.iter(SVG + "mask"))
    assert len(masks) == 2
    for m in masks:
        ident = m.find(SVG + "path").get("filter")[5:-1]
        blur = [f for f in root.iter(SVG + "filter") if f.get("id") == ident][0].find(SVG + "feGaussianBlur")
        assert float(blur.get("stdDeviation")) > 0
    off, _ = _scape(silver=0.0, thin_edge=0.0)
    assert not list(off.iter(SVG + "mask")) and not [g for g in off.iter(SVG + "linearGradient")
                                                     if g.get("id", "").startswith("rim")]


def test_ground_shadows_fall_away_from_the_sun_nearer_for_near_clouds():
    root, _ = _scape(horizon=0.2, base_level=0.5, ground="#6f8f4e", sun_x=-0.6, sun_y=0.8, perspective=0.4)
    ground = [g for g in root.findall(SVG + "g") if g.get(INK + "label") == "ground"][0]
    shadows = {e.get("id"): e for e in ground.iter(SVG + "ellipse")}
    assert set(shadows) == {"shadow-of-cloud-1", "shadow-of-cloud-2"}
    horizon_y = 90.0 * 0.8
    for e in shadows.values():
        assert float(e.get("cy")) > horizon_y and e.get("filter")
    far, near = shadows["shadow-of-cloud-1"], shadows["shadow-of-cloud-2"]
    assert float(near.get("cy")) > float(far.get("cy"))             # nearer cloud, nearer shadow
    assert float(near.get("ry")) / float(near.get("rx")) > float(far.get("ry")) / float(far.get("rx"))
    assert float(near.get("cx")) > 50.0                               # sun from the left: shadow shifted right
    with pytest.raises(InputError, match="horizon"):
        _scape(horizon=None, ground="#6f8f4e")
    with pytest.raises(InputError, match="self_shadow"):
        _scape(self_shadow=1.5)


def test_limit_jitter_varies_each_curves_limit_and_zero_keeps_the_thesis():
    topo = poisson_tessellation(160.0, 160.0, 1.6, np.random.default_rng(5))
    runs = {}
    for j in (0.0, 0.5):
        g = CloudGrowth(topo, small_cfg(max_steps=200, limit_jitter=j), np.random.default_rng(2))
        while g.step():
            pass
        runs[j] = g
    f0 = runs[0.0].jitter[:runs[0.0].n_curves]
    f5 = runs[0.5].jitter[:runs[0.5].n_curves]
    assert np.all(f0 == 1.0)
    assert np.all((f5 >= np.exp(-0.5)) & (f5 <= np.exp(0.5))) and np.ptp(np.log(f5)) > 0.5
    # the jittered run grew another cloud from the same seed (its curves split at other lengths)
    assert runs[0.5].snake.xy().tobytes() != runs[0.0].snake.xy().tobytes()
