"""Exporter options that name a field are checked by `procgen check`, before any compute.

An option names a field when its annotation is ``procgen.FieldName`` or its name ends in
``field``; the surface exporters' ``relief`` is the first of the first kind (plate 5.20 raises
the paint still on by ``relief = "peel__lift"``).
"""
from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

from procgen import FieldName, RecipeError, check_recipe, get_plugin_manager, load_recipe
from procgen.exchange import field_options

RECIPE = Path(__file__).resolve().parents[1] / "rules" / "meshes" / "plate-5-20.toml"


def _misspelt(tmp_path: Path) -> Path:
    """Plate 5.20 with its GLB's relief field misspelt (the mesh path made absolute)."""
    text = RECIPE.read_text()
    assert text.count('relief = "peel__lift"') == 2
    head, sep, tail = text.rpartition('relief = "peel__lift"')
    text = head + 'relief = "peel__lfit"' + tail
    mesh = RECIPE.parents[2] / "procgen" / "data" / "meshes" / "cow-2k.obj"
    text = text.replace('path = "cow-2k.obj"', f'path = "{mesh.as_posix()}"')
    bad = tmp_path / "bad.toml"
    bad.write_text(text)
    return bad


def test_check_reports_misspelt_relief_field_in_one_line(tmp_path):
    bad = _misspelt(tmp_path)
    r = subprocess.run([sys.executable, "-m", "procgen.cli", "check", str(bad)], capture_output=True,
                       text=True, env=dict(os.environ), timeout=300)
    assert r.returncode == 1, r.stdout
    assert r.stderr.count("\n") == 1 and "Traceback" not in r.stderr
    assert "outputs[" in r.stderr and "relief='peel__lfit'" in r.stderr
    assert "did you mean 'peel__lift'" in r.stderr
    load_recipe("meshes/plate-5-20", get_plugin_manager())     # the right spelling checks


def test_marker_and_naming_rule_both_declare_a_field_option():
    def fmt(domain, *, stem: str, provenance: dict, relief: FieldName = "", color_field: str = "c",
            relief_scale: float = 1.0, label: str = "x") -> bytes:
        return b""

    assert field_options(fmt) == {"relief": "", "color_field": "c"}
    host = get_plugin_manager()
    for name in ("surface_obj", "surface_glb", "surface_png"):
        assert "relief" in field_options(host.exporter(name).func), name


def test_exporter_default_field_is_checked_and_a_marked_option_on_a_good_field_passes(tmp_path):
    host = get_plugin_manager()
    steps = [{"rule": "mesh.primitive", "params": {"shape": "cube"}},
             {"rule": "surface.cells", "params": {"target_cells": 600}},
             {"rule": "layers.stack", "params": {"layers": [{"preset": "stone", "thickness": 1.0}]}}]
    good = {"steps": steps, "outputs": [{"domain": "cells", "format": "surface_obj",
                                         "options": {"relief": "layers__thickness"}}]}
    check_recipe(good, host)
    bad = {"steps": steps, "outputs": [{"domain": "cells", "format": "surface_obj",
                                        "options": {"relief": "layers__thicknes"}}]}
    with pytest.raises(RecipeError, match="did you mean 'layers__thickness'"):
        check_recipe(bad, host)
