"""Exposure-driven ageing (not in the thesis): sun and rain exposure by ray casts, ageing weighted
by it, greying gated on rain."""
from __future__ import annotations

import sys

import numpy as np
import pytest
import trimesh

from procgen import InputError, MissingExtra, State
from procgen_surface.domain import SurfaceCells
from procgen_wood import exposure as ex
from procgen_wood.rules import AgeColour, Exposure
from procgen_wood.table import box


def _cells(v, f, n=20000) -> SurfaceCells:
    return SurfaceCells.from_mesh(v, f, target_cells=n)


def _run(rule, sc: SurfaceCells) -> State:
    st = State(seed=3)
    st.add_domain("cells", sc)
    rule.setup(st)
    rule.step(st)
    return st


@pytest.fixture(scope="module")
def shelter() -> SurfaceCells:
    """A 2 x 2 plate (top at z = 0.1) under a 1 x 1 roof floating at z = 0.6..0.7."""
    v1, f1 = box((-1, -1, 0), (1, 1, 0.1), 0.1)
    v2, f2 = box((-0.5, -0.5, 0.6), (0.5, 0.5, 0.7), 0.1)
    return _cells(np.vstack([v1, v2]), np.vstack([f1, f2 + len(v1)]), 15000)


@pytest.fixture(scope="module")
def sphere() -> SurfaceCells:
    s = trimesh.creation.icosphere(3)
    return _cells(s.vertices, s.faces, 10000)


def test_directions_are_unit_and_above_the_horizon():
    up = np.array([0, 0, 1.0])
    sun = ex.sun_directions(12, 45.0, up, np.array([0, -1.0, 0]))
    rain = ex.cone_directions(16, 25.0, up)
    for d in (sun, rain):
        assert np.allclose(np.linalg.norm(d, axis=1), 1)
        assert (d @ up > 0).all()
    assert np.degrees(np.arccos(rain @ up)).max() <= 25 + 1e-9
    assert sun[:, 1].mean() < 0                                    # the sun stands to the south
    noon = ex.sun_directions(1, 30.0, up, np.array([0, -1.0, 0]))[0]
    assert np.degrees(np.arcsin(noon[2])) == pytest.approx(60)     # noon elevation = 90 - latitude


def test_a_sheltered_underside_gets_no_rain_and_an_open_top_does(shelter):
    st = _run(Exposure(rain_spread=25.0), shelter)
    rain, sun = shelter["exposure__rain"], shelter["exposure__sun"]
    c, n = shelter.center3d, shelter.normal
    plate_top = (np.abs(c[:, 2] - 0.1) < 1e-9) & (n[:, 2] > 1 - 1e-12)    # flat, not rounded
    under_roof = plate_top & (np.abs(c[:, 0]) < 0.2) & (np.abs(c[:, 1]) < 0.2)
    open_top = plate_top & ((np.abs(c[:, 0]) > 0.75) | (np.abs(c[:, 1]) > 0.75))
    roof_bottom = (np.abs(c[:, 2] - 0.6) < 1e-9) & (n[:, 2] < -0.99)
    assert under_roof.sum() > 100 and open_top.sum() > 100
    assert (rain[under_roof] == 0).all() and (rain[roof_bottom] == 0).all()
    cos_mean = ex.cone_directions(16, 25.0, np.array([0, 0, 1.0]))[:, 2].mean()
    assert np.allclose(rain[open_top], cos_mean)                   # unoccluded: mean n.d exactly
    assert sun[under_roof].mean() < sun[open_top].mean() - 0.02         # low sun still slips in
    assert 0 <= rain.min() and rain.max() <= 1 and 0 <= sun.min() and sun.max() <= 1
    assert st.reports["cells.exposure.rain_sheltered_fraction"] > 0
    st2 = _run(Exposure(rain_spread=25.0, occlusion="none"), shelter)
    assert np.allclose(shelter["exposure__rain"][under_roof], cos_mean)   # no rays: no shelter
    _run(Exposure(rain_spread=25.0), shelter)                             # restore for other tests


def test_upward_faces_age_faster_than_downward_ones(sphere):
    _run(Exposure(latitude=0.0), sphere)
    n = sphere.normal
    age = np.random.default_rng(0).integers(150, 250, sphere.n_cells)   # isotropic CA ages
    sphere.add_field("ca__age", age.astype(np.int32), at="cell")
    _run(AgeColour(exposure=True, blend="ca_only"), sphere)
    w = sphere["weathering__age"]
    up, down = n[:, 2] > 0.5, n[:, 2] < -0.5
    assert w[up].mean() > 2 * w[down].mean()
    sun = sphere["exposure__sun"]
    assert sun[down].mean() < 0.25 * sun[up].mean()                 # only low sun reaches below
    assert sphere["exposure__rain"][up].min() > 0


def test_mean_age_is_monotone_in_exposure(sphere):
    _run(Exposure(latitude=30.0), sphere)
    age = np.random.default_rng(1).integers(150, 250, sphere.n_cells)
    sphere.add_field("ca__age", age.astype(np.int32), at="cell")
    _run(AgeColour(exposure=True, age_rain=0.0, blend="ca_only"), sphere)
    e, w = sphere["exposure__sun"], sphere["weathering__age"]
    bins = np.quantile(e, np.linspace(0, 1, 9))
    k = np.clip(np.searchsorted(bins, e, side="right") - 1, 0, 7)
    means = np.array([w[k == i].mean() for i in range(8)])
    assert np.all(np.diff(means) > 0)
    _run(AgeColour(exposure=False, blend="ca_only"), sphere)      # off: the thesis's isotropic value
    assert np.array_equal(sphere["weathering__age"], age.astype(float))


def test_rain_gate_keeps_sheltered_cells_brown(shelter):
    shelter.add_field("ca__age", np.full(shelter.n_cells, 432, np.int32), at="cell")
    rule = AgeColour(exposure=True, rain_gate=0.05, blend="ca_only")
    _run(rule, shelter)
    dry = shelter["exposure__rain"] < 0.05
    grey0 = np.asarray(rule.colors[rule.first_grey]) / 255
    rgb = shelter["weathering__color"]
    is_grey = np.zeros(len(rgb), bool)
    for c in rule.colors[rule.first_grey:]:
        is_grey |= np.all(np.isclose(rgb, np.asarray(c) / 255), axis=1)
    assert dry.sum() > 100 and not is_grey[dry].any()
    assert is_grey[~dry].mean() > 0.9 and grey0.shape == (3,)


def test_without_a_ray_engine_the_error_says_what_to_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "embreex", None)
    monkeypatch.setitem(sys.modules, "rtree", None)
    v, f = box((0, 0, 0), (1, 1, 1), 0.5)
    with pytest.raises(MissingExtra, match="embree"):
        ex.intersector(v, f)
    with pytest.raises(MissingExtra, match="occlusion"):               # refused at check time
        Exposure.from_params({"occlusion": "rays"})
    Exposure.from_params({"occlusion": "none"})


def test_cell_diagram_draws_every_cross_edge_link_once():
    import xml.etree.ElementTree as ET
    from procgen_wood.diagram import cells_svg
    v = np.array([[0, 0, 0], [1, 0.1, 0], [0.2, 1, 0], [-0.9, 0.3, 0]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    for nb in ("pairs", "unfold"):
        sc = SurfaceCells.from_mesh(v, f, cell_size=0.1, neighbours=nb)
        root = ET.fromstring(cells_svg(sc, stem="d"))
        ns = "{http://www.w3.org/2000/svg}"
        links = {tuple(sorted((int(a), int(b)))) for a, b in zip(sc.graph.rows[sc.graph.cross],
                                                               sc.graph.indices[sc.graph.cross])}
        assert len(root.findall(f"{ns}line")) == len(links) > 0
        assert len(root.findall(f"{ns}polygon")) == sc.n_cells + 2


def test_exposure_gated_births_make_a_sheltered_underside_lag(shelter):
    """ca.life with birth_field = exposure__birth: the plate under the roof (no rain, little sun)
    comes alive less often, so it ages less than the open plate; without the field both alike."""
    from procgen.ca.lifelike import LifeLike
    st = _run(Exposure(rain_spread=25.0, birth_floor=0.2), shelter)
    birth = shelter["exposure__birth"]
    assert birth.min() >= 0.2 and 0.9 < birth.max() <= 1.0
    assert st.reports["cells.exposure.birth_mean"] == pytest.approx(birth.mean())
    c, n = shelter.center3d, shelter.normal
    plate_top = (np.abs(c[:, 2] - 0.1) < 1e-9) & (n[:, 2] > 1 - 1e-12)
    under_roof = plate_top & (np.abs(c[:, 0]) < 0.2) & (np.abs(c[:, 1]) < 0.2)
    open_top = plate_top & ((np.abs(c[:, 0]) > 0.7) | (np.abs(c[:, 1]) > 0.7))
    assert birth[under_roof].max() < 0.55 < birth[open_top].min()
    ratio = {}
    for field in ("", "exposure__birth"):
        age = np.zeros(shelter.n_cells)
        for seed in range(3):
            rule = LifeLike.from_params({"rule": "25/357", "semantics": "table", "density": 0.1,
                                         "birth_field": field})
            st = State(seed=seed)
            st.add_domain("cells", shelter)
            st.rule_name = rule.name
            rule.setup(st)
            for k in range(80):
                st.iteration = k
                rule.step(st)
            age += shelter["ca__age"]
        ratio[field] = age[under_roof].mean() / age[open_top].mean()
    assert 0.7 < ratio[""] < 1.3                      # the thesis's CA: shelter makes little difference
    assert ratio["exposure__birth"] < 0.6 * ratio[""]  # gated births: the sheltered plate lags
