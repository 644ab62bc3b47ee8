"""Shape control and realism: seed-curve policies steer the silhouette, `procgen sweep` reports
Lovejoy's area-perimeter dimension and the aspect/solidity band of an ensemble."""
from __future__ import annotations

import json

import numpy as np
import pytest

from procgen_snaxel.fractal import perimeter_dimension
from procgen_snaxel.growth import CloudGrowth
from procgen_snaxel.params import GrowthParams
from procgen_snaxel.tiles import TiledTopology

S = 0.25      # the thesis's pixel lengths (and speeds) scaled by 1/4 (Poisson radius 1, fringe row 6.25)
SMALL = dict(radius=4 * S, v_min=5 * S, v_max=30 * S, G_max=10 * S, table=[[0, 50 * S, 400 * S], [50 * S, 150 * S, 1000 * S], [150 * S, 200 * S, 1500 * S],
                                  [200 * S, 25 * S]], t_max=150 * S, g_min=240 * S, g_max=250 * S, c_min=3 * S)


# The 20-seed bands (seeds 1-20, the gallery's quick Poisson radius 6) of every preset:
# ((aspect min, max), (solidity min, max)), aspect = box width / height, solidity = area / hull
# area, measured with `procgen sweep clouds/<preset> --grid steps.grow.params.radius=6.0
# --seeds 1-20` (NOTES.md gives the medians and D), rounded outwards to 0.01. A later change that
# moves a preset out of its band fails test_preset_stays_in_its_band. Re-measured for issue 37
# (a broken curve's pieces keep its travelled distance; snaxels stop on the margin / base line;
# humilis, congestus and stratocumulus grow on a cascade of length limits).
PRESET_BANDS = {
    "cumulus-humilis": ((1.41, 2.94), (0.66, 0.90)),
    "cumulus-congestus": ((0.29, 0.90), (0.61, 0.78)),
    "stratocumulus": ((1.63, 5.05), (0.53, 0.77)),
    "ash-plume": ((0.33, 1.19), (0.55, 0.77)),
}


@pytest.mark.parametrize("preset", ["cumulus-congestus", "stratocumulus", "ash-plume"])
def test_preset_stays_in_its_band(host, preset, tmp_path):
    """Seed 1 of each preset (humilis: seeds 1-20 in the sweep test below) inside its band."""
    from procgen import run
    from procgen.recipes import load_recipe

    rec = load_recipe(f"clouds/{preset}", host, ["steps.grow.params.radius=6.0"])
    rec.outputs.clear()
    rep = run(rec, host, seed=1, progress=False, out_dir=tmp_path).state.reports
    (a_lo, a_hi), (s_lo, s_hi) = PRESET_BANDS[preset]
    assert a_lo <= rep["cloud.aspect"] <= a_hi and s_lo <= rep["cloud.solidity"] <= s_hi, rep


def test_perimeter_dimension_of_known_shapes():
    a = np.array([1.0, 10.0, 100.0, 1000.0])
    assert perimeter_dimension(a, 3.5 * np.sqrt(a))[0] == pytest.approx(1.0)       # similar smooth shapes
    assert perimeter_dimension(a, 2.0 * a ** (1.35 / 2))[0] == pytest.approx(1.35)  # Lovejoy's clouds
    with pytest.raises(ValueError, match="different areas"):
        perimeter_dimension(np.ones(4), np.ones(4))


def grown(policy: str, seed: int, **kw) -> dict:
    cfg = GrowthParams(**SMALL, n_c=5, seed_policy=policy, seed_bias=6.0, seed_from="any", **kw)
    topo = TiledTopology(cfg.radius, 32.0, np.random.SeedSequence(seed))
    return CloudGrowth(topo, cfg, np.random.default_rng(seed)).run().report()


def test_seed_policies_steer_the_silhouette():
    """Same seeds: weighting seed curves by height makes taller clouds than weighting them by
    horizontal spread (aspect = width / height)."""
    tall = [grown("height", s)["aspect"] for s in (1, 2)]
    wide = [grown("spread", s)["aspect"] for s in (1, 2)]
    assert np.mean(tall) < 0.8 * np.mean(wide), (tall, wide)


LOVEJOY_D, LOVEJOY_ERR = 1.35, 0.05
"""Lovejoy ("Area-perimeter relation for rain and cloud areas", Science 216, 185-187, 1982): D =
1.35 +- 0.05 for cloud and rain areas from 1 to 1.2e6 km^2. Not a thesis number: the thesis
(seed 004) reports no fractal dimension or any other metric (its comparisons, Chapter 4, are by
eye); its tie to a fractal outline is section 3.5.1, "The small bumps of a cloud reside on big
bulges: a recursive subdivision of volume and surface" (Figure 3.18), which the length-limits
table is there to mimic."""


def test_sweep_reports_the_fractal_dimension_in_band(tmp_path, host):
    """The default cumulus ensemble (clouds/cumulus-humilis, seeds 1-20, the gallery's quick
    Poisson radius 6) has Lovejoy's area-perimeter D within his 1.35 +- 0.05 (LOVEJOY_D: his
    measurement, not the thesis's, which states none; section 3.5.1's "recursive subdivision of
    volume and surface" is what the table imitates). Measured as Lovejoy measured it (fractal.py:
    fixed pixel = the Poisson radius, log-binned fit): seeds 1-20 read 1.365 +- 0.020; four
    disjoint 20-seed ensembles (seeds 1-80) read 1.31-1.39, mean 1.35, SD 0.03, so the tolerance
    is his error bar, and the test takes 20 seeds because 3-seed ensembles spread as widely as
    the band (SD 0.03-0.09). Issue 37: with the preset's old single drop to the texture row D
    read 1.57 once every curve piece kept its row; the cascade of limits brought it back. The 20
    outlines also stay in the preset's aspect / solidity band (PRESET_BANDS)."""
    from procgen.sweep import sweep

    seeds = list(range(1, 21))
    results = sweep("clouds/cumulus-humilis", ["steps.grow.params.radius=6.0"], seeds, tmp_path / "sweep",
                    progress=False)
    assert [r.status for r in results] == ["done"] * len(seeds), [r.error for r in results]
    (stats,) = json.loads((tmp_path / "sweep" / "ensemble.json").read_text()).values()
    assert stats["runs"] == len(seeds) and stats["D_area_decades"] > 1.0 and stats["D_bins"] >= 10
    assert abs(stats["D"] - LOVEJOY_D) <= LOVEJOY_ERR, stats
    (a_lo, a_hi), (s_lo, s_hi) = PRESET_BANDS["cumulus-humilis"]
    assert a_lo <= stats["aspect_min"] <= stats["aspect_max"] <= a_hi
    assert s_lo <= stats["solidity_min"] <= stats["solidity_max"] <= s_hi


def _centre_x(policy: str, seed: int, guide) -> float:
    """Horizontal offset of the final outline's area centroid from the source (x = 0)."""
    from shapely.geometry import Polygon

    cfg = GrowthParams(**dict(SMALL, radius=2.0), n_c=4, seed_policy=policy, seed_bias=8.0, seed_from="any",
                       **({"guide_strokes": [[-300.0, -50.0, -300.0, 50.0]]} if policy == "sketch" else {"guide_grid": "g"}))
    g = CloudGrowth(TiledTopology(cfg.radius, 32.0, np.random.SeedSequence(seed)), cfg, np.random.default_rng(seed),
                    guide=guide).run()
    return Polygon(g.snake.xy()).centroid.x


def test_a_user_field_or_sketch_draws_the_next_clusters_towards_it():
    """A guide field rising to the right pulls the cloud right; a guide stroke far on the left
    pulls it left (same seeds, the same growth otherwise)."""
    import shapely

    ramp = lambda p: p[:, 0]                                                      # noqa: E731
    line = shapely.MultiLineString([[(-300.0, -50.0), (-300.0, 50.0)]])
    stroke = lambda p: -shapely.distance(shapely.points(p), line)                  # noqa: E731
    right, left = _centre_x("field", 1, ramp), _centre_x("sketch", 1, stroke)
    assert right > 5.0 and left < -5.0, (right, left)


def _check(tmp_path, host, extra: str) -> str:
    from procgen import RecipeError
    from procgen.recipes import check_recipe, load_recipe

    p = tmp_path / "r.toml"
    p.write_text(f'[recipe]\nname = "r"\n\n[[steps]]\nrule = "snaxel.grow"\nuntil = "stable"\n'
                 f'[steps.params]\nradius = 1.0\ng_min = 60.0\ng_max = 62.5\nt_max = 37.5\n{extra}\n')
    with pytest.raises(RecipeError) as err:
        check_recipe(load_recipe(p, host), host)
    msg = str(err.value)
    assert "\n" not in msg
    return msg


def test_procgen_check_refuses_bad_seed_policies_in_one_line(tmp_path, host):
    assert "seed_policy" in _check(tmp_path, host, 'seed_policy = "tallest"')
    assert "guide_grid" in _check(tmp_path, host, 'seed_policy = "field"')
    assert "guide_strokes or guide_svg" in _check(tmp_path, host, 'seed_policy = "sketch"')
    assert "ignores it" in _check(tmp_path, host, 'guide_strokes = [[0, 0, 10, 10]]')
    svg = tmp_path / "empty.svg"
    svg.write_text('<svg xmlns="http://www.w3.org/2000/svg" viewBox="0 0 10 10"><text>hi</text></svg>')
    assert "no stroke" in _check(tmp_path, host, f'seed_policy = "sketch"\nguide_svg = "{svg}"\n'
                                                 'bounds = [0.0, 0.0, 300.0, 300.0]')
    assert "'nowhere'" in _check(tmp_path, host, 'seed_policy = "field"\nguide_grid = "nowhere"')
