"""Batch work (recipe + overrides + seed -> folder) run locally or on dask, shared by gallery and sweep.

The split follows who can see the output folder. Only the client is sure to: the machines of a
dask.distributed cluster often share no filesystem with it. So

- the client plans each job: it loads and checks the recipe, hashes it with the seed and the
  package versions, and skips a job whose folder holds a stamp with that hash (a finished run is
  never redone);
- a worker (a local process or a dask worker on another machine) gets the resolved recipe itself,
  not a path, renders the run in memory and hands back the files' bytes;
- the client commits each result as it arrives: the files into a temporary sibling folder, the
  stamp last, then one rename. A killed client or worker, or a full disk, never leaves a
  half-written run folder (a refused write makes that run "failed" and the batch goes on), and
  a job that dask re-runs after its worker died is written once, when its result arrives.

Results are taken as they complete with a bounded number in flight, so neither the client nor
the cluster ever holds the whole batch; a failing job becomes a "failed" result with its error
and the others go on.
"""
from __future__ import annotations

import concurrent.futures as cf
import functools
import hashlib
import itertools
import json
import shutil
import sys
import time
import traceback
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import TYPE_CHECKING, Any

from .accel import share_cores
from .errors import MissingExtra, ProcgenError, RecipeError, printable, shown
from .exchange.write import STAGING_PREFIX, write_folder
from .recipes import RESERVED_FILES

if TYPE_CHECKING:
    from .plugins import PluginHost

STAMP = RESERVED_FILES[2]          # ".procgen-done.json": recipes refuse it as an output name


@dataclass
class JobResult:
    key: str
    seed: int
    status: str  # "done", "skipped" (up to date), "failed", "unavailable" (needs an optional extra)
    seconds: float = 0.0
    error: str = ""
    files: list[str] = field(default_factory=list)
    reports: dict[str, Any] = field(default_factory=dict)

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass(frozen=True)
class Job:
    """One run: ``recipe`` (a name or a file on the client) with ``overrides`` and ``seed`` into ``folder``.

    ``plan_job`` fills the rest on the client; those fields are what a worker needs, so it never
    reads the client's disk.
    """

    key: str
    recipe: str
    overrides: tuple[str, ...]
    seed: int
    folder: str
    data: dict[str, Any] = field(default_factory=dict)   # the recipe after overrides, checked
    source: str = ""
    base_dir: str | None = None
    versions: dict[str, str] = field(default_factory=dict)
    hash: str = ""


@dataclass
class JobOutput:
    """What a worker hands back: the result and, when done, every file's bytes."""

    result: JobResult
    files: dict[str, bytes] = field(default_factory=dict)


def job_hash(recipe_data: dict[str, Any], seed: int, versions: dict[str, str]) -> str:
    blob = json.dumps({"recipe": recipe_data, "seed": seed, "versions": versions},
                      sort_keys=True, default=str).encode()
    return hashlib.sha256(blob).hexdigest()


def _failed(job: Job, t0: float, exc: BaseException) -> JobResult:
    if isinstance(exc, ProcgenError):
        error = shown(" ".join(str(exc).split()))
    else:
        tb = traceback.extract_tb(exc.__traceback__)
        where = f" (at {Path(tb[-1].filename).name}:{tb[-1].lineno})" if tb else ""
        error = shown(f"{type(exc).__name__}: {' '.join(str(exc).split())}{where}")
    status = "unavailable" if isinstance(exc, MissingExtra) else "failed"
    return JobResult(job.key, job.seed, status, time.perf_counter() - t0, error=error)


def plan_job(job: Job, host: "PluginHost", loaded: dict[tuple[str, tuple[str, ...]], Any] | None = None) -> Job:
    """Load and check the job's recipe on the client; fill what a worker needs. Raises ProcgenError.

    ``loaded`` caches recipes by (recipe, overrides): the seeds of a sweep share one.
    """
    from .recipes import load_recipe

    loaded = {} if loaded is None else loaded
    if (job.recipe, job.overrides) not in loaded:
        loaded[job.recipe, job.overrides] = load_recipe(job.recipe, host, list(job.overrides))
    recipe = loaded[job.recipe, job.overrides]
    versions = host.versions()
    return replace(job, data=recipe.data, source=recipe.source,
                   base_dir=None if recipe.base_dir is None else str(recipe.base_dir),
                   versions=versions, hash=job_hash(recipe.data, job.seed, versions))


def stamp_result(job: Job) -> JobResult | None:
    """The skipped result when ``job.folder`` already holds this job's finished run."""
    try:
        old = json.loads((Path(job.folder) / STAMP).read_text())
    except (OSError, ValueError):
        return None
    if not isinstance(old, dict) or old.get("hash") != job.hash:
        return None
    return JobResult(job.key, job.seed, "skipped", float(old.get("seconds", 0.0)),
                     files=old.get("files", []), reports=old.get("reports", {}))


@functools.lru_cache(maxsize=1)
def _worker_host() -> "PluginHost":
    """One plugin host per worker process (building it loads every entry point)."""
    from .plugins import get_plugin_manager

    return get_plugin_manager()


def compute_job(job: Job, host: "PluginHost | None" = None) -> JobOutput:
    """Render a planned job in memory and return its files' bytes. Runs on a worker.

    Writes nothing (a worker needs no disk); any error becomes a "failed" result, and a warning
    one line naming the run.
    """
    t0 = time.perf_counter()
    try:
        with warnings.catch_warnings():
            warnings.showwarning = functools.partial(_show_warning, job)
            return _compute(job, host, t0)
    except Exception as exc:  # one broken job must not stop the batch
        return JobOutput(_failed(job, t0, exc))


def _show_warning(job: Job, message: Warning | str, *_: Any, **__: Any) -> None:
    """A warning raised in a job as one line naming the run: its text, never the warning's class
    or the file that raised it (a library's site-packages path)."""
    sys.stderr.write(f"procgen: warning: {printable(job.key)}: {shown(' '.join(str(message).split()))}\n")
    sys.stderr.flush()      # one write: lines of parallel workers never interleave


def _compute(job: Job, host: "PluginHost | None", t0: float) -> JobOutput:
    """``compute_job``'s work; raises what the job raises."""
    from .recipes import check_recipe
    from .runner import render

    host = host or _worker_host()
    versions = host.versions()
    if versions != job.versions:
        diff = sorted(k for k in {*versions, *job.versions} if versions.get(k) != job.versions.get(k))
        raise RecipeError("this worker's packages differ from the client's ("
                          + ", ".join(f"{k}: worker {versions.get(k, 'missing')}, client "
                                      f"{job.versions.get(k, 'missing')}" for k in diff)
                          + "); install the same procgen and plugins on every worker")
    recipe = check_recipe(job.data, host, job.source, None if job.base_dir is None else Path(job.base_dir))
    result, files = render(recipe, host, seed=job.seed, progress=False)
    reports = json.loads(json.dumps(result.state.reports, default=str))
    return JobOutput(JobResult(job.key, job.seed, "done", time.perf_counter() - t0,
                               files=sorted(files), reports=reports), files)


def commit(job: Job, out: JobOutput) -> None:
    """Write a done job's files into its folder: staged beside it, stamp last, one rename.

    Raises WriteError (a full disk...) and leaves the folder as it was.
    """
    res = out.result
    info = {"hash": job.hash, "recipe": job.recipe, "overrides": list(job.overrides), "seed": job.seed,
            "seconds": round(res.seconds, 3), "files": res.files, "reports": res.reports}
    write_folder(job.folder, {**out.files, STAMP: json.dumps(info, indent=2, sort_keys=True, default=str)},
                 replace=True)


def clean_stale_temps(root: Path) -> None:
    """Remove temporary folders left by killed jobs (they are never complete)."""
    if root.is_dir():
        for tmp in root.rglob(f"{STAGING_PREFIX}*"):
            if tmp.is_dir():
                shutil.rmtree(tmp, ignore_errors=True)


def _executor(processes: int, scheduler: Any) -> tuple[cf.Executor | None, Callable[[], int], Callable[[], None]]:
    """(executor, how many jobs to keep in flight now, close) for local processes or a dask cluster."""
    if scheduler is None:
        if processes <= 1:
            return None, lambda: 1, lambda: None
        pool = cf.ProcessPoolExecutor(max_workers=processes, initializer=share_cores,
                                      initargs=(processes,))
        return pool, lambda: 2 * processes, lambda: pool.shutdown(cancel_futures=True)
    try:
        from dask.distributed import Client
    except ImportError:
        raise RecipeError("--scheduler needs the dask extra: pip install 'procgen-rules[dask]'") from None
    own = isinstance(scheduler, str)
    try:
        client = Client(scheduler, timeout="20s") if own else scheduler
    except (OSError, TimeoutError) as exc:
        raise RecipeError(f"--scheduler {scheduler}: cannot reach the dask scheduler ({exc})") from None
    # pure=False: a seed is a new run each time, never a cached result of an earlier one.
    # The window follows the cluster as workers join or leave.
    return (client.get_executor(pure=False), lambda: 2 * max(1, sum(client.nthreads().values())),
            client.close if own else lambda: None)


def _outputs(todo: Sequence[tuple[int, Job]], executor: cf.Executor | None, window: Callable[[], int],
             host: "PluginHost") -> Iterator[tuple[int, Job, JobOutput]]:
    """Each (index, job) with its output, as jobs complete; at most ``window()`` in flight."""
    if executor is None:
        for i, job in todo:
            yield i, job, compute_job(job, host)
        return
    waiting = iter(todo)
    inflight: dict[cf.Future, tuple[int, Job]] = {}
    while True:
        room = window() - len(inflight)
        for i, job in itertools.islice(waiting, max(0, room)):
            inflight[executor.submit(compute_job, job)] = (i, job)
        if not inflight:
            return
        done, _ = cf.wait(inflight, return_when=cf.FIRST_COMPLETED)
        for fut in done:
            i, job = inflight.pop(fut)
            try:
                out = fut.result()
            except Exception as exc:  # the task itself died: dask gave up on lost workers, unpicklable...
                out = JobOutput(_failed(job, time.perf_counter(), exc))
            yield i, job, out


def run_jobs(jobs: Sequence[Job], host: "PluginHost", *, processes: int = 1, scheduler: Any = None,
             force: bool = False, desc: str = "jobs", progress: bool | None = None) -> list[JobResult]:
    """Plan, skip what is done, run the rest (``processes`` local processes, or the dask cluster at
    ``scheduler``: an address or a ``Client``), commit each result as it arrives. Results in job order.

    A job whose recipe does not load fails on its own; the others run.
    """
    from tqdm import tqdm

    results: dict[int, JobResult] = {}
    todo: list[tuple[int, Job]] = []
    loaded: dict[tuple[str, tuple[str, ...]], Any] = {}
    for i, job in enumerate(jobs):
        t0 = time.perf_counter()
        try:
            planned = plan_job(job, host, loaded)
        except ProcgenError as exc:
            results[i] = _failed(job, t0, exc)
            continue
        skipped = None if force else stamp_result(planned)
        if skipped is not None:
            results[i] = skipped
        else:
            todo.append((i, planned))
    del loaded
    # A terminal gets a bar naming the last finished run; a log (stderr not a terminal, progress
    # left to decide) gets one line per finished run, so a long batch is never silent.
    show = sys.stderr.isatty() if progress is None else progress
    lines = progress is None and not show
    with tqdm(total=len(jobs), initial=len(results), desc=desc, unit="run", disable=not show,
              file=sys.stderr) as bar:
        if todo:
            executor, window, close = _executor(processes, scheduler)
            try:
                for i, job, out in _outputs(todo, executor, window, host):
                    if out.result.status == "done":
                        try:
                            commit(job, out)
                        except ProcgenError as exc:     # a full disk: this run failed, the rest go on
                            out = JobOutput(replace(_failed(job, 0.0, exc), seconds=out.result.seconds))
                    results[i] = out.result
                    bar.set_postfix_str(f"{job.key} seed {job.seed} {out.result.status}", refresh=False)
                    bar.update(1)
                    if lines:
                        print(progress_line(desc, out.result, len(results), len(jobs)), file=sys.stderr,
                              flush=True)
            finally:
                close()
    return [results[i] for i in range(len(jobs))]


def progress_line(desc: str, result: JobResult, done: int, total: int) -> str:
    """``gallery [12/175] clouds-fig-4-3a seed 101: 12.3 s done`` (a failure adds its error)."""
    text = (f"{desc} [{done}/{total}] {printable(result.key)} seed {result.seed}: "
            f"{result.seconds:.1f} s {result.status}")
    return f"{text}: {printable(result.error)}" if result.error else text


def render_job(key: str, recipe_ref: str, overrides: list[str], seed: int, folder: str,
               force: bool = False) -> JobResult:
    """One job in this process, resumable like any batch job."""
    from .plugins import get_plugin_manager

    return run_jobs([Job(key, recipe_ref, tuple(overrides), seed, folder)], get_plugin_manager(),
                    force=force, progress=False)[0]
