"""Step ids: overrides that name a step keep hitting it when steps are inserted; bad ids are one line."""
from __future__ import annotations

import csv

import pytest

from procgen import RecipeError
from procgen.gallery import load_gallery, overrides_for
from procgen.recipes import load_recipe
from procgen.sweep import sweep

RECIPE = """
[[steps]]
id = "sample"
rule = "points.poisson_disk"
params = { radius = 0.1 }

[[steps]]
id = "mesh"
rule = "mesh.delaunay"
"""
INSERTED = """
[[steps]]
rule = "points.poisson_disk"
params = { domain = "extra", radius = 0.3 }
""" + RECIPE


def _one_line(exc: pytest.ExceptionInfo) -> str:
    msg = str(exc.value)
    assert "\n" not in msg
    return msg


def test_an_id_keeps_its_step_when_a_step_is_inserted(host, tmp_path):
    a, b = tmp_path / "a.toml", tmp_path / "b.toml"
    a.write_text(RECIPE)
    b.write_text(INSERTED)
    by_id = ["steps.sample.params.radius=0.05"]
    ra, rb = load_recipe(a, host, by_id), load_recipe(b, host, by_id)
    assert ra.steps[0].rule.radius == 0.05 and ra.steps[0].id == "sample"
    assert rb.steps[1].rule.radius == 0.05 and rb.steps[0].rule.radius == 0.3
    # a position is still accepted, and it is what moves when a step is inserted
    by_index = ["steps.0.params.radius=0.05"]
    assert load_recipe(a, host, by_index).steps[0].rule.radius == 0.05
    rb = load_recipe(b, host, by_index)
    assert rb.steps[0].rule.radius == 0.05 and rb.steps[1].rule.radius == 0.1


def test_unknown_duplicate_and_malformed_ids_are_one_line_errors(host, tmp_path):
    f = tmp_path / "r.toml"
    f.write_text(RECIPE)
    with pytest.raises(RecipeError, match=r"no step with id 'sampel'.*did you mean 'sample'") as exc:
        load_recipe(f, host, ["steps.sampel.params.radius=0.2"])
    assert "ids: sample, mesh" in _one_line(exc)
    dup = tmp_path / "dup.toml"
    dup.write_text(RECIPE.replace('id = "mesh"', 'id = "sample"'))
    with pytest.raises(RecipeError, match=r"steps\[1\]: id 'sample' is already used by steps\[0\]") as exc:
        load_recipe(dup, host)
    _one_line(exc)
    with pytest.raises(RecipeError, match="used by 2 steps") as exc:
        load_recipe(dup, host, ["steps.sample.params.radius=0.2"])
    _one_line(exc)
    for bad in ('"3"', '"a.b"', "7", '""'):
        g = tmp_path / "bad.toml"
        g.write_text(RECIPE.replace('"mesh"', bad))
        with pytest.raises(RecipeError, match=r"steps\[1\]: id must be a name") as exc:
            load_recipe(g, host)
        _one_line(exc)


def test_gallery_overrides_address_steps_by_id(host, tmp_path):
    (tmp_path / "r.toml").write_text(RECIPE)
    g = tmp_path / "gallery.toml"
    g.write_text(f"""
[[entry]]
recipe = "{(tmp_path / 'r.toml').as_posix()}"
id = "ids"
set = {{ "steps.sample.params.width" = 2.0 }}
quick = {{ "steps.sample.params.radius" = 0.2 }}
""")
    [entry] = load_gallery(host, path=g)
    r = load_recipe(entry.recipe, host, overrides_for(entry, quick=True))
    assert (r.steps[0].rule.width, r.steps[0].rule.radius) == (2.0, 0.2)


def test_every_shipped_gallery_override_resolves(host):
    """Each built-in gallery entry's overrides (full and quick) name existing steps and params."""
    entries = load_gallery(host)
    assert len(entries) > 40
    for e in entries:
        for quick in (False, True):
            load_recipe(e.recipe, host, overrides_for(e, quick))
        for key in list(e.set) + list(e.quick):
            if key.startswith("steps."):
                assert not key.split(".")[1].isdigit(), f"{e.slug}: {key} counts positions; use the step's id"


def test_sweep_grid_keys_may_use_ids(tmp_path):
    runs = sweep("demo/basics", ["steps.sample.params.radius=0.08,0.12", "steps.terrain.params.nx=16"], [1],
                 tmp_path / "o", progress=False)
    assert [r.status for r in runs] == ["done", "done"]
    rows = list(csv.DictReader((tmp_path / "o/summary.csv").open()))
    n = {r["steps.sample.params.radius"]: int(r["points.n_points"]) for r in rows}
    assert n["0.08"] > n["0.12"]
    with pytest.raises(RecipeError, match="no step with id 'smaple'"):
        sweep("demo/basics", ["steps.smaple.params.radius=0.1"], [1], tmp_path / "bad", progress=False)
    assert not (tmp_path / "bad").exists()
