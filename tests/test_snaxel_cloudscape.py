"""The illustrated cloudscape: soft lobes shading one another, light dimming through the cloud,
rounded outlines, silver linings, translucent edges, each cloud's outline projected on the ground,
small pale clouds at the horizon, one layer per cloud; curve limits of varied size."""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest

from procgen import InputError, Polylines
from procgen.exchange.svg import svg_decimals
import svgelements
import shapely
import shapely.affinity
from shapely import Polygon

from procgen_snaxel.cloudscape_svg import (DEPTH_REACH, DEPTH_STEPS, FLANK_GAP, GROUND_REACH, NECK_FLOOR, broaden,
                                           LOBE_DIM, cloudscape_svg, light_depth, lobe_light, neck_ratio, occlusion,
                                           rim_lobes, round_sides, rounded, silhouette)
from procgen_snaxel.growth import CloudGrowth
from procgen_snaxel.tessellate import poisson_tessellation

from test_snaxel_engine import small_cfg
from _svg_path import d_points

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
    refs = set(re.findall(rb"url\(#([^)]+)\)", raw)) | set(re.findall(rb'href="#([^"]+)"', raw))
    assert refs and {r.decode() for r in refs} <= ids               # gradients, clips, masks, filters exist
    kinds = {e.tag[len(SVG):] for e in root.iter(SVG + "defs").__next__()}
    assert {"radialGradient", "linearGradient", "clipPath", "mask", "filter"} <= kinds


def _rgb(hexcolour: str) -> float:
    return sum(int(hexcolour[k:k + 2], 16) for k in (1, 3, 5))


def _stops(root: ET.Element) -> dict[str, list[ET.Element]]:
    return {g.get("id"): g.findall(SVG + "stop") for g in root.iter() if g.tag.endswith("Gradient")}


def test_the_shaded_lobe_is_darker_and_no_lobe_has_a_hard_edge():
    root, _ = _scape(sun_x=0.0, sun_y=1.0, self_shadow=0.6)
    stops = _stops(root)
    layer = [g for g in root.findall(SVG + "g") if g.get(INK + "label") == "cloud 2 (depth 1)"][0]
    discs = [c for c in layer.iter(SVG + "circle") if (c.get("fill") or "").startswith("url(#lobe")]
    assert len(discs) == 2
    cy = [float(c.get("cy")) for c in discs]
    fills = [c.get("fill")[5:-1] for c in discs]
    low, high = (0, 1) if cy[0] > cy[1] else (1, 0)                 # page y-down: larger cy is lower
    assert _rgb(stops[fills[low]][0].get("stop-color")) < _rgb(stops[fills[high]][0].get("stop-color"))
    assert discs[-1].get("fill") == f"url(#{fills[high]})"          # the sunward lobe is drawn last
    for ident, st in stops.items():                                 # soft lobes: opaque dome, transparent rim
        if ident.startswith("lobe"):
            assert float(st[0].get("stop-opacity")) == 1.0 and float(st[-1].get("stop-opacity")) == 0.0
    flat, _ = _scape(sun_x=0.0, sun_y=1.0, self_shadow=0.0)
    assert len({st[0].get("stop-color") for k, st in _stops(flat).items() if k.startswith("lobe1-")}) == 1


def test_light_dims_with_the_cloud_it_crossed():
    sun = np.array([-0.6, 0.8])
    a = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    disc = np.column_stack([50 + 20 * np.cos(a), 40 + 20 * np.sin(a)])
    probes = np.random.default_rng(3).uniform([30, 20], [70, 60], (500, 2))
    got = light_depth(disc, sun, 40.0, probes)
    # independent count: steps k * DEPTH_REACH * height / DEPTH_STEPS toward the sun that are in the disc
    steps = np.arange(1, DEPTH_STEPS + 1) / DEPTH_STEPS * DEPTH_REACH * 40.0
    ahead = probes[:, None, :] + steps[None, :, None] * sun[None, None, :]
    want = (np.hypot(ahead[..., 0] - 50, ahead[..., 1] - 40) < 19.97).sum(1)
    ok = np.abs(np.hypot(*(ahead - [50, 40]).transpose(2, 0, 1)) - 20).min(1) > 0.1   # not on the polygon's edge
    assert np.array_equal(got[ok], want[ok]) and want.max() == DEPTH_STEPS
    sunward, deep = np.array([[50 - 0.6 * 19, 40 + 0.8 * 19]]), np.array([[50 + 0.6 * 15, 40 - 0.8 * 15]])
    assert light_depth(disc, sun, 40.0, sunward)[0] == 0 and light_depth(disc, sun, 40.0, deep)[0] == DEPTH_STEPS
    # the drawing shifts the silhouette by exactly these steps, away from the sun (page y down)
    root, _ = _scape(sun_x=-0.6, sun_y=0.8, self_shadow=0.5)
    layer = [g for g in root.findall(SVG + "g") if g.get(INK + "label") == "cloud 2 (depth 1)"][0]
    shifts = [tuple(map(float, re.findall(r"-?[\d.]+", u.get("transform")))) for u in layer.iter(SVG + "use")
              if (u.get("transform") or "").startswith("translate")]
    height = 2 * 12 * np.sin(np.pi * 7 / 15) + 8.0                   # the two domes' sampled tops and the gap
    want_shifts = [(0.6 * k * DEPTH_REACH * height, 0.8 * k * DEPTH_REACH * height)    # down-right on the page
                   for k in np.arange(1, DEPTH_STEPS + 1) / DEPTH_STEPS]
    assert np.allclose(shifts, want_shifts, atol=1e-3)


def test_rounded_outline_cuts_spikes_and_the_thesis_outline_stays_the_default():
    a = np.linspace(0, 2 * np.pi, 720, endpoint=False)
    r = 20 + 8 * (np.abs(np.sin(12 * a)) > 0.995)                      # a disc with 24 thin spikes
    spiky = np.column_stack([50 + r * np.cos(a), 40 + r * np.sin(a)])
    soft = rounded(spiky, 2.0)
    assert np.hypot(*(soft - [50, 40]).T).max() < 20.5                  # every spike cut
    assert Polygon(soft).area == pytest.approx(np.pi * 400, rel=0.02)    # the body kept
    assert Polygon(soft).exterior.is_ccw
    root, _ = _scape()
    outlines = {p.get("id"): p.get("d") for p in root.iter(SVG + "path") if (p.get("id") or "").startswith("outline")}
    assert len(outlines) == 2 and len(d_points(outlines["outline0"])) == 24     # the snaxel contour, point for point
    smooth, _ = _scape(outline="rounded", round_radius=0.2)
    assert {p.get("d") for p in smooth.iter(SVG + "path") if p.get("id") == "outline1"} != {outlines["outline1"]}


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
        ident = m.find(SVG + "use").get("filter")[5:-1]
        blur = [f for f in root.iter(SVG + "filter") if f.get("id") == ident][0].find(SVG + "feGaussianBlur")
        assert float(blur.get("stdDeviation")) > 0
    off, _ = _scape(silver=0.0, thin_edge=0.0)
    assert not list(off.iter(SVG + "mask")) and not [g for g in off.iter(SVG + "linearGradient")
                                                     if g.get("id", "").startswith("rim")]


def _shoelace(p: np.ndarray) -> tuple[float, np.ndarray]:
    x, y = p[:, 0], p[:, 1]
    cross = x * np.roll(y, -1) - np.roll(x, -1) * y
    area = cross.sum() / 2
    c = np.array([((x + np.roll(x, -1)) * cross).sum(), ((y + np.roll(y, -1)) * cross).sum()]) / (6 * area)
    return abs(area), c


def _reified(raw: bytes, tmp_path) -> dict[str, np.ndarray]:
    """Every use/path with an id, as page points with all transforms applied (read by svgelements)."""
    f = tmp_path / "scape.svg"
    f.write_bytes(raw)
    out = {}
    for e in svgelements.SVG.parse(str(f)).elements():
        ident = getattr(e, "id", None)
        path = e if isinstance(e, svgelements.Path) else next((c for c in e if isinstance(c, svgelements.Path)), None) \
            if isinstance(e, svgelements.Use) else None
        if ident and path is not None:
            out[ident] = np.array([(s.end.x, s.end.y) for s in path if isinstance(s, (svgelements.Move, svgelements.Line))])
    return out


def test_ground_shadow_is_the_clouds_outline_projected_along_the_sun(tmp_path):
    sun3 = np.array([-0.6, 0.8, 0.9]) / np.linalg.norm([-0.6, 0.8, 0.9])
    root, raw = _scape(horizon=0.2, base_level=0.5, ground="#6f8f4e", sun_x=-0.6, sun_y=0.8, sun_z=0.9,
                       perspective=0.4, flatten=0.3, width=150, thin_edge=0.0, silver=0.0, self_shadow=0.0)
    shapes = _reified(raw, tmp_path)
    y_h = 90.0 * 0.8
    layers = {g.get(INK + "label"): g for g in root.findall(SVG + "g")}
    results = {}
    for k, label in ((1, "cloud 1 (depth 0)"), (2, "cloud 2 (depth 1)")):
        qx, ty, sc, sy, _, neg_qy = (float(v) for v in re.findall(r"-?[\d.]+", layers[label].get("transform")))
        m = (sc, 0.0, 0.0, sy, qx - sc * qx, ty + sy * neg_qy)        # translate(qx,ty) scale(sc,sy) translate(-qx,-qy)
        outline = [p for p in root.iter(SVG + "path") if p.get("id") == f"outline{k - 1}"][0].get("d")
        page_pts = d_points(outline)
        drawn = page_pts @ np.array([[m[0], m[1]], [m[2], m[3]]]) + [m[4], m[5]]
        shadow = shapes[f"shadow-of-cloud-{k}"]
        assert len(shadow) == len(drawn)
        scale = m[0]
        y_b, y_g = drawn[:, 1].max(), y_h + GROUND_REACH * (90.0 - y_h) * scale
        # expected from the light path: height above the base Z, base y_g - y_b above the ground
        z = y_b - drawn[:, 1]
        want = np.column_stack([drawn[:, 0] - (y_g - y_b + z) * sun3[0] / sun3[1],
                                y_g - z * sun3[2] / sun3[1] * (y_g - y_h) / 90.0])
        assert np.allclose(shadow, want, atol=1e-2)
        a_d, c_d = _shoelace(drawn)
        a_s, c_s = _shoelace(shadow)
        q = sun3[2] / sun3[1] * (y_g - y_h) / 90.0
        assert a_s == pytest.approx(q * a_d, rel=1e-3)                  # foreshortened by q, not sheared in area
        z_c = y_b - c_d[1]
        assert np.allclose(c_s, [c_d[0] - (y_g - y_b + z_c) * sun3[0] / sun3[1], y_g - q * z_c], atol=1e-2)
        assert shadow[:, 1].max() == pytest.approx(y_g, abs=1e-2) and shadow[:, 1].min() > y_h   # on the ground
        assert c_s[0] > c_d[0]                                          # sun from the left: cast to the right
        results[k] = (y_g, q)
    assert results[2][0] > results[1][0] and results[2][1] > results[1][1]   # nearer: lower, less foreshortened
    use = [u for u in root.iter(SVG + "use") if u.get("id") == "shadow-of-cloud-2"][0]
    assert use.get("filter")
    with pytest.raises(InputError, match="horizon"):
        _scape(horizon=None, ground="#6f8f4e")
    with pytest.raises(InputError, match="sun_z"):
        _scape(horizon=0.2, base_level=0.5, ground="#6f8f4e", sun_z=0.0)
    with pytest.raises(InputError, match="self_shadow"):
        _scape(self_shadow=1.5)
    with pytest.raises(InputError, match="outline"):
        _scape(outline="smooth")


def test_horizon_clouds_are_smaller_paler_pairwise_different_and_fixed_by_the_outlines():
    kw = dict(horizon=0.2, base_level=0.5, haze_clouds=12, perspective=0.4, sky_horizon="#c9def2")
    root, raw = _scape(**kw)
    assert raw == _scape(**kw)[1]                                   # same outlines, same haze, byte for byte
    layers = [g.get(INK + "label") for g in root.findall(SVG + "g")]
    assert layers == ["sky", "horizon clouds", "cloud 1 (depth 0)", "cloud 2 (depth 1)"]
    haze = [g for g in root.findall(SVG + "g") if g.get(INK + "label") == "horizon clouds"][0]
    subs = haze.findall(SVG + "g")
    assert len(subs) == 12 and all(g.get(INK + "groupmode") == "layer" for g in subs)
    far = [g for g in root.findall(SVG + "g") if g.get(INK + "label") == "cloud 1 (depth 0)"][0]
    far_scale = float(re.findall(r"-?[\d.]+", far.get("transform"))[2])
    far_w = 40.0 * far_scale                                        # the far test cloud is 40 wide
    stops = _stops(root)
    sky = np.array([int("c9def2"[k:k + 2], 16) for k in (0, 2, 4)])

    def paleness(ident: str) -> float:     # distance of the top colour from the horizon sky (smaller = paler)
        c = stops[ident][0].get("stop-color")
        return float(np.abs(np.array([int(c[k:k + 2], 16) for k in (1, 3, 5)]) - sky).sum())

    y_h = 90.0 * 0.8
    shapes = []
    for g in subs:
        p = g.find(SVG + "path")
        pts = d_points(p.get("d"))
        assert np.ptp(pts[:, 0]) < 0.6 * far_w and pts[:, 1].max() <= y_h + 0.05    # smaller, above the horizon
        assert pts[:, 0].min() >= 0.02 * 150 - 0.05 and pts[:, 0].max() <= 150 - 0.02 * 150 + 0.05   # whole
        assert paleness(p.get("fill")[5:-1]) < paleness("body0")                      # paler than the far cloud
        pts = (pts - pts.min(0)) / np.ptp(pts, axis=0)                                # unit box: no stretch hides a clone
        shapes.append(Polygon(pts).buffer(0))
    for a in range(len(shapes)):                                    # no two alike, even mirrored
        for b in range(a):
            mirrored = shapely.affinity.scale(shapes[b], -1.0, 1.0, origin=(0.5, 0.0))
            diff = min(shapes[a].symmetric_difference(shapes[b]).area, shapes[a].symmetric_difference(mirrored).area)
            assert diff > 0.01 * max(shapes[a].area, shapes[b].area)     # a clone, even stretched, is ~0
    moved, _ = _scape(**kw, sun_x=-0.5)
    assert moved.findall(SVG + "g")[1].findall(SVG + "g")[0].find(SVG + "path").get("d") == \
        subs[0].find(SVG + "path").get("d")                           # not the light: the outlines fix them
    with pytest.raises(InputError, match="haze_clouds"):
        _scape(horizon=None, haze_clouds=3)


def test_texture_is_lit_noise_and_off_by_default():
    root, _ = _scape(texture=0.4)
    tex = [f for f in root.iter(SVG + "filter") if f.get("id", "").startswith("texture")]
    assert len(tex) == 2
    for f in tex:
        assert f.find(SVG + "feTurbulence").get("type") == "fractalNoise"
        assert f.find(SVG + "feDiffuseLighting").find(SVG + "feDistantLight") is not None
    plain, _ = _scape()
    assert not [f for f in plain.iter(SVG + "filter") if f.get("id", "").startswith("texture")]


def test_texture_follows_the_lobes_widest_on_their_shaded_flank():
    root, _ = _scape(texture=0.4, sun_x=-0.6, sun_y=0.8)
    layer = [g for g in root.findall(SVG + "g") if g.get(INK + "label") == "cloud 2 (depth 1)"][0]
    discs = sorted((float(c.get("cx")), float(c.get("cy")), float(c.get("r"))) for c in layer.iter(SVG + "circle"))
    rect = [r for r in layer.iter(SVG + "rect") if (r.get("filter") or "").startswith("url(#texture")][0]
    mask = [m for m in root.iter(SVG + "mask") if m.get("id") == rect.get("mask")[5:-1]][0]
    rings = sorted((float(c.get("cx")), float(c.get("cy")), float(c.get("r"))) for c in mask.iter(SVG + "circle"))
    assert len(discs) == 2 and np.allclose(rings, discs)            # one ring per lobe, on the lobe
    grad = [g for g in root.iter(SVG + "radialGradient") if g.get("id") == mask.find(SVG + "circle").get("fill")[5:-1]][0]
    lum = [(float(st.get("offset")), _rgb(st.get("stop-color"))) for st in grad.findall(SVG + "stop")]
    assert lum[0][1] == 0 and lum[-1][1] == 0 and max(v for _, v in lum) == 3 * 255   # smooth dome, bumpy rim, none past it
    assert float(grad.get("fx")) < 0.5 and float(grad.get("fy")) < 0.5   # dark centre toward the sun (up-left)


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


def test_procgen_check_names_a_wrong_outline_before_any_growth(host, tmp_path):
    from procgen import RecipeError
    from procgen.recipes import find_recipe, load_recipe

    text = find_recipe("clouds/cloudscape", host).read_text()
    assert 'outline = "rounded"' in text and "haze_clouds = 40" in text
    bad = tmp_path / "scape.toml"
    bad.write_text(text.replace('outline = "rounded"', 'outline = "smooth"'))
    with pytest.raises(RecipeError, match="outline.*smooth"):
        load_recipe(bad, host)


def _chords(p: np.ndarray, y: float) -> float:
    """Cross-section length at height y, from the outline's edge crossings (no shapely)."""
    a, b = p, np.roll(p, -1, axis=0)
    hit = (a[:, 1] - y) * (b[:, 1] - y) < 0
    t = (y - a[hit, 1]) / (b[hit, 1] - a[hit, 1])
    xs = np.sort(a[hit, 0] + t * (b[hit, 0] - a[hit, 0]))
    return float((xs[1::2] - xs[0::2]).sum())


def _narrowest(p: np.ndarray, rows: int = 200) -> float:
    """Independent neck measure: min over heights (above NECK_FLOOR) of the chord over the widest chord above."""
    y0, y1 = p[:, 1].min(), p[:, 1].max()
    ys = np.linspace(y0 + NECK_FLOOR * (y1 - y0), y1, rows + 1)[:-1] + 1e-7
    w = np.array([_chords(p, y) for y in ys])
    return float((w / np.maximum.accumulate(w[::-1])[::-1]).min())


def _tower(x: float = 60.0) -> np.ndarray:
    """A broad flat base 80 wide and 10 tall, a neck 8 wide and 20 tall, a round head 40 across on top."""
    base = shapely.box(x - 40, 0, x + 40, 10)
    neck = shapely.box(x + 10, 5, x + 18, 32)
    head = shapely.Point(x + 14, 48).buffer(20, quad_segs=16)
    poly = shapely.orient_polygons(shapely.union_all([base, neck, head]))
    return np.asarray(poly.exterior.coords)[:-1]


def test_a_tower_on_a_narrow_neck_is_broadened_into_a_broad_based_heap():
    tower = _tower()
    assert neck_ratio(tower) == pytest.approx(_narrowest(tower), abs=0.03) and _narrowest(tower) < 0.25
    heap, added = broaden(tower)
    assert _narrowest(heap) > 0.85 and added                         # broad-based: no level much wider than below
    assert Polygon(heap).buffer(1e-6).contains(Polygon(tower))       # filled, nothing of the cloud cut
    assert heap[:, 1].min() == pytest.approx(0.0) and heap[:, 1].max() == pytest.approx(tower[:, 1].max())
    assert Polygon(heap).exterior.is_ccw
    dome = np.column_stack([50 + 30 * np.cos(np.linspace(0, np.pi, 40)), 30 * np.sin(np.linspace(0, np.pi, 40))])
    assert neck_ratio(dome) > 0.97                                   # a dome has no neck


def _bumpy_tower() -> np.ndarray:
    """:func:`_tower` with a cauliflower head: ten discs of radius 7 round the head's rim."""
    a = np.linspace(0, 2 * np.pi, 10, endpoint=False)
    bumps = shapely.buffer(shapely.points(np.column_stack([74 + 15 * np.cos(a), 48 + 15 * np.sin(a)])), 7.0,
                           quad_segs=8)
    poly = shapely.orient_polygons(shapely.union_all([Polygon(_tower()), *bumps]))
    return np.asarray(poly.exterior.coords)[:-1]


def _concave_turning(p: np.ndarray, keep, step: float) -> float:
    """Concave turning (radians) per unit length of the outline ``p`` (counter-clockwise) resampled
    every ``step``, over the samples ``keep(samples)`` selects: 0 on a smooth convex bell, high
    where bumps meet in notches."""
    ring = shapely.LinearRing(p)
    q = shapely.get_coordinates(shapely.line_interpolate_point(ring, np.arange(0, ring.length, step)))
    d = np.roll(q, -1, axis=0) - q
    turn = np.angle(np.exp(1j * (np.arctan2(d[:, 1], d[:, 0]) - np.arctan2(*np.roll(d, 1, axis=0)[:, ::-1].T))))
    sel = keep(q)
    return float(np.clip(-turn[sel], 0, None).sum() / (sel.sum() * step))


def test_a_broadened_flank_is_as_bumpy_as_the_grown_outline():
    tower = _bumpy_tower()
    h = np.ptp(tower[:, 1])
    for shape in (broaden(tower)[0], silhouette(tower, "rounded", 0.05 * h, 0.7, None, 0.0)[0]):
        assert _narrowest(shape) > 0.7                               # broadened: no narrow neck left
        flank = _concave_turning(shape, lambda q: (shapely.distance(Polygon(tower), shapely.points(q)) > FLANK_GAP * h)
                                 & (q[:, 1] > FLANK_GAP * h), 0.005 * h)
        head = _concave_turning(tower, lambda q: q[:, 1] > 30, 0.005 * h)   # the grown head's notches
        assert flank > 0.5 * head > 0, (flank, head)
    bell = rounded(np.asarray(shapely.convex_hull(Polygon(tower)).exterior.coords)[:-1], 0.05 * h)
    assert _concave_turning(bell, lambda q: q[:, 1] > 0, 0.005 * h) < 0.05 * head    # a smooth bell scores ~0


def test_no_lobe_buried_in_the_body_is_drawn():
    disc = np.column_stack([50 + 20 * np.cos(np.linspace(0, 2 * np.pi, 200, endpoint=False)),
                            20 + 20 * np.sin(np.linspace(0, 2 * np.pi, 200, endpoint=False))])
    rim, buried = (np.array([50.0, 36.0]), 6.0), (np.array([50.0, 22.0]), 6.0)
    assert [r for _, r in rim_lobes([rim, buried], disc)] == [6.0]          # the buried one dropped
    root, _ = _edge_scape(neck=0.6)
    drawn = _drawn_outlines(root)
    for g in root.findall(SVG + "g"):                                 # every lobe drawn reaches its cloud's rim
        if not g.get(INK + "label").startswith("cloud "):
            continue
        tx, ty, sc, sy, nx, ny = (float(v) for v in re.findall(r"-?[\d.]+", g.get("transform")))
        ring = shapely.LinearRing(drawn[g.get(INK + "label")])
        circles = [c for c in g.iter(SVG + "circle") if (c.get("fill") or "").startswith("url(#lobe")]
        assert circles
        for c in circles:
            x, y, r = (float(c.get(k)) for k in ("cx", "cy", "r"))
            centre = shapely.Point(tx + sc * (x + nx), ty + sy * (y + ny))
            assert ring.distance(centre) <= sc * r / 1.15 + 1e-2


def test_round_sides_removes_the_growth_domains_wall():
    a = np.linspace(-np.pi / 2, np.pi / 2, 40)
    walled = np.vstack([np.column_stack([30 * np.cos(a), 20 + 20 * np.sin(a)]), [[0, 40], [0, 0]]])  # cut at x = 0
    free = round_sides(walled, (0.0, 100.0), 0.5)
    h = np.ptp(free[:, 1])
    side = free[np.abs(free[:, 0]) <= 0.5, 1]
    assert not np.any((side > 0.1 * h) & (side < 0.9 * h)) and free[:, 0].min() < -3.0   # a bulge, no wall left
    assert Polygon(free).buffer(1e-6).contains(Polygon(walled)) and free[:, 1].min() >= -1e-9   # base kept flat
    b = np.linspace(0, 2 * np.pi, 200, endpoint=False)
    disc = np.column_stack([50 + 20 * np.cos(b), 20 + 20 * np.sin(b)])
    assert np.array_equal(round_sides(disc, (0.0, 100.0), 0.5), disc)    # away from the walls: unchanged
    assert np.array_equal(round_sides(walled, (-5.0, 100.0), 0.5), walled)   # not at a wall: a flat side kept


def _edge_scape(**kw) -> tuple[ET.Element, bytes]:
    """Two clouds grown against the left and right walls of a 300 x 100 domain, one with a tower on a neck."""
    a = np.linspace(-np.pi / 2, np.pi / 2, 30)
    left = np.vstack([np.column_stack([2 + 40 * np.cos(a), 50 + 16 * np.sin(a)]), [[2, 66], [2, 34]]])
    right = _tower(262.0)
    dom = Polylines.from_list([left, right], closed=True, bounds=(0.0, 300.0, 0.0, 100.0))
    dom.add_field("cloud__depth", np.array([1, 0]), at="line")
    dom.add_field("snaxel__curve", np.concatenate([np.arange(len(left)) // 6, np.arange(len(right)) // 12]), at="point")
    raw = cloudscape_svg(dom, horizon=0.2, base_level=0.5, **kw)
    return ET.fromstring(raw), raw


def _drawn_outlines(root: ET.Element) -> dict[str, np.ndarray]:
    """Each cloud layer's outline (page units) with its layer transform applied."""
    paths = {p.get("id"): d_points(p.get("d"))
             for p in root.iter(SVG + "path") if (p.get("id") or "").startswith("outline")}
    out = {}
    for g in root.findall(SVG + "g"):
        label = g.get(INK + "label")
        if not label.startswith("cloud "):
            continue
        tx, ty, sc, sy, nx, ny = (float(v) for v in re.findall(r"-?[\d.]+", g.get("transform")))
        ident = next(u.get("{http://www.w3.org/1999/xlink}href") or u.get("href") for u in g.iter(SVG + "use"))[1:]
        p = paths[ident]
        out[label] = np.column_stack([tx + sc * (p[:, 0] + nx), ty + sy * (p[:, 1] + ny)])
    return out


def test_clouds_stay_whole_inside_the_frame_unless_bleed_and_necks_are_repaired():
    root, raw = _edge_scape(neck=0.6, frame_margin=0.03)
    assert raw == _edge_scape(neck=0.6, frame_margin=0.03)[1]         # byte-identical for the same input
    drawn = _drawn_outlines(root)
    assert len(drawn) == 2
    tol = 0.5 * 10.0 ** -svg_decimals(300) + 1e-3                    # half the path resolution + the transform's
    for p in drawn.values():                                         # whole clouds inside the page by the margin
        assert p[:, 0].min() >= 0.03 * 300 - tol and p[:, 0].max() <= 300 - 0.03 * 300 + tol
        assert p[:, 1].min() >= 0.03 * 300 - tol
        model = np.column_stack([p[:, 0], -p[:, 1]])                 # y up for the neck measure
        assert _narrowest(model) >= 0.6                              # no neck under 60 % of the width above it
    bled, _ = _edge_scape(neck=0.0, bleed=True)
    loose = _drawn_outlines(bled)
    assert min(p[:, 0].min() for p in loose.values()) < 0.03 * 300   # bleed: placed where they grew
    assert min(_narrowest(np.column_stack([p[:, 0], -p[:, 1]])) for p in loose.values()) < 0.3   # neck kept
    with pytest.raises(InputError, match="neck"):
        _edge_scape(neck=1.5)


def test_lobe_light_uses_the_suns_height_toward_the_viewer():
    rng = np.random.default_rng(7)
    xy = rng.uniform(-1, 1, (200000, 2))
    xy = xy[np.hypot(*xy.T) < 1]
    normals = np.column_stack([xy, np.sqrt(1 - (xy ** 2).sum(1))])          # the visible half of a round lobe
    for sun3 in ([-0.35, 0.54, 0.76], [-0.6, 0.8, 0.0], [0.3, 0.4, -0.866]):
        sun3 = np.array(sun3) / np.linalg.norm(sun3)
        (fx, fy), dim = lobe_light(sun3)
        lambert = normals @ sun3
        brightest = xy[np.argmax(lambert)]
        assert (fx - 0.5) / 0.45 == pytest.approx(brightest[0], abs=0.04)        # focal = brightest point seen
        assert (0.5 - fy) / 0.45 == pytest.approx(brightest[1], abs=0.04)
        lit_share = float((lambert > 0).mean())                                # lit share of the disc as seen
        assert dim == pytest.approx(LOBE_DIM * (1 - lit_share), abs=0.01)
    front, _ = _scape(sun_x=-0.6, sun_y=0.8, sun_z=2.0, self_shadow=0.0)
    back, _ = _scape(sun_x=-0.6, sun_y=0.8, sun_z=-0.5, self_shadow=0.0, silver=0.6)
    f, b = _stops(front)["lobe1-0"], _stops(back)["lobe1-0"]
    assert _rgb(b[0].get("stop-color")) < _rgb(f[0].get("stop-color"))         # backlit lobes are greyer
    gf = [g for g in front.iter(SVG + "radialGradient") if g.get("id") == "lobe1-0"][0]
    gb = [g for g in back.iter(SVG + "radialGradient") if g.get("id") == "lobe1-0"][0]
    assert abs(float(gf.get("fx")) - 0.5) < abs(float(gb.get("fx")) - 0.5)     # a high front sun lights the dome head-on
    rim = [g for g in back.iter(SVG + "linearGradient") if g.get("id") == "rim1"][0].findall(SVG + "stop")[-1]
    assert float(rim.get("stop-opacity")) > 0.6                                   # and the backlit rim glows more
