"""A card's numbers come from its run: no number typed by hand in a title, caption or "differs"
line, and every placeholder names something the run or the entry really has."""
from __future__ import annotations

import json

import pytest

from procgen.gallery import load_gallery, overrides_for
from procgen.recipes import load_recipe
from procgen.site.text import PLACEHOLDER, fill, plain, typed_numbers


@pytest.fixture(scope="module")
def entries(host):
    return load_gallery(host)


def _texts(e):
    return {"title": e.title, "caption": e.caption, "differs": e.differs}


def test_no_card_types_a_number_by_hand(entries):
    typed = [f"{e.slug}.{k}: {n}" for e in entries for k, t in _texts(e).items() for n in typed_numbers(t)]
    assert not typed, f"{len(typed)} numbers typed by hand (use a placeholder): " + "; ".join(typed[:40])


def test_every_thesis_and_step_placeholder_resolves(host, entries):
    """``{thesis.K}`` needs K in the entry's thesis table; ``{steps.ID.params.NAME}`` a step ID
    of the recipe (after the entry's overrides) whose rule has parameter NAME."""
    bad = []
    recipes = {}
    for e in entries:
        for where, text in _texts(e).items():
            for key in PLACEHOLDER.findall(text):
                if key.startswith("thesis.") and key[7:] not in e.thesis:
                    bad.append(f"{e.slug}.{where}: {{{key}}} is not in its thesis table")
                elif key.startswith("steps."):
                    if e.slug not in recipes:
                        recipes[e.slug] = load_recipe(e.recipe, host, overrides_for(e, False))
                    parts = key.split(".")
                    steps = {s.id: s for s in recipes[e.slug].steps} | \
                        {str(s.index): s for s in recipes[e.slug].steps}
                    st = steps.get(parts[1]) if len(parts) > 2 else None
                    ok = st is not None and (parts[2:] == ["iterations"] or (
                        parts[2:] == ["frames", "every"] and st.frames is not None) or (
                        len(parts) == 4 and parts[2] == "params" and parts[3] in st.rule.param_values()))
                    if not ok:
                        bad.append(f"{e.slug}.{where}: {{{key}}} names no step parameter of {e.recipe}")
    assert not bad, "; ".join(bad[:30])


RUN = {"reports": {"peel.exposed_share_fraction": 0.352, "cells.n_cells": 561489, "c.saturation_ratio": 9.7954,
                   "cells.voronoi.completion_r10": 0.9621},
       "resolved_recipe": {"steps": [{"id": "cells", "rule": "x", "params": {"target_cells": 6000}},
                                     {"id": "peel", "rule": "y", "params": {}}]},
       "steps": [{"iterations": 1, "params": {"target_cells": 6000, "cell_size": 0.01}},
                 {"iterations": 28, "params": {"rate": 0.5}}]}


def test_placeholders_print_the_runs_own_numbers():
    html, missing = fill("{cells.n_cells} cells, {peel.exposed_share_fraction} exposed (thesis: "
                         "{thesis.peel.exposed_share_fraction}), {c.saturation_ratio} later, "
                         "{steps.peel.iterations} steps of {steps.cells.params.cell_size}; `P = 1/2` {gone}",
                         RUN, {"peel.exposed_share_fraction": 0.45})
    assert missing == ["gone"]
    assert plain("{cells.n_cells} cells, {cells.voronoi.completion_r10} at r 10", RUN, {}) == \
        "561,489 cells, 96.2 % at r 10"
    assert ">35.2 %<" in html and ">45 %<" in html and ">9.8x<" in html and ">28<" in html
    assert ">0.01<" in html and "<code>P = 1/2</code>" in html and ">?<" in html


def test_a_typed_number_is_caught_and_references_are_not():
    assert typed_numbers("about 45 % of the gold shows") == ["45"]
    assert typed_numbers("Fig. 4.18(a) has 571,398 cells") == ["571,398"]
    assert typed_numbers("Plates 5.5/5.6, Figs 4.2(e)/4.3, Plate D-19, section 4.1.4, 3-D and 2.5-D; "
                         "{cells.n_cells} cells `P = sqrt(2)/2 - 1/2`") == []


def test_gallery_pages_fill_the_text_from_the_run(host, tmp_path):
    """End to end on a real entry: the card's title on the front page and entry page carries the
    run's own count, which the run.json holds."""
    from procgen.gallery import build_gallery

    gal = tmp_path / "g.toml"
    gal.write_text('[[entry]]\nrecipe = "demo/basics"\nseeds = [3]\n'
                   'title = "{points.n_points} points, radius {steps.sample.params.radius}"\n'
                   'caption = "a {nope.not_reported} placeholder"\n')
    rep = build_gallery(host, out_dir=tmp_path / "out", gallery_file=gal, quick=True)
    info = json.loads((tmp_path / "out" / "demo-basics" / "seed-3" / "run.json").read_text())
    n = f"{info['reports']['points.n_points']:,}"
    for page in (tmp_path / "out" / "index.html", tmp_path / "out" / "demo-basics" / "index.html"):
        text = page.read_text()
        assert f">{n}</span> points" in text and ">?</span>" in text
    assert any("nope.not_reported" in w for w in rep.warnings)
