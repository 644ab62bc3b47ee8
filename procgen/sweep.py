"""Parameter x seed sweeps: the product of --grid values and seeds, run locally or on dask.

Each run is a resumable job (procgen.jobs): in a local process pool, or with a scheduler address
on a dask.distributed cluster (extra ``dask``; imported only then) whose workers hand the files
back to this process, so the cluster needs no filesystem shared with it. The summary CSV has a
row per run with its parameters, status, time and reported numbers.
"""
from __future__ import annotations

import csv
import io
import itertools
import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from .errors import RecipeError
from .exchange import write
from .exchange.write import make_folder
from .jobs import Job, JobResult, clean_stale_temps, run_jobs
from .recipes import MAX_SEED, parse_override

#: Runs one sweep may plan (grid points x seeds): each run is a folder and a row of summary.csv,
#: and the plan is a list in memory, so ``--seeds 1-1000000000`` is refused before it is built.
MAX_RUNS = 100_000
#: Grid points (parameter combinations): each one's recipe is checked before any run starts.
MAX_GRID_POINTS = 10_000


@dataclass
class SweepRun:
    key: str
    overrides: list[str]
    values: dict[str, Any]
    seed: int


def parse_grid(spec: str) -> tuple[str, list[str]]:
    """``steps.3.params.n_c=2,4,8`` -> ('steps.3.params.n_c', ['2', '4', '8'])."""
    if "=" not in spec:
        raise RecipeError(f"--grid {spec!r}: expected KEY=V1,V2,..., e.g. steps.1.params.radius=0.01,0.02")
    key, raw = spec.split("=", 1)
    values = [v.strip() for v in raw.split(",") if v.strip()]
    if not values:
        raise RecipeError(f"--grid {spec!r}: no values")
    if len(values) > MAX_GRID_POINTS:
        raise RecipeError(f"--grid {key.strip()[:60]}: {len(values):,} values, more than the "
                          f"{MAX_GRID_POINTS:,} grid points a sweep may have")
    for v in values:
        parse_override(f"{key}={v}")
    return key.strip(), values


def parse_seeds(spec: str) -> list[int]:
    """``1-100``, ``3``, or ``1,5,9`` (ranges inclusive)."""
    seeds: list[int] = []
    shown = spec if len(spec) <= 60 else spec[:57] + "..."
    for part in spec.split(","):
        part = part.strip()
        m = re.fullmatch(r"(\d{1,19})-(\d{1,19})", part)
        if m:
            a, b = int(m.group(1)), int(m.group(2))
            if b < a:
                raise RecipeError(f"--seeds {shown!r}: range {part} runs backwards")
            if b > MAX_SEED:
                raise RecipeError(f"--seeds {shown!r}: seed {b} is above 2^63 - 1")
            if len(seeds) + b - a + 1 > MAX_RUNS:
                raise RecipeError(f"--seeds {shown!r}: {len(seeds) + b - a + 1:,} seeds, more than the "
                                  f"{MAX_RUNS:,} runs a sweep may have")
            seeds.extend(range(a, b + 1))
        elif part.isdigit() and len(part) <= 19 and int(part) <= MAX_SEED:
            seeds.append(int(part))
        elif part.isdigit():
            raise RecipeError(f"--seeds {shown!r}: seed {part[:25]} is above 2^63 - 1")
        else:
            raise RecipeError(f"--seeds {shown!r}: expected N, A-B or a comma list")
        if len(seeds) > MAX_RUNS:
            raise RecipeError(f"--seeds {shown!r}: more than the {MAX_RUNS:,} runs a sweep may have")
    return seeds


def plan(grids: list[str], seeds: list[int]) -> list[SweepRun]:
    axes = [parse_grid(g) for g in grids]
    points = 1
    for _, vals in axes:          # refused before the product is built
        points *= len(vals)
        if points > MAX_GRID_POINTS or points * len(seeds) > MAX_RUNS:
            sizes = " x ".join(str(len(v)) for _, v in axes)
            raise RecipeError(f"--grid: {sizes} values x {len(seeds)} seeds is more than a sweep may have "
                              f"({MAX_GRID_POINTS:,} grid points, {MAX_RUNS:,} runs)")
    runs = []
    used: dict[str, int] = {}
    for combo in itertools.product(*[[(k, v) for v in vals] for k, vals in axes]):
        # a folder name, never a path: letters, digits, '_' of the key, and '.', '+', '-' of the value
        # (so -1 and 1, 1e-3 and 1e3 stay apart); a name two grid points would share (the same
        # parameter of two steps, values differing only in other characters) gets ~2, ~3, ...
        label = "_".join(f"{re.sub(r'[^A-Za-z0-9_]+', '', k.rsplit('.', 1)[-1])}-{re.sub(r'[^A-Za-z0-9.+-]+', '', v)}"
                         for k, v in combo).lstrip(".") or "base"
        used[label] = used.get(label, 0) + 1
        if used[label] > 1:
            label = f"{label}~{used[label]}"
        for seed in seeds:
            runs.append(SweepRun(f"{label}/seed-{seed}", [f"{k}={v}" for k, v in combo], dict(combo), seed))
    return runs


def sweep(recipe_ref: str, grids: list[str], seeds: list[int], out_dir: Path, *, jobs: int = 1,
          scheduler: str | None = None, force: bool = False, progress: bool | None = None) -> list[JobResult]:
    """Run every (grid point, seed); write ``summary.csv``; return the results in plan order.

    ``scheduler``: a dask scheduler address (or a ``dask.distributed.Client``); else ``jobs`` local
    processes. Every grid point is checked before any run starts.
    """
    from .plugins import get_plugin_manager
    from .recipes import load_recipe

    runs = plan(grids, seeds)
    host = get_plugin_manager()
    for r in runs[:: max(1, len(seeds))]:
        load_recipe(recipe_ref, host, r.overrides)  # fail fast: every grid point must check
    out_dir = Path(out_dir)
    make_folder(out_dir)
    clean_stale_temps(out_dir)
    batch = [Job(r.key, recipe_ref, tuple(r.overrides), r.seed, str(out_dir / r.key)) for r in runs]
    results = run_jobs(batch, host, processes=jobs, scheduler=scheduler, force=force, desc="sweep",
                       progress=progress)
    write(out_dir / "summary.csv", summary_csv(runs, results))
    ensemble = ensemble_statistics(recipe_ref, host, runs, results)
    if ensemble:
        write(out_dir / "ensemble.json", json.dumps(ensemble, indent=1, sort_keys=True) + "\n")
    return results


def ensemble_statistics(recipe_ref: str, host: Any, runs: list[SweepRun], results: list[JobResult]
                        ) -> dict[str, dict[str, Any]]:
    """Statistics over each grid point's seeds (and over all runs, key "all") from every rule of the
    recipe that defines ``ensemble_statistics(reports: list[dict]) -> dict`` (a rule summarising an
    ensemble of its runs, e.g. a fractal dimension). Empty when no rule does."""
    from .recipes import load_recipe

    groups: dict[str, list[int]] = {}
    for i, r in enumerate(runs):
        groups.setdefault(r.key.rsplit("/seed-", 1)[0], []).append(i)
    if len(groups) > 1:
        groups["all"] = list(range(len(runs)))
    out: dict[str, dict[str, Any]] = {}
    for label, idx in groups.items():
        rules = [s.rule for s in load_recipe(recipe_ref, host, runs[idx[0]].overrides).steps]
        reports = [results[i].reports for i in idx if results[i].status != "failed"]
        for rule in rules:
            summarise = getattr(rule, "ensemble_statistics", None)
            if summarise is not None and reports:
                out.setdefault(label, {}).update(summarise(reports))
    return out


def summary_csv(runs: list[SweepRun], results: list[JobResult]) -> str:
    params = sorted({k for r in runs for k in r.values})
    reports = sorted({k for res in results for k, v in res.reports.items() if not isinstance(v, (dict, list))})
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["run", "seed", *params, "status", "seconds", *reports, "error"])
    for r, res in zip(runs, results):
        w.writerow([r.key, r.seed, *[r.values.get(p, "") for p in params], res.status,
                    f"{res.seconds:.3f}", *[res.reports.get(k, "") for k in reports], res.error])
    return buf.getvalue()
