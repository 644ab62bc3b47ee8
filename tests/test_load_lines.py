"""lines.load: SVG paths as Polylines (y up, mm or user units), extruded; no closed path = check error."""
from __future__ import annotations

import numpy as np
import pytest

from procgen.exchange.svg_read import read_svg
from procgen.recipes import check_recipe
from procgen.errors import RecipeError
from procgen.runner import run
from procgen.data import builtin_rules_dir


def _run(host, tmp_path, steps):
    recipe = check_recipe({"steps": steps}, host, str(tmp_path / "r.toml"), tmp_path)
    return run(recipe, host, progress=False).state


def test_logo_lines_are_the_drawing_flipped_y_up_in_mm(host, tmp_path):
    svg = builtin_rules_dir() / "data" / "leaf-logo.svg"
    st = _run(host, tmp_path, [{"rule": "lines.load", "params": {"file": str(svg), "units": "mm", "scale": 2.0}}])
    pl = st.domains["outline"]
    d = read_svg(svg)
    assert pl.n_lines == 5 and list(pl.closed) == [c for _, c in d.polylines] == [True, True, True, False, True]
    assert pl.bounds == (0.0, 120.0, 0.0, 120.0)              # 60 mm page, scale 2
    for i, (p, _) in enumerate(d.polylines):
        np.testing.assert_allclose(pl.line(i), np.column_stack([p[:, 0], 60.0 - p[:, 1]]) * 2.0, rtol=1e-6)
    tip = pl.line(0)[np.argmax(pl.line(0)[:, 1])]
    np.testing.assert_allclose(tip, [2 * (28 + 2), 2 * (60 - 3 - 1)], rtol=1e-6)   # leaf tip, layer translate(2,1)


def test_closed_outlines_extrude_into_watertight_slabs_with_their_holes(host, tmp_path):
    import shapely
    st = _run(host, tmp_path, [{"rule": "lines.load", "params": {"file": "data/leaf-logo.svg", "closed_only": True}},
                               {"rule": "mesh.extrude", "params": {"depth": 4.0, "spacing": 2.0}}])
    m = st.domains["solid"].to_trimesh()
    assert m.is_watertight and m.is_winding_consistent
    leaf, window1, window2, sun = (shapely.Polygon(st.domains["outline"].line(i)) for i in range(4))
    area = (leaf - window1 - window2 | sun).area                 # the leaf with two windows, and the sun
    assert st.reports["solid.parts"] == 2 and st.reports["solid.holes"] == 2
    assert m.volume == pytest.approx(area * 4.0, rel=0.01)
    assert [p.is_watertight for p in m.split(only_watertight=False)] == [True, True]


def test_svg_without_a_closed_path_fails_at_check_for_an_extrusion(host, tmp_path):
    (tmp_path / "strokes.svg").write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 10 10">'
                                          '<path d="M 1 1 C 3 0 5 9 9 9"/></svg>')
    steps = [{"rule": "lines.load", "params": {"file": "strokes.svg", "closed_only": True}},
             {"rule": "mesh.extrude"}]
    with pytest.raises(RecipeError, match=r"steps\[0\].*strokes\.svg: no closed path") as e:
        check_recipe({"steps": steps}, host, "r.toml", tmp_path)
    assert "\n" not in str(e.value)
    pl = _run(host, tmp_path, [{"rule": "lines.load", "params": {"file": "strokes.svg"}}]).domains["outline"]
    assert pl.n_lines == 1 and not pl.closed[0]
