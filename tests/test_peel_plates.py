"""The peeling plates' recipes as a user runs them (shipped recipes, reduced cell counts).

Plate 5.20 (thesis 5.3.4(b), "an average step of the automatic peeling" of a gold animal under
dark-brown paint): the mid-peel frame must show both materials side by side, many groups of
varied size, not one body-wide group that keeps the paint on.  Band for the exposed gold: 30 % to
70 % of the painted area.  The plate's picture (d) is the middle of the peeling and shows the gold
and the paint in comparable amounts (its point is the contrast between them); with groups removed
shallowest first, the area gone lags the step count a little, so the lower bound is below a half;
above 70 % it would read as a bare gold animal with paint scraps, below 30 % as paint with a few
chips.  Plates 5.16 and 5.17 peel along the crack model's cracks, as the thesis does.
"""
from __future__ import annotations

import numpy as np
import pytest

from procgen import check_recipe, get_plugin_manager, run
from procgen.recipes import find_recipe, read_toml
from procgen_layers.stack import cell_areas

#: the cell count of the gallery's quick setting: the crack model and the peeling in seconds
CELLS = 20000


def run_plate(name: str, keep_after: str = "peel", **peel_params):
    """Run a shipped plate recipe up to its peel step (no frames or outputs), fewer cells."""
    host = get_plugin_manager()
    path = find_recipe(f"meshes/{name}", host)
    data = read_toml(path)
    steps = data["steps"]
    last = next(i for i, s in enumerate(steps) if s.get("id") == keep_after)
    data["steps"] = steps[:last + 1]
    data.pop("outputs", None)
    for s in data["steps"]:
        s.pop("frames", None)
        if s.get("id") == "cells":
            s["params"]["target_cells"] = CELLS
    data["steps"][last]["params"].update(peel_params)
    recipe = check_recipe(data, host, str(path), path.parent)
    return run(recipe, host, progress=False)


def test_plate_5_20_mid_peel_shows_a_band_of_gold_between_many_groups():
    res = run_plate("plate-5-20")
    sc = res.state.get("cells")
    reports = res.state.reports
    thick = np.asarray(sc["layers__thickness"])
    area = cell_areas(sc)
    painted = np.asarray(sc["peel__level"]) >= 0           # cells that held the paint
    gone = painted & (thick[:, 1] <= 0)
    share = area[gone].sum() / area[painted].sum()
    assert 0.30 <= share <= 0.70, share
    assert reports["peel.exposed_share"] == pytest.approx(share, rel=1e-9)
    group = np.asarray(sc["peel__group"])
    sizes = np.bincount(group[group >= 0], area[group >= 0])
    assert len(sizes) > 200                                  # many groups ...
    assert sizes.max() / sizes.sum() < 0.3                   # ... none dominating the body
    assert reports["peel.largest_group_share"] == pytest.approx(sizes.max() / sizes.sum(), rel=1e-9)
    big = np.sort(sizes)[::-1]
    assert big[0] > 20 * np.median(sizes)                    # of varied size
    # the gold shows on the peeled cells only; the paint is still on the others
    assert np.all(thick[~gone & painted & (np.asarray(sc["peel__level"]) > 0), 1] > 0)


@pytest.mark.parametrize("name", ["plate-5-16", "plate-5-17"])
def test_plates_5_16_and_5_17_peel_along_the_crack_models_cracks(name):
    host = get_plugin_manager()
    rules = [s["rule"] for s in read_toml(find_recipe(f"meshes/{name}", host))["steps"]]
    assert "cracks.imposed" not in rules
    assert rules.index("cracks.stress") < rules.index("cracks.propagate") < rules.index("cracks.peel")


def test_plate_5_17_first_picture_is_the_cracked_cells_before_any_peeling():
    """Thesis plate 5.17 (a): the cells of the precomputed cracks in black, nothing peeled yet."""
    host = get_plugin_manager()
    data = read_toml(find_recipe("meshes/plate-5-17", host))
    ids = [s.get("id") for s in data["steps"]]
    assert ids.index("cracks") < ids.index("crackview") < ids.index("peel")
    first = data["outputs"][0]
    assert first["options"]["color_by"] == "surface__color"
    peel = host.rule("cracks.peel")         # the peel leaves that colour field as painted
    assert all(f.name != "surface__color" for f in peel.fields if f.intent == "out")
    sc = run_plate("plate-5-17", keep_after="crackview").state.get("cells")
    cracked = np.asarray(sc["crack__width"])[:, -1] > 0
    rgb = np.asarray(sc["surface__color"])
    assert 0.05 < cracked.mean() < 0.6
    assert np.all(rgb[cracked] == 0.0) and np.all(rgb[~cracked] == 1.0)
