"""Recipe checking: every mistake is one RecipeError line naming file, step and key; no output."""
from __future__ import annotations

import math
import string

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from procgen import ProcgenError, RecipeError
from procgen.recipes import apply_overrides, check_recipe, load_recipe, parse_toml
from procgen.runner import run

GOOD = {
    "recipe": {"name": "t", "seed": 2},
    "steps": [
        {"rule": "points.poisson_disk", "params": {"radius": 0.1}},
        {"rule": "mesh.delaunay", "params": {"points": "points", "mesh": "tess"}},
        {"rule": "mesh.boundary", "params": {"mesh": "tess", "lines": "outline"}},
        {"rule": "lines.smooth", "params": {"lines": "outline", "out": "smooth"}},
    ],
    "outputs": [{"domain": "smooth", "format": "svg", "file": "s.svg"}],
}


def _err(host, data, match):
    with pytest.raises(RecipeError, match=match) as info:
        check_recipe(data, host, "r.toml")
    msg = str(info.value)
    assert "\n" not in msg and msg.startswith("r.toml")
    return msg


def _with(path, value):
    import copy

    d = copy.deepcopy(GOOD)
    node = d
    for p in path[:-1]:
        node = node[p]
    node[path[-1]] = value
    return d


def test_good_recipe_checks(host):
    r = check_recipe(GOOD, host, "r.toml")
    assert [s.rule.name for s in r.steps] == ["points.poisson_disk", "mesh.delaunay", "mesh.boundary", "lines.smooth"]


def test_unknown_rule_with_suggestion(host):
    msg = _err(host, _with(["steps", 1, "rule"], "mesh.delaunai"), "unknown rule")
    assert "steps[1]" in msg and "did you mean 'mesh.delaunay'" in msg


def test_unknown_parameter_with_suggestion(host):
    msg = _err(host, _with(["steps", 0, "params"], {"radus": 0.1}), "unknown parameter 'radus'")
    assert "steps[0] (points.poisson_disk)" in msg and "did you mean 'radius'" in msg


@pytest.mark.parametrize("value,match", [("big", "expected a number"), (-1.0, "outside the allowed range"),
                                         (0, "outside the allowed range"), (math.nan, "finite"),
                                         (math.inf, "finite"), (True, "expected a number")])
def test_bad_parameter_values(host, value, match):
    msg = _err(host, _with(["steps", 0, "params"], {"radius": value}), match)
    assert "'radius'" in msg


def test_missing_domain_is_a_dataflow_error(host):
    d = _with(["steps", 1, "params"], {"points": "nope", "mesh": "tess"})
    msg = _err(host, d, "needs a PointSet domain 'nope'")
    assert "steps[1] (mesh.delaunay)" in msg


def test_incompatible_domain_chain(host):
    d = {"steps": [{"rule": "grid.noise", "params": {"grid": "g", "nx": 8, "ny": 8}},
                   {"rule": "mesh.delaunay", "params": {"points": "g"}}]}
    _err(host, d, "needs domain 'g' to be a PointSet, but an earlier step made it a Grid")


def test_missing_field_is_a_dataflow_error(host):
    d = {"steps": [{"rule": "grid.noise", "params": {"grid": "g", "nx": 8, "ny": 8}},
                   {"rule": "grid.to_mesh", "params": {"grid": "g", "height_field": "water__depth"}}]}
    _err(host, d, "needs field 'water__depth' on domain 'g'")


def test_output_exporter_must_fit_domain(host):
    d = _with(["outputs"], [{"domain": "tess", "format": "heightmap_png16"}])
    _err(host, d, "format 'heightmap_png16' writes Grid, but domain 'tess' is a TriMesh")
    d = _with(["outputs"], [{"domain": "smooth", "format": "svgg"}])
    _err(host, d, "did you mean 'svg'")
    d = _with(["outputs"], [{"domain": "smooth", "format": "svg", "options": {"fil": "#fff"}}])
    _err(host, d, "no option 'fil'")
    d = _with(["outputs"], [{"domain": "smooth", "format": "svg", "file": "../escape.svg"}])
    _err(host, d, "inside the output folder")


def test_unknown_keys_and_structure(host):
    _err(host, _with(["steps", 0, "iteration"], 3), "unknown key 'iteration'.*did you mean 'iterations'")
    _err(host, {"stepz": []}, "unknown key 'stepz'")
    _err(host, {"steps": []}, "at least one")
    _err(host, _with(["steps", 0, "until"], "forever"), "only \"stable\"")
    _err(host, _with(["steps", 0, "iterations"], 0), "positive integer")


def test_memory_guard_refuses_huge_sizes(host):
    d = {"steps": [{"rule": "grid.noise", "params": {"nx": 16384, "ny": 16384}}]}
    d2 = {"steps": [{"rule": "points.poisson_disk", "params": {"radius": 1e-5}}]}
    for data in (d, d2):
        with pytest.raises(RecipeError):
            check_recipe(data, host, "r.toml")


def test_set_overrides_are_validated(host, tmp_path):
    f = tmp_path / "r.toml"
    f.write_text('[[steps]]\nrule = "points.poisson_disk"\nparams = { radius = 0.1 }\n')
    r = load_recipe(f, host, ["steps.0.params.radius=0.2"])
    assert r.steps[0].rule.radius == 0.2
    with pytest.raises(RecipeError, match="outside the allowed range"):
        load_recipe(f, host, ["steps.0.params.radius=-3"])
    with pytest.raises(RecipeError, match="no such index"):
        load_recipe(f, host, ["steps.4.params.radius=1"])
    with pytest.raises(RecipeError, match="KEY=VALUE"):
        load_recipe(f, host, ["steps.0.params.radius"])
    assert apply_overrides({"a": {"b": 1}}, ["a.c=word"], "x") == {"a": {"b": 1, "c": "word"}}


# -- hypothesis: malformed recipes never raise anything but ProcgenError, never write ----------
_json = st.recursive(
    st.none() | st.booleans() | st.integers(-5, 10**6) | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(string.ascii_letters + "._", max_size=12),
    lambda children: st.lists(children, max_size=4) | st.dictionaries(
        st.sampled_from(["rule", "params", "steps", "outputs", "domain", "format", "radius", "iterations",
                         "until", "recipe", "seed", "mesh", "points", "file", "options", "nx"]), children, max_size=5),
    max_leaves=20)


def _mutations():
    rules = st.sampled_from(["points.poisson_disk", "mesh.delaunay", "grid.noise", "nope.rule", "lines.smooth"])
    step = st.fixed_dictionaries({"rule": rules}, optional={"params": _json, "iterations": _json, "until": _json})
    return st.fixed_dictionaries({"steps": st.lists(step, max_size=3)},
                                 optional={"outputs": _json, "recipe": _json}) | _json


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=_mutations())
def test_malformed_recipes_raise_only_procgen_errors(host, tmp_path_factory, data):
    out = tmp_path_factory.mktemp("out")
    try:
        recipe = check_recipe(data, host, "fuzz.toml")
    except ProcgenError as exc:
        assert "\n" not in str(exc)
        assert not any(out.iterdir())
        return
    # a recipe that passes the check must run or fail with a ProcgenError
    try:
        run(recipe, host, out_dir=out / "o", progress=False)
    except ProcgenError:
        assert not (out / "o").exists()


@settings(max_examples=80, deadline=None)
@given(text=st.text(max_size=200))
def test_garbage_toml_is_a_recipe_error(text):
    try:
        parse_toml(text, "g.toml")
    except RecipeError as exc:
        assert str(exc).startswith("g.toml: invalid TOML")


def test_exporter_default_field_must_exist(host):
    d = {"steps": [{"rule": "grid.noise", "params": {"nx": 8, "ny": 8}}],
         "outputs": [{"domain": "terrain", "format": "image_png"}]}     # default field surface__color
    _err(host, d, "option field='surface__color': domain 'terrain' has no field")
    d["outputs"][0]["options"] = {"field": "surface__height"}
    check_recipe(d, host, "r.toml")


def test_chain_across_families_with_wrong_domain_is_refused(host):
    # a Grid handed to the surface automaton (which needs a TriMesh) fails in one line naming the step
    d = {"steps": [{"rule": "grid.noise", "params": {"grid": "terrain", "nx": 8, "ny": 8}},
                   {"rule": "surface.cells", "params": {"mesh": "terrain", "target_cells": 100}}]}
    msg = _err(host, d, "needs domain 'terrain' to be a TriMesh, but an earlier step made it a Grid")
    assert "steps[1] (surface.cells)" in msg
    # a snaxel growth asked to run on surface cells
    d = {"steps": [{"rule": "mesh.primitive"}, {"rule": "surface.cells", "params": {"target_cells": 100}},
                   {"rule": "snaxel.grow", "params": {"mesh": "cells"}}]}
    _err(host, d, r"steps\[2\] \(snaxel.grow\): needs domain 'cells' to be a TriMesh, but an earlier step made it a SurfaceCells")


def test_layer_names_are_checked_against_earlier_steps(host):
    surf = {"rule": "water.surface", "params": {"nx": 16, "ny": 16, "layers": ["stone", "copper", "patina"]}}
    msg = _err(host, {"steps": [surf, {"rule": "layers.corrode", "params": {"cells": "terrain",
                                                                          "consume": ["coper"]}}]},
               "did you mean 'copper'")
    assert "steps[1] (layers.corrode)" in msg
    cells = [{"rule": "mesh.primitive"}, {"rule": "surface.cells", "params": {"target_cells": 100}},
             {"rule": "layers.stack", "params": {"layers": ["copper", "patina"]}}]
    _err(host, {"steps": cells + [{"rule": "layers.corrode", "params": {"product": "patena"}}]},
         r"steps\[3\] \(layers.corrode\).*did you mean 'patina'")


def test_exporter_option_types_are_checked(host):
    d = _with(["outputs"], [{"domain": "smooth", "format": "svg", "options": {"width": "wide"}}])
    _err(host, d, "format 'svg': option 'width': expected an integer")
    d = _with(["outputs"], [{"domain": "smooth", "format": "svg", "options": {"gradient": "#fff"}}])
    _err(host, d, "option 'gradient'")
    d = _with(["outputs"], [{"domain": "smooth", "format": "svg", "options": {"width": 640, "fill": None}}])
    check_recipe(d, host, "r.toml")
