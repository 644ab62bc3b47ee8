"""Thesis properties of the extra crack and peeling plates (3DSCA thesis 5.2.6, 5.3.2; seed 000).

* Plate 5.9: the field four times stronger on 4.86x as many cells starts with a larger share of
  unstable cells (thesis: 28,634 of 98,224 against 198,440 of 477,006), each run keeps its own
  report, and the stronger field's cracks are wider (the thesis's (e) "almost invisible", (f)
  "thick"), recomputed from the cells' crack widths.
* Figure 5.19: the per-CM-step series of a run: the released share recomputed from the
  spectrum before and after, never falling; the modules' count ends at zero.
* Figure 5.28: the peeling-group convergence reaches 99.9 % within its passes, and the levels
  it counts are a distance transform (every level-k cell touches a level k-1 cell of its group).
* Plate 5.7: two Y cracks born apart on a single-direction field stop short of each other.
* Plate 5.11/5.12: the crack mirror flips with the light: a sun from the opposite azimuth puts
  the highlight where the shadow was, at the Snell offset t tan(asin(sin a / n)).
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from procgen.recipes import load_recipe
from procgen.runner import run


def _run(host, name: str, overrides: list[str], upto: str | None = None, outputs: bool = False):
    recipe = load_recipe(name, host, overrides)
    if upto is not None:
        cut = max(i for i, s in enumerate(recipe.steps) if s.id == upto)
        recipe = dataclasses.replace(recipe, steps=recipe.steps[:cut + 1])
    if not outputs:
        recipe = dataclasses.replace(recipe, outputs=[])
    return run(recipe, host, seed=1, progress=False).state


# -- Plate 5.9 --------------------------------------------------------------------------------
@pytest.fixture(scope="module")
def vase(host):
    """(e) and (f) of plate 5.9 at 1/50 of the thesis's cells (the same 4.86 ratio), 2 series each."""
    over = ["steps.cells_e.params.target_cells=1965", "steps.cells_f.params.target_cells=9540",
            "steps.cracks_e.params.resistance=1.0", "steps.cracks_f.params.resistance=1.0",
            "steps.cracks_e.max_iterations=2", "steps.cracks_f.max_iterations=2"]
    return _run(host, "meshes/plate-5-9", over, upto="cracks_f")


def test_plate_5_9_stronger_field_more_unstable_each_run_its_own_report(vase):
    rep = vase.reports
    e, f = rep["cracks_e.unstable_start_fraction"], rep["cracks_f.unstable_start_fraction"]
    assert 0.0 < e < f <= 1.0, (e, f)
    # the shares are recomputed from the relaxed field (before any crack) and mR
    for run_id in ("e", "f"):
        cells = vase.domains[f"cells_{run_id}"]
        assert rep[f"cracks_{run_id}.active_cells"] == cells.n_cells
        assert rep[f"cracks_{run_id}.unstable_start_cells"] == round(
            rep[f"cracks_{run_id}.unstable_start_fraction"] * cells.n_cells)
    assert rep["cells_f.n_cells"] / rep["cells_e.n_cells"] == pytest.approx(477006 / 98224, rel=0.15)
    assert rep["vase_e.n_faces"] == 480
    # the shared cracks.* keys hold the last run's numbers; (e)'s own survive beside them
    assert rep["cracks.unstable_start_fraction"] == rep["cracks_f.unstable_start_fraction"] != e


def test_plate_5_9_recipe_draws_e_faint_and_f_thick(vase):
    """The card's contrast between (e)'s faint cracks and (f)'s thick ones.  The thesis ran (e)
    and (f) with different crack parameters without saying which; ours give (e) a width scale
    24 times (f)'s, so this checks the recipe's own choice reaches the picture (with equal width
    scales the two runs' median widths are within a few per cent of each other)."""
    widths = {}
    for run_id in ("e", "f"):
        w = np.asarray(vase.domains[f"cells_{run_id}"]["crack__width"])[:, -1]
        assert (w > 0).sum() > 20
        widths[run_id] = float(np.median(w[w > 0]))
    assert widths["f"] > 1.5 * widths["e"], widths


# -- Figure 5.19 ------------------------------------------------------------------------------
def test_fig_5_19_series_matches_the_spectrum(host):
    over = ["steps.cells.params.target_cells=3000", "steps.cracks.max_iterations=4"]
    state = _run(host, "meshes/plate-5-10", over, upto="cracks")
    before = _run(host, "meshes/plate-5-10", ["steps.cells.params.target_cells=3000"], upto="stress")
    s0 = np.asarray(before.domains["cells"]["stress__spectrum"])[:, -1].sum()
    s1 = np.asarray(state.domains["cells"]["stress__spectrum"])[:, -1].sum()
    series = state.domains["cracks_series"]
    alive, released, unstable = series.line(0), series.line(1), series.line(2)
    assert len(alive) == state.reports["cracks.cm_steps"] > 10
    assert alive[-1, 1] == 0 and alive[:, 1].max() == state.reports["cracks.max_modules"] > 0
    assert np.all(np.diff(released[:, 1]) >= -1e-9)                 # release only ever removes
    assert released[-1, 1] == pytest.approx(100.0 * (1.0 - s1 / s0), rel=1e-9)
    assert len(unstable) == state.reports["cracks.series"]
    assert unstable[-1, 1] == pytest.approx(100.0 * state.reports["cracks.unstable_fraction"])


# -- Figure 5.28 ------------------------------------------------------------------------------
def test_fig_5_28_peeling_converges_and_levels_are_a_distance_transform(host):
    from procgen_cracks.peel import sharp_links

    state = _run(host, "meshes/fig-5-28", ["steps.cells.params.target_cells=8000"])
    rep = state.reports
    assert rep["peel.converged_share"] >= 0.999
    assert 1 <= rep["peel.passes_to_target"] <= rep["peel.passes"]
    curve = state.domains["peel_convergence"].line(0)[:, 1]
    k = rep["peel.passes_to_target"]
    assert np.all(np.diff(curve[:k + 1]) > 0)                       # every pass adds cells
    cells = state.domains["cells"]
    level = np.asarray(cells["peel__level"])
    group = np.asarray(cells["peel__group"])
    graph = cells.cell_graph("von_neumann")
    keep = ~sharp_links(cells, graph, 30.0)
    # the links both ways (the cross-edge graph need not list a link from both of its cells)
    r = np.concatenate([graph.rows[keep], graph.indices[keep]])
    c = np.concatenate([graph.indices[keep], graph.rows[keep]])
    same = (group[r] == group[c]) & (group[r] >= 0)
    best = np.full(len(level), np.iinfo(np.int64).max)
    np.minimum.at(best, r[same], level[c[same]])
    deep = (level >= 2) & (group >= 0)
    assert deep.any()
    assert np.all(best[deep] == level[deep] - 1)


# -- Plate 5.7 --------------------------------------------------------------------------------
def test_plate_5_7_two_y_cracks_stop_short_of_each_other(host):
    state = _run(host, "meshes/plate-5-7", [], upto="cracks")
    rep = state.reports
    assert rep["cracks.cracks"] == 2 and rep["cracks.meetings"] == 0
    assert rep["cracks.lost_at_border"] == 0 and rep["cracks.stopped_by_potential"] >= 2
    cells = state.domains["cells"]
    cid = np.asarray(cells["crack__id"])[:, -1]
    xyz = np.asarray(cells.center3d)
    a, b = xyz[cid == 0], xyz[cid == 1]
    # they run past each other along x (en echelon) ...
    assert min(a[:, 0].max(), b[:, 0].max()) > max(a[:, 0].min(), b[:, 0].min())
    # ... yet no cell of one touches a cell of the other
    gap = np.min(np.linalg.norm(a[:, None, :2] - b[None, :, :2], axis=2))
    assert gap > 2.0 * float(cells.size)


# -- crack mirror (Plates 5.11, 5.12) ---------------------------------------------------------
def test_crack_mirror_flips_with_the_light(host):
    from procgen_cracks.mirror import mirror_bands
    from procgen_cracks.render_rules import crack_segments, parse_light, stack_layer

    recipe = load_recipe("meshes/plate-5-11", host, ["steps.cells.params.target_cells=3000"])
    cut = next(i for i, s in enumerate(recipe.steps) if s.id == "cracks")
    recipe = dataclasses.replace(recipe, steps=recipe.steps[:cut + 1], outputs=[])
    state = run(recipe, host, seed=1, progress=False).state
    cells = state.domains["cells"]
    seg = crack_segments(cells, state.domains["cracks"], stack_layer(cells, -1))
    assert len(seg) > 20
    t = np.full(len(seg), 0.01)
    elev, n = 40.0, 1.5
    sh_a, hi_a, front_a = mirror_bands(cells, seg, t, parse_light([20.0, elev]), refraction=n)
    sh_b, hi_b, front_b = mirror_bands(cells, seg, t, parse_light([200.0, elev]), refraction=n)
    assert front_a.all() and front_b.all()
    np.testing.assert_allclose(hi_b.a, sh_a.a, atol=1e-12)
    np.testing.assert_allclose(hi_b.b, sh_a.b, atol=1e-12)
    np.testing.assert_allclose(sh_b.a, hi_a.a, atol=1e-12)
    np.testing.assert_allclose(hi_b.wa, sh_a.wa, atol=1e-12)
    # the offset: Snell's t tan(asin(sin a1 / n)) times the share of the light across the segment
    ab = seg.b - seg.a
    across = np.column_stack([-ab[:, 1], ab[:, 0]]) / np.linalg.norm(ab, axis=1)[:, None]
    # the plane's facet frame maps to the world's x-y up to a rotation: compare magnitudes
    fr = cells.layout.frames
    tang = parse_light([20.0, elev])
    t2 = np.column_stack([fr.ex[seg.face] @ tang, fr.ey[seg.face] @ tang])
    side = np.abs(np.sum(across * t2 / np.linalg.norm(t2, axis=1)[:, None], axis=1))
    a1 = np.radians(90.0 - elev)
    a2 = np.arcsin(np.sin(a1) / n)
    np.testing.assert_allclose(sh_a.wa, 0.01 * np.tan(a2) * side, rtol=1e-9, atol=1e-15)


# -- Plate D-19 -------------------------------------------------------------------------------
def test_d_19_flowers_point_along_the_stressed_axis(host):
    """A field along axis 0 only: every painted flower is a petal pair along the facet's ex."""
    from procgen_cracks.flowers3d import flower_cells, star_radius

    recipe = load_recipe("meshes/plate-5-5", host, ["steps.cells.params.cell_size=0.01",
                                                    "steps.stress.params.percent=[100.0, 0.0, 0.0, 0.0]",
                                                    "steps.stress.params.jitter=0.0"])
    recipe = dataclasses.replace(recipe, steps=recipe.steps[:4], outputs=[])
    cells = run(recipe, host, seed=1, progress=False).state.domains["cells"]
    spec = np.asarray(cells["stress__spectrum"])[:, -1]
    every, size = 10, 0.45
    inside = flower_cells(cells, spec, every, size)
    ij = np.asarray(cells.ij)
    d = ij[inside] - np.rint(ij[inside] / every).astype(np.int64) * every
    # petals reach out to size * every cells along x and stay within the gap width along y
    assert np.abs(d[:, 0]).max() == int(np.floor(size * every + 0.5))
    assert np.abs(d[:, 1]).max() <= 1
    # the star outline: tips at the petal lengths, 0.22 of the longest between two petals
    tips = np.array([[4.0, 1.0, 2.0, 3.0]])
    th = np.array([0.0, np.pi / 4, np.pi / 2, np.pi, np.pi / 8, 5 * np.pi / 4])
    r = star_radius(th, np.repeat(tips, len(th), axis=0))
    np.testing.assert_allclose(r, [4.0, 1.0, 2.0, 4.0, 0.88, 1.0])
