"""Cellular-network recipes end to end: determinism, exports other tools read, holes left out."""
from __future__ import annotations

import json

import numpy as np

from procgen.jobs import render_job


def _render(host, tmp_path, name, overrides, sub):
    res = render_job(f"cellnet-{name}", f"cellnet/{name}", overrides, 1, str(tmp_path / sub))
    assert res.status == "done", res.error
    return res


def test_fig_9_twice_gives_identical_bytes(host, tmp_path):
    over = ["steps.0.params.size=30.0"]
    a = _render(host, tmp_path, "fig-9", over, "a")
    b = _render(host, tmp_path, "fig-9", over, "b")
    files = [f for f in a.files if f != "run.json"]
    assert files == [f for f in b.files if f != "run.json"] and len(files) == 3
    for f in files:
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes(), f


def test_fig_1_runs_every_effect_and_exports_readable_splats(host, tmp_path):
    import trimesh

    res = _render(host, tmp_path, "fig-1", ["steps.seed.params.target_cells=3000"], "s")
    out = tmp_path / "s"
    run = json.loads((out / "run.json").read_text())
    reports = run["reports"]
    n = reports["cells.n_cells"]
    # the eight effects ran as one synchronous network, tens of steps, until nothing changed
    effects = [s for s in run["steps"] if s["rule"] == "cellnet.parallel"][0]
    assert effects["iterations"] > 60 and effects["stopped"] == "stable"
    assert len(effects["params"]["behaviours"]) == 8
    assert reports["cells.transparent_fraction"] > 0          # impacts made holes
    (tm,) = trimesh.load(out / "scene.glb", process=False).geometry.values()
    n_present = round(n * (1 - reports["cells.transparent_fraction"]))
    assert len(tm.faces) == 4 * n_present                    # 4 triangles per present cell
    colors = np.asarray(tm.visual.vertex_attributes["color"])[:, :3]   # COLOR_0 under a white material
    assert len(np.unique(colors // 16, axis=0)) > 20         # many materials' colours
    assert (out / "scene.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "scene.glb" in res.files
