"""ca.voronoi writes its label field and coverage curve when published, not every step.

A step only grows the labels and counts them; the field and the curve reach the state in
``publish`` (before each frame) and in ``finish``.  These tests fail if a frame or a published
state shows anything but the labels and the coverage of its own iteration, on both paths.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from procgen import Grid, State
from procgen.ca.propagation import VoronoiPropagation
from procgen.recipes import check_recipe
from procgen.runner import run


def _accelerate(value: str, monkeypatch: pytest.MonkeyPatch) -> None:
    if value == "1":
        pytest.importorskip("numba")
    monkeypatch.setenv("PROCGEN_ACCELERATE", value)


def _recipe(iterations: int, frames: bool) -> dict:
    step = {"rule": "ca.voronoi", "iterations": iterations, "params": {"seeds": 5}}
    if frames:
        step["frames"] = {"every": 4, "domain": "cells", "format": "npy",
                          "options": {"field": "voronoi__label"}}
    return {"steps": [{"rule": "grid.noise", "params": {"nx": 40, "ny": 30, "grid": "cells"}}, step],
            "outputs": [{"domain": "cells", "format": "npy", "file": "labels.npy",
                         "options": {"field": "voronoi__label"}}]}


@pytest.mark.parametrize("accelerate", ["0", "1"])
def test_a_frame_at_iteration_k_is_the_field_of_a_run_of_k_iterations(
        accelerate: str, host, tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    _accelerate(accelerate, monkeypatch)
    run(check_recipe(_recipe(12, frames=True), host), host, out_dir=tmp_path / "frames", progress=False)
    shown = []
    for k in (4, 8, 12):
        out = tmp_path / f"k{k}"
        run(check_recipe(_recipe(k, frames=False), host), host, out_dir=out, progress=False)
        frame = (tmp_path / "frames" / "frames" / "step1" / f"frame_{k:04d}.npy").read_bytes()
        assert frame == (out / "labels.npy").read_bytes()
        shown.append(frame)
    assert len(set(shown)) == 3                            # the regions grew between the frames


@pytest.mark.parametrize("accelerate", ["0", "1"])
def test_published_coverage_is_the_share_of_present_cells_labelled(
        accelerate: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """The running count gives the grid pass's double exactly, on a grid with holes; a step
    alone leaves the field and the curve as they were, publish brings both up to date."""
    _accelerate(accelerate, monkeypatch)
    present = np.random.default_rng(0).random((50, 70)) > 0.1
    dom = Grid((50, 70))
    dom.add_field("cell__alive", present, at="cell")
    st = State(seed=2)
    st.add_domain("cells", dom)
    st.rule_name = "ca.voronoi"
    rule = VoronoiPropagation.from_params({"seeds": 6})
    st.iteration = -1
    rule.setup(st)
    for k in range(1000):
        st.iteration = k
        field, curve = dom["voronoi__label"], st.get("coverage")
        going = rule.step(st)
        assert dom["voronoi__label"] is field and st.get("coverage") is curve
        rule.publish(st)
        field, pts = np.asarray(dom["voronoi__label"]), st.get("coverage").points
        n = len(pts) // 2                                  # line 0: (step, cumulative %)
        assert pts[n - 1, 1] == 100.0 * float(np.mean(field[present] > 0))
        if not going:
            break
    assert 99.0 < pts[n - 1, 1] <= 100.0 and n > 10
