"""Sweeps on a real dask.distributed cluster whose workers cannot see the client's output folder.

A scheduler and two workers run as separate processes. The workers live in their own mount
namespace with a private tmpfs over the client's folder (``unshare --mount``, root only); where
that is not allowed they run from another working directory while the client writes to a
relative path. The test id says which isolation ran. The recipe is a file in the client's folder,
so the workers cannot read it either: they get the resolved recipe and hand the files back.
"""
from __future__ import annotations

import csv
import json
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import pytest

import distributed  # the test extra installs it: a missing one fails, never skips

from procgen.cli import main
from procgen.jobs import STAMP  # noqa: E402
from procgen.sweep import sweep  # noqa: E402

TINY = """
[recipe]
name = "tiny"
seed = 1

[[steps]]
rule = "points.poisson_disk"
params = { domain = "points", width = 1.0, height = 1.0, radius = 0.1 }

[[steps]]
rule = "mesh.delaunay"
params = { points = "points", mesh = "tessellation" }

[[steps]]
rule = "grid.noise"
params = { grid = "terrain", nx = 16, ny = 16 }

[[outputs]]
domain = "tessellation"
format = "svg_mesh"
file = "tessellation.svg"

[[outputs]]
domain = "terrain"
format = "image_png"
file = "terrain.png"
options = { field = "surface__height", cmap = "terrain" }
"""
GRID = ["steps.0.params.radius=0.1,0.2"]
SEEDS = [1, 2, 3]


def _isolation() -> str:
    """"unshare" where this process may give children a private tmpfs (root with CAP_SYS_ADMIN, as
    in CI), else "cwd"."""
    if os.name != "posix" or os.geteuid() != 0 or not (shutil.which("unshare") and shutil.which("mount")):
        return "cwd"
    with tempfile.TemporaryDirectory() as probe:
        r = subprocess.run(["unshare", "--mount", "sh", "-c", 'mount -t tmpfs procgen-probe "$0"', probe],
                           capture_output=True, timeout=30)
    return "unshare" if r.returncode == 0 else "cwd"


MODE = _isolation()


class Cluster:
    def __init__(self, root: Path) -> None:
        self.root = root
        self.client_dir = root / "client"          # the client's folder: recipe and outputs
        self.client_dir.mkdir()
        self.mode = MODE
        # the workers' files: inside the hidden tmpfs with unshare, beside the client's otherwise
        self.scratch = self.client_dir / "worker-scratch" if self.mode == "unshare" else root / "workers"
        self.procs: list[subprocess.Popen] = []
        self.address = ""

    def _spawn(self, cmd: list[str], log: str) -> subprocess.Popen:
        # this folder on the path: the killed-worker test's task function is importable there too
        env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(Path(__file__).parent), os.environ.get("PYTHONPATH", "")])}
        with open(self.root / log, "wb") as fh:
            p = subprocess.Popen(cmd, stdout=fh, stderr=subprocess.STDOUT, start_new_session=True, env=env,
                                 cwd=self.root / "workers" if self.mode == "cwd" else "/")
        self.procs.append(p)
        return p

    def start(self) -> None:
        (self.root / "workers").mkdir()
        sched_file = self.root / "scheduler.json"
        sched = self._spawn([sys.executable, "-m", "distributed.cli.dask_scheduler", "--host", "127.0.0.1",
                             "--port", "0", "--no-dashboard", "--scheduler-file", str(sched_file),
                             "--idle-timeout", "600"], "scheduler.log")
        for _ in range(600):        # poll its address file for up to about a minute
            if sched.poll() is not None:
                break
            try:
                self.address = json.loads(sched_file.read_text())["address"]
                break
            except (OSError, ValueError, KeyError):
                time.sleep(0.1)
        if not self.address:
            raise RuntimeError("dask scheduler did not start:\n" + (self.root / "scheduler.log").read_text())
        # two worker processes (each under a nanny that restarts it if it dies) sharing one namespace
        cmd = [sys.executable, "-m", "distributed.cli.dask_worker", self.address, "--nworkers", "2",
               "--nthreads", "1", "--no-dashboard", "--death-timeout", "60", "--local-directory", str(self.scratch)]
        if self.mode == "unshare":   # a private tmpfs over the client's folder, then the workers
            cmd = ["unshare", "--mount", "sh", "-c", 'mount -t tmpfs procgen-hidden "$0" && exec "$@"',
                   str(self.client_dir), *cmd]
        self._spawn(cmd, "workers.log")

    def stop(self) -> None:
        for p in self.procs:   # each process group we started: the scheduler; the workers and their nannies
            try:
                os.killpg(p.pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
        for p in self.procs:
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()

    def logs(self) -> str:
        return "\n".join(f"--- {f.name}\n{f.read_text(errors='replace')[-3000:]}" for f in self.root.glob("*.log"))


@pytest.fixture(scope="module")
def cluster(tmp_path_factory):
    c = Cluster(tmp_path_factory.mktemp("cluster"))
    (c.client_dir / "tiny.toml").write_text(TINY)
    try:
        c.start()
        with distributed.Client(c.address, timeout="60s") as client:
            client.wait_for_workers(2, timeout=120)
            c.client = client
            yield c
    except Exception:
        print(c.logs())
        raise
    finally:
        c.stop()


@pytest.fixture
def in_client_dir(cluster, monkeypatch):
    monkeypatch.chdir(cluster.client_dir)   # the client writes to a relative path, as a user would
    return cluster


def _tree(root: Path) -> dict[str, bytes]:
    """Every file of a sweep, run.json without its timings (the only bytes allowed to differ)."""
    out = {}
    for p in sorted(root.rglob("*")):
        rel = p.relative_to(root).as_posix()
        if not p.is_file() or p.name in (STAMP, "summary.csv"):
            continue
        data = p.read_bytes()
        if p.name == "run.json":
            info = json.loads(data)
            for st in info["steps"]:
                st.pop("seconds")
            data = json.dumps(info, sort_keys=True).encode()
        out[rel] = data
    return out


def _workers_see(cluster, path: Path) -> list[bool]:
    return list(cluster.client.run(os.path.exists, str(path.resolve())).values())


@pytest.mark.parametrize("isolation", [MODE])
def test_cluster_sweep_hands_files_back_and_resumes(in_client_dir, isolation):
    c = in_client_dir
    local = sweep("tiny.toml", GRID, SEEDS, Path("local"), jobs=1, progress=False)
    assert [r.status for r in local] == ["done"] * 6
    remote = sweep("tiny.toml", GRID, SEEDS, Path("remote"), scheduler=c.address, progress=False)
    assert [r.status for r in remote] == ["done"] * 6, [r.error for r in remote]
    print(f"isolation: {c.mode}")
    if c.mode == "unshare":     # the workers cannot see the client's folder, nor the recipe in it
        assert _workers_see(c, Path("remote")) == [False, False]
        assert _workers_see(c, Path("tiny.toml")) == [False, False]
    else:                       # nothing landed in the workers' working directory
        assert not (c.root / "workers" / "remote").exists()
    a, b = _tree(Path("local")), _tree(Path("remote"))
    assert len(a) == 6 * 3 and a.keys() == b.keys()
    for k in a:
        assert a[k] == b[k], f"{k} differs between the local and the cluster run"
    assert sorted(p.parent.parent.name + "/" + p.parent.name for p in Path("remote").rglob(STAMP)) == \
        sorted(r.key for r in remote)
    rows = list(csv.DictReader(Path("remote/summary.csv").open()))
    assert [r["status"] for r in rows] == ["done"] * 6 and all(int(r["points.n_points"]) > 0 for r in rows)
    # a second sweep redoes nothing: every run skipped, not one file rewritten
    mtimes = {p: p.stat().st_mtime_ns for p in Path("remote").rglob("*") if p.is_file() and p.name != "summary.csv"}
    again = sweep("tiny.toml", GRID, SEEDS, Path("remote"), scheduler=c.address, progress=False)
    assert [r.status for r in again] == ["skipped"] * 6
    assert {p: p.stat().st_mtime_ns for p in mtimes} == mtimes


def test_cluster_failing_job_is_reported_and_others_finish(in_client_dir, capsys):
    c = in_client_dir
    # the colour map is looked up by the exporter on the worker: the recipe checks, the run fails there
    code = main(["sweep", "tiny.toml", "--grid", "outputs.1.options.cmap=gray,no_such_cmap", "--seeds", "1,2",
                 "--out", "failing", "--scheduler", c.address])
    printed = capsys.readouterr().out
    assert code == 1
    assert "sweep: 2 run, 0 up to date, 2 failed" in printed
    assert printed.count("FAILED") == 2 and "no_such_cmap" in printed
    rows = {r["run"]: r for r in csv.DictReader(Path("failing/summary.csv").open())}
    assert {k: r["status"] for k, r in rows.items()} == {
        "cmap-gray/seed-1": "done", "cmap-gray/seed-2": "done",
        "cmap-nosuchcmap/seed-1": "failed", "cmap-nosuchcmap/seed-2": "failed"}
    assert all("no_such_cmap" in rows[k]["error"] for k in rows if "no_such" in k)
    assert sorted(p.name for p in Path("failing/cmap-gray/seed-1").iterdir()) == \
        [STAMP, "run.json", "terrain.png", "tessellation.svg"]
    assert not Path("failing/cmap-nosuchcmap").exists()   # a failed run leaves nothing behind


def test_cluster_gallery_takes_the_same_path(in_client_dir, host):
    import re

    from procgen.gallery import build_gallery

    c = in_client_dir
    rep = build_gallery(host, only=["demo/*"], quick=True, out_dir=Path("gallery"), scheduler=c.address,
                        progress=False)
    assert rep.results and [r.status for r in rep.results] == ["done"] * len(rep.results), rep.summary()
    if c.mode == "unshare":
        assert _workers_see(c, Path("gallery")) == [False, False]
    index = Path("gallery/index.html").read_text()
    pictures = re.findall(r'<img src="([^"]+)"', index)
    assert len(pictures) >= 2 * len(rep.results) and all(Path("gallery", p).is_file() for p in pictures)
    again = build_gallery(host, only=["demo/*"], quick=True, out_dir=Path("gallery"), scheduler=c.address,
                          progress=False)
    assert [r.status for r in again.results] == ["skipped"] * len(rep.results)


def _die_once(job):
    """Kill the worker process running the first job that gets here; later attempts run normally."""
    from distributed import get_worker

    from procgen.jobs import compute_job

    # the workers' shared scratch folder (worker-xxxx/.. is the same for both)
    marker = os.path.join(os.path.dirname(get_worker().local_directory), "killed-once")
    try:
        os.close(os.open(marker, os.O_CREAT | os.O_EXCL))
    except FileExistsError:
        return compute_job(job)
    os._exit(1)


def test_cluster_worker_dying_mid_job_is_retried_and_written_once(in_client_dir, monkeypatch):
    import procgen.jobs

    c = in_client_dir
    local = sweep("tiny.toml", GRID, SEEDS, Path("killed-local"), jobs=1, progress=False)
    before = set(c.client.scheduler_info()["workers"])
    monkeypatch.setattr(procgen.jobs, "compute_job", _die_once)
    commits: list[str] = []
    real_commit = procgen.jobs.commit
    monkeypatch.setattr(procgen.jobs, "commit", lambda job, out: (commits.append(job.key), real_commit(job, out)))
    res = sweep("tiny.toml", GRID, SEEDS, Path("killed"), scheduler=c.address, progress=False)
    assert [r.status for r in res] == ["done"] * 6, [r.error for r in res]
    assert sorted(commits) == sorted(r.key for r in res)          # each run written once
    c.client.wait_for_workers(2, timeout=120)
    assert set(c.client.scheduler_info()["workers"]) != before      # a worker did die (its nanny restarted it)
    assert [r.status for r in local] == ["done"] * 6
    assert _tree(Path("killed")) == _tree(Path("killed-local"))
    assert not list(Path("killed").rglob(".tmp-*"))
