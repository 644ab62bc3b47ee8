"""The 3DSCA thesis's own numbers, measured by the shipped recipes (Gobron's thesis, seed 000).

Each test runs a recipe as `procgen run` does (no exports) and compares a report with the figure
the thesis states, within a tolerance argued beside it.
"""
from __future__ import annotations

import numpy as np
import pytest

from procgen.ca.coverage import disc_completion
from procgen.recipes import load_recipe
from procgen.runner import run


def reports(host, name: str, *overrides: str, seed: int = 1) -> dict:
    return run(load_recipe(name, host, list(overrides)), host, seed=seed, progress=False).state.reports


def test_disc_completion_counts_the_ideal_circle_only():
    dist = np.array([0.0, 1.0, 2.0, 3.0, np.nan])
    reached = np.array([True, True, False, True, True])
    assert disc_completion(reached, dist, 2.0) == pytest.approx(2 / 3)   # NaN and r > 2 left out
    assert disc_completion(reached, dist, 1.0) == 1.0


@pytest.mark.parametrize("mode", ["unfold", "pairs"])
def test_plate_3_2_disc_completion(host, mode):
    """Thesis plate 3.2: the disc is "completed at 87 %" at radius 10 and 99.9 % at radius 70.

    Tolerances.  r = 10: the ideal circle holds ~314 cells and its ragged rim ~63 of them, so
    one run (the thesis shows one) moves by +-2 points between seeds (SD over 8 seeds: 2.2
    unfold, 2.0 pairs), and the thesis counted pixels of a rendered image, not cell centres;
    our mean is 95 % (unfold) / 94 % (pairs): accepted within 10 points of 87 %.  r = 70: the rim
    is 3 % of the ~15,400 cells; SD 0.15 points; the thesis-literal pairs mode loses up to a
    point along the folded edge (one partner per edge cell): accepted within 1.5 points of 99.9 %.
    """
    rep = reports(host, "meshes/plate-3-2", f'steps.cells.params.neighbours="{mode}"')
    assert abs(rep["cells.voronoi.completion_r10"] - 0.87) <= 0.10
    assert abs(rep["cells.voronoi.completion_r70"] - 0.999) <= 0.015
    assert rep["cells.voronoi.completion_r70"] > rep["cells.voronoi.completion_r10"]


@pytest.mark.slow
def test_plate_4_1_steps_to_full_coverage(host):
    """Thesis 4.1.4 / Figure 4.4: 250,000 cells on a 50-triangle object covered in 110 steps.

    The thesis gives neither the object's shape nor the number of seeds; the time to full
    coverage is the largest distance from a cell to its nearest seed, so it moves with the seed
    draw and with the object's extent in cells.  Our 24 seeds (not tuned to the thesis) take
    129, 135 and 141 steps with seeds 1-3: 17-28 % above 110, so the thesis probably used more
    seeds or a more compact object.  Accepted within 30 % of 110; 95 % coverage must come well
    before full coverage (the long tail of the last corners that Figure 4.4 shows).
    """
    rep = reports(host, "meshes/plate-4-1")
    full, p95 = rep["cells.voronoi.steps_to_full"], rep["cells.voronoi.steps_to_95"]
    assert abs(full - 110) <= 0.30 * 110
    assert p95 < full


@pytest.mark.slow
def test_plate_4_2_patina_saturates_about_nine_times_later_than_voronoi(host):
    """Thesis 4.2.4 / Figure 4.9: on ~220,000 cells the patina saturates "about 9 times" later
    than the systematic Voronoi propagation (950 vs 110 steps: 8.6), and its seeds "have very
    strong propagation difficulties at the beginning".

    Both times are steps to 95 % (our patina leaves its strongest cells sound, so it never reaches
    100 %), the Voronoi diagram being plate 4.1's 24 seeds on the same cup cells.  The thesis's
    ratio compares two different runs whose seed counts it does not give; the Voronoi time alone
    moves by about 15 % with the seed draw: accepted within a third of 9.  The hard start: the
    patina spends a larger share of its saturation time below 5 % than the Voronoi diagram does.
    (The full-size recipe: about a minute; a smaller cup changes the ratio, since new seeds come
    per cell per step.)
    """
    rep = reports(host, "meshes/plate-4-2")
    assert abs(rep["cells.corrosion.saturation_ratio"] - 9.0) <= 3.0
    assert rep["cells.corrosion.start_share"] > 1.5 * rep["cells.voronoi.start_share"]


def test_surface_distances_on_the_fold_match_the_flattened_square():
    """Plate 3.2's fold flattened by rotating the second triangle back about the shared diagonal:
    the surface distance from the seed to every cell is the planar distance there (an independent
    reference for the unfolding used by the completion measure)."""
    from procgen.ca.cells import cell_distances
    from procgen_surface.domain import SurfaceCells

    v = np.array([[0, 0, 0], [0, 2, 0], [2, 2, 0], [1.866025404, 0.133974596, -0.707106781]])
    sc = SurfaceCells.from_mesh(v, np.array([[0, 1, 2], [0, 2, 3]]), cell_size=0.05)
    k = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    perp = lambda p: p - (p @ k) * k                         # noqa: E731
    a1, a2 = perp(v[3]) / np.linalg.norm(perp(v[3])), perp(np.array([2.0, 0, 0]))
    a2 /= np.linalg.norm(a2)
    rot = np.column_stack([k, a2, np.cross(k, a2)]) @ np.column_stack([k, a1, np.cross(k, a1)]).T
    flat = np.where((sc.face == 1)[:, None], sc.center3d @ rot.T, sc.center3d)
    assert np.allclose(rot @ v[3], [2, 0, 0]) and np.allclose(flat[:, 2], 0, atol=1e-9)
    seed = int(np.argmin(np.linalg.norm(sc.center3d - [1.08, 0.92, 0.0], axis=1)))
    d = cell_distances(sc, seed)
    np.testing.assert_allclose(d, np.linalg.norm(flat - flat[seed], axis=1), atol=1e-9)
