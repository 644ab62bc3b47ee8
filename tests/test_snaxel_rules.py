"""Snaxel clouds through procgen: recipes, outputs other tools read, reports, bad input."""
from __future__ import annotations

import io
import json
import re
import xml.etree.ElementTree as ET

import numpy as np
import pytest
from _svg_path import d_points
from shapely.geometry import LineString, Polygon

from procgen import RecipeError, run
from procgen.recipes import load_recipe

SVG = "{http://www.w3.org/2000/svg}"

SMALL = """
[recipe]
name = "small_cloud"
seed = 3

{mesh_steps}
[[steps]]
rule = "{rule}"
{until}
[steps.params]
{params}

{outputs}
"""

# the thesis's Table 4.5 / Table 4.2 row 4.2(e) scaled by 1/4 to a 300-unit domain
MESH_STEPS = """
[[steps]]
rule = "points.poisson_disk"
params = { domain = "points", width = 300.0, height = 300.0, radius = 2.0 }

[[steps]]
rule = "mesh.delaunay"
params = { points = "points", mesh = "tessellation" }
"""
BASE = dict(bounds=[0.0, 0.0, 300.0, 300.0], radius=2.0, table=[[0, 12.5, 100], [12.5, 37.5, 250], [37.5, 50, 375], [50, 6.25]],
            t_max=37.5, g_min=60.0, g_max=62.5, n_c=3, c_min=1.5, margin=5.0)


def toml_value(v) -> str:
    if isinstance(v, str):
        return json.dumps(v)
    if isinstance(v, list):
        return "[" + ", ".join(toml_value(x) for x in v) + "]"
    return repr(v)

CLOUD_OUTPUTS = """
[[outputs]]
domain = "cloud"
format = "cloud_svg"
file = "cloud.svg"

[[outputs]]
domain = "cloud_history"
format = "cloud_process_svg"
file = "process.svg"

[[outputs]]
domain = "cloud_view"
format = "cloud_view_svg"
file = "view.svg"

[[outputs]]
domain = "cloud_history"
format = "cloud_gif"
file = "growth.gif"

[[outputs]]
domain = "cloud_history"
format = "cloud_anim_svg"
file = "growth.svg"
"""


def recipe_file(tmp_path, extra: dict | None = None, rule: str = "snaxel.grow", outputs: str = CLOUD_OUTPUTS,
                name: str = "r.toml", mesh: bool = False):
    """A small cloud recipe: lazy tiles, or with ``mesh`` an eager Poisson + Delaunay mesh."""
    until = 'until = "stable"\nmax_iterations = 20000' if rule == "snaxel.grow" else ""
    params = dict(BASE, **(extra or {}))
    if mesh:
        params["mesh"] = "tessellation"
    p = tmp_path / name
    p.write_text(SMALL.format(rule=rule, until=until, outputs=outputs, mesh_steps=MESH_STEPS if mesh else "",
                              params="\n".join(f"{k} = {toml_value(v)}" for k, v in params.items())))
    return p


def grow(tmp_path, host, extra: dict | None = None, seed: int | None = None, out: str = "out", mesh: bool = False):
    rec = load_recipe(recipe_file(tmp_path, extra, mesh=mesh), host)
    return run(rec, host, seed=seed, out_dir=tmp_path / out, progress=False)


def cloud_path(svg: bytes) -> ET.Element:
    root = ET.fromstring(svg)
    paths = list(root.iter(SVG + "path"))
    assert len(paths) == 1, "the cloud must be one path"
    return root, paths[0]


def test_cloud_svg_is_one_closed_path_other_tools_render(tmp_path, host):
    import cairosvg
    from PIL import Image

    res = grow(tmp_path, host)
    svg = (tmp_path / "out" / "cloud.svg").read_bytes()
    root, path = cloud_path(svg)
    d = path.get("d")
    assert d.startswith("M") and d.rstrip().endswith("z")
    assert [float(x) for x in root.get("viewBox").split()] == [0.0, 0.0, 300.0, 300.0]    # y-down, from 0 0
    assert root.get("width") == "800px" and "transform" not in svg.decode()
    # one vertex per snaxel: N_s reported in run.json matches the path
    reports = json.loads((tmp_path / "out" / "run.json").read_text())["reports"]
    assert reports["N_s"] == len(d_points(d)) and reports["N_v"] > reports["N_s"]
    # rasterised by cairo: the cloud interior is white, the corner is sky
    png = cairosvg.svg2png(bytestring=svg, output_width=300, output_height=300)
    img = np.asarray(Image.open(io.BytesIO(png)).convert("RGB"))
    cloud = res.state.get("cloud").line(0)
    poly = Polygon(cloud)
    inner = poly.representative_point()
    assert tuple(img[int(300 - inner.y), int(inner.x)]) == (255, 255, 255)
    assert tuple(img[2, 2]) == (0x8F, 0xB8, 0xE0)
    coverage = (img[:, :, 0].astype(float) - 0x8F) / (255 - 0x8F)      # antialiased edge pixels count partly
    assert coverage.sum() == pytest.approx(poly.area, rel=0.01)


def test_same_seed_byte_identical_other_seed_differs(tmp_path, host):
    grow(tmp_path, host, seed=5, out="a")
    grow(tmp_path, host, seed=5, out="b")
    grow(tmp_path, host, seed=6, out="c")
    for name in ("cloud.svg", "process.svg", "growth.gif"):
        assert (tmp_path / "a" / name).read_bytes() == (tmp_path / "b" / name).read_bytes()
    assert (tmp_path / "a" / "cloud.svg").read_bytes() != (tmp_path / "c" / "cloud.svg").read_bytes()


def test_process_view_and_animations(tmp_path, host):
    from PIL import Image

    res = grow(tmp_path, host, mesh=True)          # the eager mesh path, as the thesis tessellates
    hist = res.state.get("cloud_history")
    assert hist.n_lines >= 5 and np.all(np.diff(hist["snapshot__step"]) > 0)
    polys = [Polygon(hist.line(i)) for i in range(hist.n_lines)]
    assert all(p.is_valid for p in polys)
    assert all(a.buffer(-1e-6).within(b) for a, b in zip(polys, polys[1:]))      # nested contours
    proc = ET.fromstring((tmp_path / "out" / "process.svg").read_bytes())
    strokes = {p.get("stroke") for p in proc.iter(SVG + "path")} - {None, "none"}
    assert len(strokes) >= 5                                               # one colour per curve
    view = (tmp_path / "out" / "view.svg").read_text()
    assert "#d42020" in view and "#ffd21f" in view and "#2451c8" in view    # Fig 1.2 colour code
    gif = Image.open(tmp_path / "out" / "growth.gif")
    assert gif.n_frames == hist.n_lines
    counts = []
    for k in (0, gif.n_frames - 1):
        gif.seek(k)
        counts.append(int((np.asarray(gif.convert("RGB")) == 255).all(axis=2).sum()))
    assert counts[1] > 20 * max(counts[0], 1)
    anim = ET.fromstring((tmp_path / "out" / "growth.svg").read_bytes())
    assert len(list(anim.iter(SVG + "animate"))) == hist.n_lines


def test_reports_name_the_thesis_quantities(tmp_path, host):
    grow(tmp_path, host)
    rep = json.loads((tmp_path / "out" / "run.json").read_text())["reports"]
    for key in ("N_s", "N_v", "cloud.births", "cloud.merges", "cloud.holes", "cloud.clusters_grown", "cloud.steps"):
        assert key in rep
    assert rep["cloud.clusters_grown"] == 3 and len(rep["cloud.clusters"]) == 3
    assert rep["cloud.finished"] is True


@pytest.mark.parametrize("extra, words", [
    (dict(table=[[0, 50, 400], [40, 100, 25]]), ["table row 1", "overlapping"]),
    (dict(table=[[0, 50, 400], [100, 25], [50, 100, 30]]), ["table row 1"]),
    (dict(v_min=0.0), ["v_min"]),
    (dict(t_max=70.0), ["g_max", "t_max"]),
    (dict(w_s=1.2), ["w_s"]),
    (dict(strokes=[[10.0, 10.0, 320.0, 40.0]]), ["stroke 0", "outside the domain"]),
    (dict(sketch_svg="{svg}"), ["no stroke"]),
    (dict(seed_policy="tallest"), ["seed_policy", "uniform"]),
    (dict(bounds=[0.0, 0.0, 50.0, 50.0]), ["too small", "g_min"]),
    (dict(sketch_svg="/nonexistent/sketch.svg"), ["not found"]),
    (dict(source=[2.0, 150.0]), ["source", "margin"]),
])
def test_bad_input_is_one_line_error_before_compute(tmp_path, host, extra, words):
    svg = tmp_path / "empty.svg"
    svg.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 10 10"><g><text x="1" y="5">hi</text></g></svg>')
    extra = {k: (str(svg) if v == "{svg}" else v) for k, v in extra.items()}
    with pytest.raises(RecipeError) as err:
        load_recipe(recipe_file(tmp_path, extra), host)
    msg = str(err.value)
    assert "\n" not in msg and all(w in msg for w in words), msg


def test_sketch_from_shipped_svg_is_engulfed(tmp_path, host):
    from procgen_snaxel.rules import resolve_sketch
    from procgen_snaxel.sketch import strokes_from_svg

    res = grow(tmp_path, host, dict(sketch_svg="mushroom.svg", c_t=1.0, n_c=1, t_max=0.0, g_min=20.0, g_max=20.0))
    poly = Polygon(res.state.get("cloud").line(0))
    strokes = strokes_from_svg(resolve_sketch("mushroom.svg"), (0.0, 300.0, 0.0, 300.0))
    assert len(strokes) == 3
    for s in strokes:
        assert poly.contains(LineString(s))
    rep = res.run_info["reports"]
    assert rep["cloud.sketch_steps"] > 0


def test_cloudscape_composites_clouds_back_to_front(tmp_path, host):
    import cairosvg

    outputs = '[[outputs]]\ndomain = "sky"\nformat = "cloudscape_svg"\nfile = "sky.svg"\n'
    p = recipe_file(tmp_path, dict(scape="sky", n_clouds=3, n_c=2), rule="snaxel.cloudscape", outputs=outputs)
    res = run(load_recipe(p, host), host, out_dir=tmp_path / "o", progress=False)
    sky = res.state.get("sky")
    assert sky.n_lines == 3 and list(sky["cloud__depth"]) == [0, 1, 2]
    assert all(Polygon(sky.line(i)).is_valid for i in range(3))
    svg = (tmp_path / "o" / "sky.svg").read_bytes()
    root = ET.fromstring(svg)
    assert len(list(root.iter(SVG + "clipPath"))) == 3
    ids = [m for m in re.findall(rb'clip-path="url\(#cloud(\d)\)"', svg)]
    assert ids == [b"0", b"1", b"2"]                      # farthest first
    assert len(cairosvg.svg2png(bytestring=svg)) > 1000


def test_cloud_svg_options_stroke_gradient_smoothing():
    from procgen import Polylines
    from procgen_snaxel.exporters import cloud_svg

    t = np.linspace(0, 2 * np.pi, 40, endpoint=False)
    ring = np.column_stack([50 + 20 * np.cos(t), 50 + 15 * np.sin(t)])
    dom = Polylines(ring, [0, 40], closed=[True], bounds=(0.0, 100.0, 0.0, 100.0))
    plain = ET.fromstring(cloud_svg(dom))
    assert list(plain.iter(SVG + "path"))[0].get("stroke") is None
    styled = ET.fromstring(cloud_svg(dom, stroke="#334455", gradient=["#ffffff", "#c0c8d8"], smooth=2))
    path = list(styled.iter(SVG + "path"))[0]
    assert path.get("stroke") == "#334455" and path.get("fill").startswith("url(#")
    assert len(list(styled.iter(SVG + "linearGradient"))) == 1
    assert len(d_points(path.get("d"))) == 40 * 4            # two Chaikin passes: 4x the vertices
    with pytest.raises(Exception, match="smooth"):
        cloud_svg(dom, smooth=9)


def test_time_step_too_large_for_the_tessellation(tmp_path, host):
    from procgen import InputError

    rec = load_recipe(recipe_file(tmp_path, dict(dt=0.5)), host)
    with pytest.raises(InputError, match="dt = 0.5"):
        run(rec, host, progress=False)


def test_runner_frames_show_the_growth(tmp_path, host):
    """frames = {every = K}: the rule publishes before each frame, so it is the outline at that step."""
    p = recipe_file(tmp_path, dict(), outputs="")
    text = p.read_text().replace('max_iterations = 20000',
                                 'max_iterations = 20000\nframes = { every = 20, domain = "cloud", format = "cloud_svg" }')
    p.write_text(text)
    res = run(load_recipe(p, host), host, out_dir=tmp_path / "o", progress=False)
    frames = sorted((tmp_path / "o" / "frames" / "step0").glob("frame_*.svg"))
    assert len(frames) == res.run_info["reports"]["cloud.steps"] // 20
    areas = []
    for f in frames:
        d = cloud_path(f.read_bytes())[1].get("d")
        pts = d_points(d)
        areas.append(Polygon(pts).area)
    assert all(b >= a for a, b in zip(areas, areas[1:])) and areas[-1] > 3 * areas[0]


INKSCAPE_SKETCH = """<?xml version="1.0" encoding="UTF-8"?>
<svg xmlns="http://www.w3.org/2000/svg" xmlns:inkscape="http://www.inkscape.org/namespaces/inkscape"
     width="100mm" height="50mm" viewBox="0 0 200 100" version="1.1">
  <g inkscape:groupmode="layer" inkscape:label="Layer 1" id="layer1" transform="translate(20,10)">
    <path d="m 10,40 a 30,30 0 0 1 60,0" style="fill:none;stroke:#000000;stroke-width:1" />
  </g>
  <g inkscape:groupmode="layer" inkscape:label="Layer 2" id="layer2" transform="matrix(2,0,0,2,100,0)">
    <path d="M 0,40 C 0,20 20,20 20,40" style="fill:none;stroke:#000000" />
  </g>
</svg>
"""


def test_sketch_svg_honours_layer_transforms_arcs_and_curves(tmp_path):
    """An Inkscape 1.x file: a layer translated, a half-circle arc, a layer scaled with a Bezier.
    Mapped onto a 0..400 x 0..200 domain (2 units per viewBox unit, y flipped)."""
    from procgen_snaxel.sketch import strokes_from_svg

    p = tmp_path / "sketch.svg"
    p.write_text(INKSCAPE_SKETCH)
    arc, bez = strokes_from_svg(p, (0.0, 400.0, 0.0, 200.0))
    # arc: centre (20+40, 10+40) = (60, 50), radius 30, upper half (SVG y down) -> domain centre
    # (120, 100), radius 60, the bulge above the centre (y up)
    r = np.hypot(arc[:, 0] - 120.0, arc[:, 1] - 100.0)
    assert np.allclose(r, 60.0, atol=0.1) and len(arc) > 8
    assert arc[:, 1].max() == pytest.approx(160.0, abs=0.1) and np.all(arc[:, 1] >= 100.0 - 1e-6)
    # Bezier in a layer scaled by 2 and moved by 100: ends at (100, 80) and (140, 80) in the
    # viewBox -> (200, 40) and (280, 40) in the domain; its top (t = 1/2) at y = 80 - 2*15 = 50
    # -> domain y = 200 - 100 = 100
    assert bez[0] == pytest.approx([200.0, 40.0]) and bez[-1] == pytest.approx([280.0, 40.0])
    assert bez[:, 1].max() == pytest.approx(100.0, abs=0.5)       # within the flattening tolerance
