"""mesh.extrude: several shapes, holes, islands in holes, both SVG fill rules; every part a
watertight slab whose volume is the region's area times the depth."""
from __future__ import annotations

import numpy as np
import pytest
import shapely

from procgen import InputError, Polylines, State
from procgen.builtin.solids import Extrude, winding_numbers


def _square(x0: float, y0: float, s: float) -> np.ndarray:
    return np.array([[x0, y0], [x0 + s, y0], [x0 + s, y0 + s], [x0, y0 + s]], float)


def _extrude(rings, closed=True, **params) -> State:
    st = State(seed=4)
    st.add_domain("outline", Polylines.from_list(rings, closed=closed))
    rule = Extrude.from_params({"spacing": 0.05, "depth": 0.3, **params})
    st.rule_name = rule.name
    rule.step(st)
    return st


def _parts(st: State):
    m = st.get("solid")
    tm = m.to_trimesh()
    assert np.all(m.edge_valence == 2) and tm.is_winding_consistent
    return tm, tm.split(only_watertight=False)


def test_a_frame_with_an_island_and_a_separate_triangle():
    frame, hole, island = _square(0, 0, 1), _square(0.3, 0.3, 0.4), _square(0.4, 0.4, 0.2)
    tri = np.array([[2.0, 0.0], [2.6, 0.0], [2.3, 0.7]])
    st = _extrude([frame, hole[::-1], island, tri])          # directions do not matter for evenodd
    tm, parts = _parts(st)
    area = 1 - 0.16 + 0.04 + 0.21
    assert tm.volume == pytest.approx(0.3 * area, rel=1e-12)  # straight sides: corners kept exactly
    assert sorted(round(p.volume / 0.3, 9) for p in parts) == [0.04, 0.21, 0.84]
    assert all(p.is_watertight for p in parts)
    assert (st.reports["solid.parts"], st.reports["solid.holes"]) == (3, 1)
    pts = np.array([[0.15, 0.15, 0.15], [0.35, 0.5, 0.15], [0.5, 0.5, 0.15], [2.3, 0.2, 0.15], [1.5, 0.5, 0.15]])
    assert tm.contains(pts).tolist() == [True, False, True, True, False]   # frame, hole, island, triangle, gap


def test_fill_rules_on_nested_and_overlapping_rings():
    outer, inner = _square(0, 0, 1), _square(0.25, 0.25, 0.5)
    same = _extrude([outer, inner], fill="nonzero")                   # same direction: no hole
    assert _parts(same)[0].volume == pytest.approx(0.3, rel=1e-12)
    reverse = _extrude([outer, inner[::-1]], fill="nonzero")          # reversed: a hole
    assert _parts(reverse)[0].volume == pytest.approx(0.3 * 0.75, rel=1e-12)
    a, b = _square(0, 0, 1), _square(0.5, 0.5, 1)                     # overlapping quarter
    xor = _extrude([a, b])
    union = _extrude([a, b], fill="nonzero")
    assert _parts(xor)[0].volume == pytest.approx(0.3 * 1.5, rel=1e-12)
    assert _parts(union)[0].volume == pytest.approx(0.3 * 1.75, rel=1e-12)


def test_curved_outline_with_sharp_tips_stays_watertight():
    """A crescent (two arcs meeting at sharp tips) and a star: narrow tips force the boundary
    refinement; the volume matches shapely's area of the same polygon."""
    t = np.linspace(0, 2 * np.pi, 400, endpoint=False)
    disc = shapely.Polygon(np.column_stack([np.cos(t), np.sin(t)]))
    bite = shapely.Polygon(np.column_stack([0.45 + 0.85 * np.cos(t), 0.85 * np.sin(t)]))
    crescent = np.asarray((disc - bite).exterior.coords)
    k = np.arange(10)
    r = np.where(k % 2 == 0, 0.9, 0.3)
    star = np.column_stack([3 + r * np.cos(k * np.pi / 5), r * np.sin(k * np.pi / 5)])
    st = _extrude([crescent, star], spacing=0.08, depth=0.2)
    tm, parts = _parts(st)
    want = (disc - bite).area + shapely.Polygon(star).area
    assert tm.volume == pytest.approx(0.2 * want, rel=2e-3)           # curves thinned within 2 % of spacing
    assert len(parts) == 2 and all(p.is_watertight for p in parts)


def test_winding_numbers_and_an_outline_without_area():
    sq = _square(0, 0, 1)
    pts = np.array([[0.5, 0.5], [1.5, 0.5]])
    assert winding_numbers(sq, pts).tolist() == [1, 0]
    assert winding_numbers(sq[::-1], pts).tolist() == [-1, 0]
    with pytest.raises(InputError, match="no closed ring"):
        _extrude([sq], closed=False)
