"""The compiled crack render scan (procgen_cracks.render_kernels) against the numpy one, byte for
byte: the micro-cell coverage for every width profile, and whole recipes' exported files."""
from __future__ import annotations

import dataclasses
import hashlib

import numpy as np
import pytest

from procgen.recipes import load_recipe
from procgen.runner import run
from procgen_cracks.render import PROFILES, micro_coverage
from procgen_cracks.render_rules import crack_segments, stack_layer

pytest.importorskip("numba")


@pytest.fixture(scope="module")
def mud(host):
    """Crack paths of the plate-5.10 recipe at 2,000 cells (cracks on every facet, crossing
    facet edges)."""
    recipe = load_recipe("meshes/plate-5-10", host, ["steps.cells.params.target_cells=2000"])
    cut = next(i for i, s in enumerate(recipe.steps) if s.id == "cracks")
    recipe = dataclasses.replace(recipe, steps=recipe.steps[:cut + 1], outputs=[])
    state = run(recipe, host, seed=1, progress=False).state
    cells = state.domains["cells"]
    return cells, crack_segments(cells, state.domains["cracks"], stack_layer(cells, -1))


@pytest.mark.parametrize("profile", PROFILES)
def test_compiled_coverage_equals_numpy_coverage(mud, profile):
    """Hairlines (the constant fallback) and cracks up to 2 cells wide (every V / U profile,
    pieces overlapping over many micro-cells, bands spilling over facet edges), k = 3 and 8."""
    cells, seg = mud
    for k, scale in ((3, 1.0), (8, 4.0)):
        wide = dataclasses.replace(seg, wa=seg.wa * scale, wb=seg.wb * scale)
        ref = micro_coverage(cells, wide, k, profile=profile, saturation=0.4, accelerate=False)
        got = micro_coverage(cells, wide, k, profile=profile, saturation=0.4, accelerate=True)
        assert (ref > 0).sum() > 1000 * (1 + 10 * (k > 3))
        assert got.dtype == ref.dtype and got.tobytes() == ref.tobytes(), (k, scale)


def test_compiled_coverage_honours_the_facet_mask(mud):
    """The crack mirror draws on front-lit facets only (``faces``)."""
    cells, seg = mud
    lit = np.zeros(cells.n_faces, bool)
    lit[::2] = True
    ref = micro_coverage(cells, seg, 6, profile="v_linear", faces=lit, accelerate=False)
    got = micro_coverage(cells, seg, 6, profile="v_linear", faces=lit, accelerate=True)
    assert 0 < (ref > 0).sum() and got.tobytes() == ref.tobytes()


def _digests(host, name: str, overrides: list[str], out) -> dict[str, str]:
    recipe = load_recipe(name, host, overrides)
    run(recipe, host, seed=1, out_dir=out, progress=False)
    return {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in sorted(out.iterdir())
            if p.suffix in (".png", ".obj", ".glb", ".svg", ".mtl")}


@pytest.mark.parametrize("name, overrides", [
    ("meshes/plate-5-4", []),
    ("meshes/plate-5-10", ["steps.cells.params.target_cells=2500"]),
])
def test_both_paths_write_the_same_files(host, tmp_path, monkeypatch, name, overrides):
    """Textures, OBJ, GLB, PNG and SVG of the six-profile plate 5.4 and the mud plate 5.10
    (k = 11) are byte-identical on both paths (PROCGEN_ACCELERATE)."""
    monkeypatch.setenv("PROCGEN_ACCELERATE", "0")
    ref = _digests(host, name, overrides, tmp_path / "numpy")
    monkeypatch.setenv("PROCGEN_ACCELERATE", "1")
    got = _digests(host, name, overrides, tmp_path / "numba")
    assert len(ref) >= 2 and got == ref
