"""Sweeps: grid x seeds, resumable, summary CSV; a dask LocalCluster gives byte-identical files."""
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


def test_bad_grid_value_fails_before_any_run(tmp_path):
    with pytest.raises(RecipeError, match="radius"):
        sweep("demo/basics", ["steps.0.params.radius=0.1,-2"], [1], tmp_path / "o")
    assert not (tmp_path / "o").exists()


def _files(root):
    return {p.relative_to(root).as_posix(): p.read_bytes() for p in root.rglob("*")
            if p.is_file() and p.name not in ("run.json", ".procgen-done.json", "summary.csv")}


def test_local_sweep_resumes_and_dask_cluster_matches(tmp_path):
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

    from dask.distributed import Client, LocalCluster

    with LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=None) as cluster:
        with Client(cluster) as client:
            remote = sweep("demo/basics", grid, [1, 2], tmp_path / "dask", scheduler=cluster.scheduler_address,
                           progress=False)
            del client
    assert [r.status for r in remote] == ["done"] * 4
    a, b = _files(tmp_path / "local"), _files(tmp_path / "dask")
    assert a.keys() == b.keys() and len(a) >= 4 * 8
    for k in a:
        assert a[k] == b[k], f"{k} differs between local and dask runs"
