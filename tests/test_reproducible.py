"""Same recipe + same seed = byte-identical files, across every family (quick gallery settings)."""
from __future__ import annotations

import json
import os
import subprocess
import sys

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


# recipes whose outputs numpy's run-time SIMD choice changed (a snaxel cloud grew another shape
# on an AVX-512 machine) before they used procgen.portable's exp, log, power and pseudo-angle
ACROSS_CPUS = ["clouds/fig-4-2e", "clouds/cumulus-congestus", "terrain/eroded-mountain", "terrain/plate-2-4"]


def test_the_same_bytes_whichever_simd_numpy_picks(host, tmp_path):
    """numpy dispatches exp, log, power ... to SIMD code chosen for the CPU at import; a child
    process with every dispatched feature disabled (NPY_DISABLE_CPU_FEATURES) stands in for an
    older machine and must write the same bytes as this process."""
    try:
        from numpy._core import _multiarray_umath as mu      # numpy >= 2
    except ImportError:
        from numpy.core import _multiarray_umath as mu       # numpy 1.26
    extra = [f for f in mu.__cpu_dispatch__ if mu.__cpu_features__.get(f)]
    if not extra:
        pytest.skip("this CPU runs numpy's baseline code only: nothing to compare")
    jobs = []
    for recipe in ACROSS_CPUS:
        entry = next(e for e in load_gallery(host) if e.recipe == recipe)
        jobs.append((entry.slug, recipe, overrides_for(entry, quick=True), entry.seeds[0]))
    child = ("import json, sys\nfrom procgen.jobs import render_job\n"
             "for slug, recipe, ov, seed in json.loads(sys.argv[1]):\n"
             "    r = render_job(slug, recipe, ov, seed, sys.argv[2] + '/' + slug)\n"
             "    assert r.status == 'done', r.error\n")
    env = {**os.environ, "NPY_DISABLE_CPU_FEATURES": " ".join(extra), "PROCGEN_ACCELERATE": "0"}
    subprocess.run([sys.executable, "-c", child, json.dumps(jobs), str(tmp_path / "baseline")], env=env, check=True)
    for slug, recipe, ov, seed in jobs:
        mine = render_job(slug, recipe, ov, seed, str(tmp_path / "mine" / slug))
        assert mine.status == "done", mine.error
        files = [f for f in mine.files if f != "run.json"]
        assert files
        for f in files:
            assert (tmp_path / "mine" / slug / f).read_bytes() == (tmp_path / "baseline" / slug / f).read_bytes(), \
                f"{recipe}: {f} differs with numpy's {', '.join(extra)} code off"
