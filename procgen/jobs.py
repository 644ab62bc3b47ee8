"""One unit of batch work (recipe + overrides + seed -> folder), shared by gallery and sweep.

A job renders into a temporary sibling folder that is renamed into place only when complete,
with a stamp file holding a provenance hash. A job whose stamp matches is skipped, so a killed
batch resumes where it stopped. The function is picklable and self-contained, so it runs the
same in a local process pool and on a dask.distributed worker.
"""
from __future__ import annotations

import hashlib
import json
import os
import shutil
import time
import traceback
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from .errors import ProcgenError
from .exchange import write

STAMP = ".procgen-done.json"


@dataclass
class JobResult:
    key: str
    seed: int
    status: str  # "done", "skipped", "failed"
    seconds: float = 0.0
    error: str = ""
    files: list[str] = field(default_factory=list)
    reports: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


def job_hash(recipe_data: dict[str, Any], seed: int, versions: dict[str, str]) -> str:
    blob = json.dumps({"recipe": recipe_data, "seed": seed, "versions": versions},
                      sort_keys=True, default=str).encode()
    return hashlib.sha256(blob).hexdigest()


def render_job(key: str, recipe_ref: str, overrides: list[str], seed: int, folder: str,
               force: bool = False) -> JobResult:
    """Run ``recipe_ref`` with ``overrides`` and ``seed`` into ``folder`` unless already done there."""
    from .plugins import get_plugin_manager
    from .recipes import load_recipe
    from .runner import run

    t0 = time.perf_counter()
    final = Path(folder)
    try:
        host = get_plugin_manager()
        recipe = load_recipe(recipe_ref, host, overrides)
        h = job_hash(recipe.data, seed, host.versions())
        stamp = final / STAMP
        if not force and stamp.is_file():
            try:
                old = json.loads(stamp.read_text())
                if old.get("hash") == h:
                    return JobResult(key, seed, "skipped", float(old.get("seconds", 0.0)),
                                     files=old.get("files", []), reports=old.get("reports", {}))
            except (OSError, ValueError):
                pass
        tmp = final.parent / f".tmp-{final.name}-{os.getpid()}"
        shutil.rmtree(tmp, ignore_errors=True)
        result = run(recipe, host, seed=seed, out_dir=tmp, progress=False)
        secs = time.perf_counter() - t0
        info = {"hash": h, "recipe": recipe_ref, "overrides": overrides, "seed": seed,
                "seconds": round(secs, 3), "files": sorted(result.files), "reports": result.state.reports}
        write(tmp / STAMP, json.dumps(info, indent=2, sort_keys=True, default=str))
        if final.exists():
            shutil.rmtree(final)
        os.replace(tmp, final)
        return JobResult(key, seed, "done", secs, files=sorted(result.files),
                         reports=json.loads(json.dumps(result.state.reports, default=str)))
    except ProcgenError as exc:
        return JobResult(key, seed, "failed", time.perf_counter() - t0, error=" ".join(str(exc).split()))
    except Exception as exc:  # one broken job must not stop the batch
        tb = traceback.extract_tb(exc.__traceback__)[-1]
        return JobResult(key, seed, "failed", time.perf_counter() - t0,
                         error=f"{type(exc).__name__}: {exc} (at {Path(tb.filename).name}:{tb.lineno})")


def clean_stale_temps(root: Path) -> None:
    """Remove temporary folders left by killed jobs (they are never complete)."""
    if root.is_dir():
        for tmp in root.rglob(".tmp-*"):
            if tmp.is_dir():
                shutil.rmtree(tmp, ignore_errors=True)
