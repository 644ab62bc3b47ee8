"""Sweeps: grid x seeds, resumable, summary CSV (on a dask cluster: tests/test_cluster.py)."""
from __future__ import annotations

import csv

import pytest

from procgen import RecipeError
from procgen.sweep import parse_grid, parse_seeds, plan, sweep

GRID = ["steps.0.params.radius=0.08,0.12"]
QUICK = "steps.4.params.nx=16"


def test_parsing():
    assert parse_seeds("1-3,7") == [1, 2, 3, 7]
    assert parse_grid("steps.1.params.r=0.1, 0.2") == ("steps.1.params.r", ["0.1", "0.2"])
    with pytest.raises(RecipeError):
        parse_seeds("3-1")
    with pytest.raises(RecipeError):
        parse_grid("steps.1.params.r")
    runs = plan(GRID + ["steps.3.params.passes=1,2"], [1, 2])
    assert len(runs) == 8 and len({r.key for r in runs}) == 8


@pytest.mark.parametrize("grids", [["steps.a.params.offset=-1,1"], ["steps.a.params.x=1e-3,1e3"],
                                   ["steps.a.params.x=1,2", "steps.b.params.x=1,2"],
                                   ['steps.a.params.name="a b","ab","a/b"'],
                                   ["steps.a.params.a_b=1,2", "steps.a.params.ab=1,2"]])
def test_every_grid_point_has_its_own_folder(grids):
    """Two grid points never share a run folder (one would overwrite the other's files), and
    every folder is one plain name under the sweep's folder."""
    runs = plan(grids, [1])
    keys = [r.key for r in runs]
    assert len(set(keys)) == len(keys), keys
    assert all(k.count("/") == 1 and ".." not in k.split("/") and not k.startswith(".") for k in keys)


def test_bad_grid_value_fails_before_any_run(tmp_path):
    with pytest.raises(RecipeError, match="radius"):
        sweep("demo/basics", ["steps.0.params.radius=0.1,-2"], [1], tmp_path / "o")
    assert not (tmp_path / "o").exists()


def test_local_sweep_resumes(tmp_path):
    grid = GRID + [f"{QUICK.split('=')[0]}=16"]
    local = sweep("demo/basics", grid, [1, 2], tmp_path / "local", jobs=2, progress=False)
    assert [r.status for r in local] == ["done"] * 4
    rows = list(csv.DictReader((tmp_path / "local/summary.csv").open()))
    assert len(rows) == 4 and {r["steps.0.params.radius"] for r in rows} == {"0.08", "0.12"}
    assert all(int(r["points.n_points"]) > 0 for r in rows)
    # smaller radius, more points (the numbers in the table are the runs' own reports)
    by = {(r["steps.0.params.radius"], r["seed"]): int(r["points.n_points"]) for r in rows}
    assert by[("0.08", "1")] > by[("0.12", "1")]
    again = sweep("demo/basics", grid, [1, 2], tmp_path / "local", jobs=1, progress=False)
    assert [r.status for r in again] == ["skipped"] * 4



def test_worker_with_other_package_versions_refuses_the_job(host, tmp_path):
    from dataclasses import replace

    from procgen.jobs import Job, compute_job, plan_job

    job = plan_job(Job("k", "demo/basics", ("steps.4.params.nx=16",), 1, str(tmp_path / "k")), host)
    mine = job.versions["procgen-rules"]
    out = compute_job(replace(job, versions={**job.versions, "procgen-rules": "0.0.0"}), host)
    assert out.result.status == "failed" and not out.files
    assert f"procgen-rules: worker {mine}, client 0.0.0" in out.result.error
    assert compute_job(job, host).result.status == "done"


@pytest.mark.parametrize("processes", [2, 3])
def test_local_workers_share_the_cores_between_their_numba_threads(processes):
    """Each local worker gets cores // processes numba threads (at least 1), unless the user chose."""
    import os

    from procgen.jobs import _executor
    pool, _, close = _executor(processes, None)
    try:
        seen = {pool.submit(os.getenv, "NUMBA_NUM_THREADS").result() for _ in range(2 * processes)}
    finally:
        close()
    share = str(max(1, (os.cpu_count() or 1) // processes))
    assert seen == {os.environ.get("NUMBA_NUM_THREADS", share)}
