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


def test_plate_4_1_steps_to_full_coverage(host):
    """Thesis 4.1.4 / Figure 4.4: 250,000 cells on a 50-triangle object covered in 110 steps.

    The thesis gives neither the object's shape nor the number of seeds; the time to full
    coverage is the largest distance from a cell to its nearest seed, so it moves with the seed
    draw (seeds 1-3 of our 24-seed recipe: see the note) and with the object's extent in cells.
    Accepted within 25 % of 110; 95 % coverage must come well before full coverage (the long
    tail of the last corners that Figure 4.4 shows).
    """
    rep = reports(host, "meshes/plate-4-1")
    full, p95 = rep["cells.voronoi.steps_to_full"], rep["cells.voronoi.steps_to_95"]
    assert abs(full - 110) <= 0.25 * 110
    assert p95 < full
