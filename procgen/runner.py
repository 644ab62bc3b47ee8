"""Running a checked recipe: iteration, progress bar, frames, outputs and run.json."""
from __future__ import annotations

import hashlib
import json
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable

import numpy as np

from .errors import InputError, PluginError, ProcgenError
from .exchange.write import write_folder
from .recipes import OutputSpec, Recipe
from .state import State, StepRecord

if TYPE_CHECKING:
    from .plugins import PluginHost

StepCallback = Callable[[State, StepRecord], None]


@dataclass
class RunResult:
    """The state a run built and the files it wrote (relative to the output folder)."""

    state: State
    files: list[str] = field(default_factory=list)
    run_info: dict[str, Any] = field(default_factory=dict)


def recipe_hash(recipe: Recipe) -> str:
    blob = json.dumps(recipe.data, sort_keys=True, default=str).encode()
    return hashlib.sha256(blob).hexdigest()[:16]


def provenance(recipe: Recipe, seed: int, host: "PluginHost") -> dict[str, Any]:
    """What made an output: recipe name and hash, seed and versions (no time, no paths)."""
    return {"recipe": recipe.name, "recipe_sha256": recipe_hash(recipe), "seed": int(seed),
            "versions": host.versions()}


def render_output(state: State, spec: OutputSpec, host: "PluginHost",
                  prov: dict[str, Any]) -> dict[str, bytes]:
    """Run one exporter; return {path relative to the output folder: bytes}. Writes nothing."""
    exporter = host.exporter(spec.format)
    domain = state.get(spec.domain)
    if not exporter.accepts(type(domain)):
        raise InputError(f"output {spec.file!r}: format {spec.format!r} cannot write a {domain.kind}")
    stem = Path(spec.file).with_suffix("").name
    try:
        blob = exporter.func(domain, stem=stem, provenance=prov, **spec.options)
    except ProcgenError:
        raise
    except (ValueError, TypeError, KeyError, IndexError) as exc:
        # the exporter's own words, never its exception class (one line for a user, not a trace)
        raise InputError(f"output {spec.file!r} ({spec.format}): cannot write this {domain.kind}: "
                         f"{str(exc).splitlines()[0] if str(exc) else 'its data does not fit the format'}") from None
    rel_dir = Path(spec.file).parent
    files = {Path(spec.file).name: blob} if isinstance(blob, (bytes, str)) else dict(blob)
    return {(rel_dir / Path(name).name).as_posix(): (data.encode() if isinstance(data, str) else bytes(data))
            for name, data in files.items()}


def _progress(total: int | None, desc: str, enabled: bool) -> Any:
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, disable=not enabled, leave=False, dynamic_ncols=True,
                unit="step", file=sys.stderr)


def run(recipe: Recipe, host: "PluginHost", *, seed: int | None = None, out_dir: Path | None = None,
        progress: bool | None = None, on_step: StepCallback | None = None,
        save_state: bool = False) -> RunResult:
    """Run every step of a checked recipe, then write its outputs and run.json into ``out_dir``.

    Nothing is written when a step or an exporter fails, nor when the disk refuses one of the
    files (WriteError names it; the folder keeps what it had); without ``out_dir`` nothing is
    exported at all (frames included). See :func:`render` for the rest.
    """
    result, files = render(recipe, host, seed=seed, progress=progress, on_step=on_step,
                           save_state=save_state, export=out_dir is not None)
    if out_dir is not None:
        write_folder(out_dir, files)     # all or nothing; run.json, last in ``files``, lands last
    return result


def render(recipe: Recipe, host: "PluginHost", *, seed: int | None = None, progress: bool | None = None,
           on_step: StepCallback | None = None, save_state: bool = False,
           export: bool = True) -> tuple[RunResult, dict[str, bytes]]:
    """Run every step of a checked recipe and render every file of the run in memory (frames,
    outputs, run.json last): ``(result, {path relative to the run folder: bytes})``. Writes
    nothing, so a batch worker needs no disk; without ``export`` no exporter runs at all.
    ``progress=None`` shows bars only on a terminal.

    A step's iterations run back to back: between two of them only its own rule writes the
    state (frames are exported after its ``publish``), so a rule may keep caches across its
    iterations.  ``on_step`` is called after every iteration to observe; it must not write.
    """
    seed = recipe.seed if seed is None else int(seed)
    show = sys.stderr.isatty() if progress is None else progress
    state = State(seed=seed, base_dir=recipe.base_dir)
    prov = provenance(recipe, seed, host)
    result = RunResult(state)
    step_info: list[dict[str, Any]] = []
    pending: dict[str, bytes] = {}   # every file of the run, written only once all succeeded
    for step in recipe.steps:
        rule = step.rule
        state.step_index, state.rule_name, state.iteration = step.index, rule.name, -1
        t_start = time.perf_counter()
        try:
            rule.setup(state)
            changed_count = 0
            done_iterations = 0
            stopped = "iterations"
            bar_total = None if step.until_stable else step.iterations
            with _progress(bar_total, f"[{step.index}] {rule.name}", show and step.iterations > 1) as bar:
                for it in range(step.iterations):
                    state.iteration = it
                    t0 = time.perf_counter()
                    changed = rule.step(state)
                    if not isinstance(changed, (bool, np.bool_)):
                        raise PluginError(f"{step.where}: step() must return a bool, got {type(changed).__name__}")
                    changed = bool(changed)
                    done_iterations = it + 1
                    rec = StepRecord(step.index, rule.name, it, changed, time.perf_counter() - t0)
                    state.records.append(rec)
                    changed_count += changed
                    if on_step is not None:
                        on_step(state, rec)
                    bar.update(1)
                    if export and step.frames is not None and (it + 1) % step.frames.every == 0:
                        rule.publish(state)
                        spec = OutputSpec(step.frames.domain, step.frames.format,
                                          _frame_name(step, it + 1, host), step.frames.options)
                        pending.update(render_output(state, spec, host, prov))
                    if step.until_stable and not changed:
                        stopped = "stable"
                        break
                else:
                    if step.until_stable:
                        stopped = "max_iterations"
            state.iteration = step.iterations
            rule.finish(state)
        except ProcgenError as exc:
            raise type(exc)(f"{step.where}: {exc}") if not str(exc).startswith(step.where) else exc
        step_info.append({"index": step.index, "rule": rule.name, "label": step.label,
                          "params": rule.param_values(), "iterations": done_iterations,
                          "changed_iterations": changed_count, "stopped": stopped,
                          "seconds": round(time.perf_counter() - t_start, 4)})
    if not export:
        return result, {}
    for spec in recipe.outputs:
        pending.update(render_output(state, spec, host, prov))
    if save_state:
        pending["state.npz"] = state.to_npz_bytes()
    info = {"recipe": recipe.name, "source": Path(recipe.source).name, "seed": seed,
            "meta": recipe.meta, "resolved_recipe": recipe.data, "provenance": prov,
            "steps": step_info, "reports": state.reports, "files": sorted([*pending, "run.json"])}
    pending["run.json"] = (json.dumps(info, indent=2, sort_keys=True, default=_json_default) + "\n").encode()
    result.files = sorted(pending)
    result.run_info = info
    return result, pending


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return str(value)


def _frame_name(step: Any, iteration: int, host: "PluginHost") -> str:
    suffix = host.exporter(step.frames.format).suffix
    return f"frames/step{step.index}/frame_{iteration:04d}{suffix}"
