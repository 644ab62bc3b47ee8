"""Same recipe + same seed = byte-identical files, across every family (quick gallery settings)."""
from __future__ import annotations

import pytest

from procgen.gallery import load_gallery, overrides_for
from procgen.jobs import render_job

SAMPLE = ["demo/basics", "clouds/fig-3-22", "terrain/plate-2-6", "meshes/plate-4-2", "chains/eroded-patina"]


@pytest.mark.parametrize("recipe", SAMPLE)
def test_two_runs_give_identical_bytes(host, tmp_path, recipe):
    entry = next(e for e in load_gallery(host) if e.recipe == recipe)
    overrides = overrides_for(entry, quick=True)
    seed = entry.seeds[0]
    runs = [render_job(entry.slug, recipe, overrides, seed, str(tmp_path / name)) for name in ("a", "b")]
    assert [r.status for r in runs] == ["done", "done"], [r.error for r in runs]
    files = [f for f in runs[0].files if f != "run.json"]
    assert files == [f for f in runs[1].files if f != "run.json"] and len(files) >= 2
    for f in files:
        assert (tmp_path / "a" / f).read_bytes() == (tmp_path / "b" / f).read_bytes(), f"{recipe}: {f} differs"
