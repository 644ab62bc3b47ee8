"""The runner: until-stable with a cap, frames every K steps, records, nothing written on failure."""
from __future__ import annotations

import json
from dataclasses import dataclass
from typing import ClassVar

import numpy as np
import pytest

from procgen import FieldSpec, Grid, InputError, PluginError, RuleBase, get_plugin_manager, param
from procgen.plugins import plugin_module
from procgen.recipes import check_recipe
from procgen.runner import run


@dataclass(kw_only=True)
class Countdown(RuleBase):
    """Fills one more cell per step until `cells` are filled, then reports no change."""

    name: ClassVar[str] = "test.countdown"
    creates: ClassVar[dict[str, str]] = {"g": "Grid"}
    fields: ClassVar[tuple] = (FieldSpec("cell__filled", "g", "cell", "out"),)
    default_iterations: ClassVar[int] = 3
    cells: int = param(5, ge=0, le=16, doc="cells to fill")
    fail_at: int = param(-1, doc="raise an InputError at this iteration (tests)")
    bad_return: bool = param(False, doc="return a non-bool (tests)")

    def setup(self, state):
        g = Grid((4, 4))
        g.add_field("cell__filled", np.zeros((4, 4)), at="cell")
        state.add_domain("g", g)

    def step(self, state):
        if state.iteration == self.fail_at:
            raise InputError("deliberate failure")
        if self.bad_return:
            return 1
        f = state.get("g")["cell__filled"].reshape(-1)
        done = int(f.sum())
        if done >= self.cells:
            return False
        f[done] = 1
        return True


@pytest.fixture(scope="module")
def thost():
    return get_plugin_manager([plugin_module("countdown", procgen_register_rules=lambda: [Countdown])])


def _recipe(host, step, outputs=()):
    return check_recipe({"steps": [dict({"rule": "test.countdown"}, **step)], "outputs": list(outputs)}, host, "c.toml")


def test_until_stable_stops_on_no_change(thost, tmp_path):
    res = run(_recipe(thost, {"params": {"cells": 5}, "until": "stable", "max_iterations": 100}), thost,
              out_dir=tmp_path)
    recs = res.state.records
    assert len(recs) == 6 and [r.changed for r in recs] == [True] * 5 + [False]
    info = json.loads((tmp_path / "run.json").read_text())
    assert info["steps"][0]["stopped"] == "stable" and info["steps"][0]["iterations"] == 6


def test_until_stable_respects_cap(thost, tmp_path):
    res = run(_recipe(thost, {"params": {"cells": 16}, "until": "stable", "max_iterations": 4}), thost,
              out_dir=tmp_path)
    assert len(res.state.records) == 4
    assert json.loads((tmp_path / "run.json").read_text())["steps"][0]["stopped"] == "max_iterations"


def test_default_and_explicit_iterations(thost):
    assert len(run(_recipe(thost, {}), thost).state.records) == 3
    assert len(run(_recipe(thost, {"iterations": 7}), thost).state.records) == 7


def test_frames_every_k_steps(thost, tmp_path):
    frames = {"every": 2, "domain": "g", "format": "image_png", "options": {"field": "cell__filled", "cmap": "gray"}}
    res = run(_recipe(thost, {"params": {"cells": 10}, "iterations": 7, "frames": frames}), thost, out_dir=tmp_path)
    names = sorted(p.name for p in (tmp_path / "frames" / "step0").iterdir())
    assert names == ["frame_0002.png", "frame_0004.png", "frame_0006.png"]
    from PIL import Image

    lit = [int((np.asarray(Image.open(tmp_path / "frames/step0" / n))[:, :, 0] > 0).sum()) for n in names]
    assert lit == [2, 4, 6]       # each frame shows the state at its own step
    assert "frames/step0/frame_0004.png" in res.files


def test_failure_writes_nothing(thost, tmp_path):
    out = tmp_path / "o"
    with pytest.raises(InputError, match=r"steps\[0\] \(test.countdown\): deliberate failure"):
        run(_recipe(thost, {"params": {"fail_at": 2}, "iterations": 5,
                            "frames": {"every": 1, "domain": "g", "format": "npy", "options": {"field": "cell__filled"}}},
                    [{"domain": "g", "format": "npy", "options": {"field": "cell__filled"}}]), thost, out_dir=out)
    assert not out.exists()


def test_non_bool_step_is_a_plugin_error(thost):
    with pytest.raises(PluginError, match="must return a bool"):
        run(_recipe(thost, {"params": {"bad_return": True}}), thost)


def test_progress_is_silent_when_not_a_tty(thost, capfd):
    run(_recipe(thost, {"iterations": 20}), thost)
    assert capfd.readouterr().err == ""


def test_failing_exporter_writes_nothing_either(thost, tmp_path):
    out = tmp_path / "o"
    outputs = [{"domain": "g", "format": "npy", "options": {"field": "cell__filled"}},
               {"domain": "g", "format": "image_png", "options": {"field": "cell__filled", "cmap": "no_such_map"}}]
    with pytest.raises(InputError, match="no_such_map"):
        run(_recipe(thost, {"iterations": 2}, outputs), thost, out_dir=out)
    assert not out.exists()


@dataclass(kw_only=True)
class Lazy(RuleBase):
    """Keeps its count privately and copies it into the grid only when asked (publish)."""

    name: ClassVar[str] = "test.lazy"
    creates: ClassVar[dict[str, str]] = {"g": "Grid"}
    fields: ClassVar[tuple] = (FieldSpec("cell__count", "g", "cell", "out"),)

    def setup(self, state):
        self._n = 0
        g = Grid((1, 1))
        g.add_field("cell__count", np.zeros((1, 1)), at="cell")
        state.add_domain("g", g)

    def step(self, state):
        self._n += 1
        return True

    def publish(self, state):
        state.get("g")["cell__count"][:] = self._n


def test_publish_is_called_before_each_frame_and_recipe_dir_is_known(tmp_path):
    host = get_plugin_manager([plugin_module("lazy", procgen_register_rules=lambda: [Lazy])])
    frames = {"every": 3, "domain": "g", "format": "npy", "options": {"field": "cell__count"}}
    rec = check_recipe({"steps": [{"rule": "test.lazy", "iterations": 9, "frames": frames}]}, host, "l.toml",
                       base_dir=tmp_path)
    assert rec.steps[0].rule.recipe_dir == tmp_path
    run(rec, host, out_dir=tmp_path / "o")
    got = [float(np.load(tmp_path / f"o/frames/step0/frame_{k:04d}.npy")[0, 0]) for k in (3, 6, 9)]
    assert got == [3.0, 6.0, 9.0]
