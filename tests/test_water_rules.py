"""The water rules end to end: recipes run, files other tools read, ledgers in run.json, errors."""
from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from procgen import RecipeError, run
from procgen.recipes import check_recipe, load_recipe

SMALL = [
    "steps.surface.params.nx=40", "steps.surface.params.ny=40", "steps.rain.params.drops=3000",
    "steps.rain.frames.every=4", *(f"steps.{r}.iterations=8" for r in ("rain", "rain-2", "rain-3", "rain-4", "rain-5")),
]
STAGES = ("a_initial", "b_44_steps", "c_88_steps", "d_132_steps", "e_176_steps", "f_220_steps")


def _run(host, tmp_path, name, overrides, seed=1):
    rec = load_recipe(name, host, overrides)
    return run(rec, host, seed=seed, out_dir=tmp_path, progress=False)


def test_plate_2_8_writes_readable_files_and_balanced_ledgers(host, tmp_path):
    res = _run(host, tmp_path, "terrain/plate-2-8", SMALL)
    info = json.loads((tmp_path / "run.json").read_text())
    rep = info["reports"]
    rain_steps = sorted(k.split(".")[0] for k in rep if k.endswith(".water.water_ledger"))
    assert len(rain_steps) == 5                     # the rain in five stages, (b) to (f)
    for st in rain_steps:                           # each stage's ledgers balance, same 3000 drops
        err = rep[f"{st}.water.max_relative_ledger_error"]
        assert err["water"] < 1e-12 and err["sediment"] < 1e-12
        wl = rep[f"{st}.water.water_ledger"]
        assert wl["emitted"] == pytest.approx(3000.0)
        assert wl["drops"] + wl["held"] + wl["evaporated"] + wl["drained"] == pytest.approx(3000.0)
    stages = [np.asarray(Image.open(tmp_path / f"{s}.png")) for s in STAGES]   # plate 2.8 (a)-(f)
    assert all(not np.array_equal(a, b) for a, b in zip(stages, stages[1:]))
    # 16-bit heightmap + sidecar, float NPY, colour PNG, OBJ with vertex colours, frames
    im = Image.open(tmp_path / "height.png")
    assert im.mode in ("I;16", "I;16B", "I") and im.size == (40, 40)
    side = json.loads((tmp_path / "height.json").read_text())
    q = np.asarray(im, dtype=float)
    z = side["z_min"] + q / 65535 * (side["z_max"] - side["z_min"])
    h = np.load(tmp_path / "height_f64.npy")
    assert np.allclose(z, h, atol=(side["z_max"] - side["z_min"]) / 65535)
    assert np.load(tmp_path / "thickness_f64.npy").shape == (40, 40, 2)
    assert Image.open(tmp_path / "f_220_steps.png").mode == "RGB"
    import trimesh
    mesh = trimesh.load(tmp_path / "surface.obj", process=False)
    assert len(mesh.vertices) == 1600 and mesh.visual.kind == "vertex"
    assert len({tuple(c) for c in mesh.visual.vertex_colors[:, :3]}) > 20
    assert any(f.startswith("frames/step2/") for f in res.files)
    for layer in (0, 1):
        assert (tmp_path / f"layer{layer}_{['stone', 'patina'][layer]}_top.png").exists()


def test_same_seed_same_bytes(host, tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    _run(host, a, "terrain/plate-2-8", SMALL)
    _run(host, b, "terrain/plate-2-8", SMALL)
    for f in ("height_f64.npy", "f_220_steps.png", "surface.obj", "thickness_f64.npy"):
        assert (a / f).read_bytes() == (b / f).read_bytes(), f
    c = tmp_path / "c"
    _run(host, c, "terrain/plate-2-8", SMALL, seed=2)
    assert (a / "height_f64.npy").read_bytes() != (c / "height_f64.npy").read_bytes()


def test_corrosion_recipe_runs_and_reports(host, tmp_path):
    _run(host, tmp_path, "terrain/plate-2-1", ["steps.0.params.nx=48", "steps.0.params.ny=48",
                                               "steps.2.iterations=20", "steps.2.params.seed_rate=0.002"])
    rep = json.loads((tmp_path / "run.json").read_text())["reports"]
    assert 0 < rep["terrain.corrosion.seeds"] <= 6 and rep["terrain.corrosion.attack_limit_violations"] == 0
    assert 0 < rep["terrain.corrosion.corroded_fraction"] < 1


BAD = [
    ('layers = ["coper"]', "did you mean 'copper'"),
    ('layers = [{ preset = "rock", thickness = -1.0 }]', "thickness must be in"),
    ('layers = [{ preset = "rock", capacity = -0.5 }]', "capacity must be >= 0"),
    ('layers = [{ preset = "rock", opacity = 1.0 }]', "opacity must be in [0, 1)"),
    ('layers = ["rock"], nx = 2', "nx"),
    ('layers = [{ preset = "rock", thikness = 1.0 }]', "did you mean 'thickness'"),
]


@pytest.mark.parametrize("layers,msg", BAD)
def test_bad_input_gives_one_line_errors_from_check(tmp_path, layers, msg):
    f = tmp_path / "bad.toml"
    f.write_text(f'[[steps]]\nrule = "water.surface"\nparams = {{ {layers} }}\n')
    out = subprocess.run([sys.executable, "-m", "procgen.cli", "check", str(f)],
                         capture_output=True, text=True, timeout=120)
    assert out.returncode != 0
    lines = [ln for ln in out.stderr.strip().splitlines() if ln.strip()]
    assert len(lines) == 1 and msg in lines[0], out.stderr


def test_unknown_layer_in_corrosion_is_a_one_line_input_error(host, tmp_path):
    with pytest.raises(RecipeError, match=r"steps\[2\] \(layers.corrode\): layers.corrode.consume: no layer "
                                          r"named 'coper' \(did you mean 'copper'\?\)"):
        load_recipe("terrain/plate-2-1", host, ["steps.0.params.nx=16", "steps.0.params.ny=16",
                                                'steps.2.params.consume=["coper"]', "steps.2.iterations=2"])


def test_frames_show_the_state_of_their_iteration(host, tmp_path):
    """water.drops writes its derived fields only when someone looks (a frame, the end): a frame
    at iteration 3 of 6 must equal the final fields of the same run stopped at 3."""
    def recipe(iterations):
        return check_recipe({"steps": [
            {"rule": "water.surface", "params": {"nx": 30, "ny": 24}},
            {"rule": "water.drops", "iterations": iterations,
             "params": {"drops": 400, "rain": 50, "evaporation": 0.01},
             "frames": {"every": 3, "domain": "terrain", "format": "npy",
                        "options": {"field": "water__depth"}}}],
            "outputs": [{"domain": "terrain", "format": "npy", "file": "depth.npy",
                         "options": {"field": "water__depth"}},
                        {"domain": "terrain", "format": "npy", "file": "height.npy"}]}, host)
    long_run, short_run = tmp_path / "six", tmp_path / "three"
    res = run(recipe(6), host, seed=4, out_dir=long_run, progress=False)
    run(recipe(3), host, seed=4, out_dir=short_run, progress=False)
    frames = sorted(f for f in res.files if f.startswith("frames/") and f.endswith(".npy"))
    assert len(frames) == 2
    at3 = np.load(long_run / frames[0])
    assert at3.any() and np.array_equal(at3, np.load(short_run / "depth.npy"))
    assert not np.array_equal(np.load(long_run / frames[1]), at3)
    # the end state is published too: the final height is base + layers after the last step
    g = res.state.get("terrain")
    top = g["surface__base"] + np.asarray(g["layers__thickness"]).sum(axis=-1)
    assert np.allclose(np.load(long_run / "height.npy"), np.flipud(top))     # (north-up rows)
    assert res.state.get("drops").n_points > 0
