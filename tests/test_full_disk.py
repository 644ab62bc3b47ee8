"""A full disk loses nothing: one line naming the file, exit 1, no partial run folder, and a batch
records that run as failed and goes on (then resumes without redoing finished runs).

The disk is simulated by making procgen's one low-level write (``_store``) fail with ENOSPC,
for every file after the first N, or for the files of one run of a batch.
"""
from __future__ import annotations

import csv
import errno
import importlib
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from procgen.cli import main
from procgen.exchange import write
from procgen.sweep import sweep

WRITE = importlib.import_module("procgen.exchange.write")
RECIPE = """
[recipe]
name = "full-disk"
seed = 3

[[steps]]
rule = "grid.noise"
params = { grid = "terrain", nx = 16, ny = 16 }

[[outputs]]
domain = "terrain"
format = "npy"
file = "height.npy"

[[outputs]]
domain = "terrain"
format = "heightmap_png16"
file = "height16.png"

[[outputs]]
domain = "terrain"
format = "image_png"
file = "colour.png"
options = { field = "surface__height" }

[[outputs]]
domain = "terrain"
format = "image_png"
file = "maps/colour2.png"
options = { field = "surface__height", cmap = "terrain" }
"""
# written in this order: height.npy, height.json, height16.png, height16.json, colour.png,
# maps/colour2.png, run.json
FILES = ["colour.png", "height.json", "height.npy", "height16.json", "height16.png", "maps/colour2.png",
         "run.json"]


def full_after(monkeypatch, n: int) -> list[int]:
    """The disk fills up after ``n`` files; returns the list of files stored so far (its length)."""
    stored: list[int] = []
    real = WRITE._store

    def store(fd: int, blob: bytes) -> None:
        if len(stored) >= n:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real(fd, blob)
        stored.append(len(blob))

    monkeypatch.setattr(WRITE, "_store", store)
    return stored


def full_where(monkeypatch, part: str) -> None:
    """Every file whose path (as the system sees it) contains ``part`` finds the disk full."""
    real = WRITE._store

    def store(fd: int, blob: bytes) -> None:
        if part in os.readlink(f"/proc/self/fd/{fd}"):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        real(fd, blob)

    monkeypatch.setattr(WRITE, "_store", store)


def everything(root: Path) -> list[str]:
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*"))


@pytest.fixture
def recipe(tmp_path) -> Path:
    (tmp_path / "rec.toml").write_text(RECIPE)
    return tmp_path / "rec.toml"


def test_the_recipe_writes_seven_files(recipe, tmp_path, capsys):
    assert main(["run", str(recipe), "--out", str(tmp_path / "out")]) == 0
    assert [p for p in everything(tmp_path / "out") if p != "maps"] == FILES


def test_a_full_disk_is_one_line_exit_1_and_no_run_folder(recipe, tmp_path, monkeypatch, capsys):
    stored = full_after(monkeypatch, 4)
    assert main(["run", str(recipe), "--out", str(tmp_path / "out")]) == 1
    err = capsys.readouterr().err
    assert err == f"procgen: error: {tmp_path / 'out' / 'colour.png'}: cannot write (no space left on device)\n"
    assert len(stored) == 4                                    # four files were on the disk...
    assert everything(tmp_path) == ["rec.toml"]               # ...and none of them is left, nor a temp


def test_a_full_disk_leaves_the_previous_run_as_it_was(recipe, tmp_path, monkeypatch, capsys):
    out = tmp_path / "out"
    assert main(["run", str(recipe), "--out", str(out), "--seed", "1"]) == 0
    (out / "mine.txt").write_text("the user's own file")
    before = {p: (out / p).read_bytes() for p in everything(out) if (out / p).is_file()}
    full_after(monkeypatch, 6)                                  # only run.json finds the disk full
    assert main(["run", str(recipe), "--out", str(out), "--seed", "2"]) == 1
    assert capsys.readouterr().err.endswith(f"{out / 'run.json'}: cannot write (no space left on device)\n")
    assert {p: (out / p).read_bytes() for p in everything(out) if (out / p).is_file()} == before


def test_write_keeps_the_old_file_and_no_temp(tmp_path, monkeypatch):
    write(tmp_path / "a.txt", "old")
    full_after(monkeypatch, 0)
    with pytest.raises(WRITE.WriteError, match=r"a\.txt: cannot write \(no space left on device\)$"):
        write(tmp_path / "a.txt", "new")
    assert everything(tmp_path) == ["a.txt"] and (tmp_path / "a.txt").read_text() == "old"


def test_a_sweep_records_the_run_as_failed_goes_on_and_resumes(recipe, tmp_path, monkeypatch):
    out = tmp_path / "sweep"
    full_where(monkeypatch, f"{os.sep}.tmp-seed-2-")          # the disk refuses seed 2's folder
    results = sweep(str(recipe), [], [1, 2, 3], out, progress=False)
    assert [r.status for r in results] == ["done", "failed", "done"]
    assert results[1].error == f"{out / 'base' / 'seed-2' / 'height.npy'}: cannot write (no space left on device)"
    assert sorted(p.name for p in (out / "base").iterdir()) == ["seed-1", "seed-3"]     # no partial seed-2
    assert [p for p in everything(out / "base" / "seed-1") if p != "maps"] == sorted(
        [*FILES, ".procgen-done.json"])
    rows = list(csv.DictReader((out / "summary.csv").open()))
    assert [(r["seed"], r["status"]) for r in rows] == [("1", "done"), ("2", "failed"), ("3", "done")]
    assert rows[1]["error"] == results[1].error
    monkeypatch.undo()                                          # space again: only seed 2 runs
    again = sweep(str(recipe), [], [1, 2, 3], out, progress=False)
    assert [r.status for r in again] == ["skipped", "done", "skipped"]


def test_the_gallery_records_the_run_as_failed_and_writes_its_index(recipe, tmp_path, monkeypatch):
    from procgen import get_plugin_manager
    from procgen.gallery import build_gallery

    (tmp_path / "g.toml").write_text(f'[[entry]]\nrecipe = "{recipe}"\nid = "disk"\nseeds = [1, 2]\n')
    full_where(monkeypatch, f"{os.sep}.tmp-seed-1-")
    report = build_gallery(get_plugin_manager(), gallery_file=tmp_path / "g.toml", out_dir=tmp_path / "gal",
                           progress=False)
    assert [(r.seed, r.status) for r in report.results] == [(1, "failed"), (2, "done")]
    assert report.failed[0].error.endswith("disk/seed-1/height.npy: cannot write (no space left on device)")
    assert not (tmp_path / "gal" / "disk" / "seed-1").exists() and (tmp_path / "gal" / "index.html").is_file()
    assert "seed 1: " in report.summary() and "no space left on device" in report.summary()


def test_procgen_run_on_a_full_disk_in_a_process_of_its_own(recipe, tmp_path):
    """The whole command, as a user runs it: exit 1, one line on stderr, nothing on the disk."""
    script = textwrap.dedent(f"""
        import errno, importlib, os, sys
        w = importlib.import_module("procgen.exchange.write")
        real, count = w._store, [0]
        def store(fd, blob):
            if count[0] >= 2:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            count[0] += 1
            real(fd, blob)
        w._store = store
        from procgen.cli import main
        sys.exit(main(["run", {str(recipe)!r}, "--out", {str(tmp_path / "out")!r}]))
        """)
    r = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=120,
                       cwd=tmp_path)
    assert r.returncode == 1 and r.stdout == ""
    assert r.stderr == (f"procgen: error: {tmp_path / 'out' / 'height16.png'}: cannot write "
                        "(no space left on device)\n")
    assert everything(tmp_path) == ["rec.toml"]
