"""Crack propagation speed: the plate-5.10 recipe (mud on a tetrahedron) at ~330,000 cells.

The thesis (5.2.6, plate 5.10): ~330 k cells, 85 % unstable at the start, 99 % stable after
20 minutes on an SGI Indigo2 (R10000, 195 MHz).  Target here: the crack part under 60 s.

Prints, for the full size and for a baseline run of an eighth of the cells in the same process
(fresh state, same recipe): wall and CPU seconds per step of the recipe (CPU time is the
figure to trust on a shared, loaded machine) (cells, stack, stress + relaxation,
propagation), CM steps, cracks, the unstable fraction at the end, the time per cell ratio
(full / baseline: near 1 means the cost grows linearly with the cells) and the ratio against
the thesis's 20 minutes; cracks.render's CPU time per covered micro-cell (full / baseline:
near 1 means its cost follows the covered micro-cells), and its micro-cell scan timed again on
the final cracks on the numpy path and on the compiled one (same bytes, checked); then the
peak RSS of the process.

    python benchmarks/cracks.py             # ~330,000 cells, plus the 1/8 baseline
    python benchmarks/cracks.py --quick     # ~40,000 cells, plus the 1/8 baseline
"""
from __future__ import annotations

import argparse
import resource
import time

from procgen.plugins import get_plugin_manager
from procgen.recipes import load_recipe
from procgen.runner import run
from procgen_cracks.render import micro_coverage
from procgen_cracks.render_rules import crack_segments, stack_layer

THESIS_SECONDS = 20 * 60


def run_plate(host, cells: int) -> dict:
    recipe = load_recipe("meshes/plate-5-10", host, [f"steps.cells.params.target_cells={cells}"])
    per_rule: dict[str, float] = {}
    cpu: dict[str, float] = {}
    last = [time.process_time()]

    def on_step(state, rec) -> None:          # CPU seconds since the last record (incl. setup)
        now = time.process_time()
        cpu[rec.rule] = cpu.get(rec.rule, 0.0) + now - last[0]
        last[0] = now

    t0 = time.perf_counter()
    res = run(recipe, host, seed=1, progress=False, on_step=on_step)
    total = time.perf_counter() - t0
    for rec in res.state.records:
        per_rule[rec.rule] = per_rule.get(rec.rule, 0.0) + rec.seconds
    rep = res.state.reports
    scan = scan_both(res.state, recipe)
    return {"scan": scan, "cells": rep["cells.n_cells"], "total": total, "per_rule": per_rule, "cpu": cpu,
            "steps": rep["cracks.steps"], "cracks": rep["cracks.cracks"], "modules": rep["cracks.modules"],
            "unstable_start": rep["cracks.unstable_start_fraction"],
            "unstable": rep["cracks.unstable_fraction"],
            "covered": rep["cells.cracks.covered_micro_cells"]}


def scan_both(state, recipe) -> dict:
    """CPU seconds of cracks.render's micro-cell scan on the run's final cracks, numpy path and
    compiled path (procgen_cracks.render_kernels; the first call compiles or loads the cache,
    so the compiled figure is the second of two calls), and whether the bytes agree."""
    step = next(s for s in recipe.steps if s.rule.name == "cracks.render").rule
    cells = state.get(step.cells)
    seg = crack_segments(cells, state.get(step.paths), stack_layer(cells, step.layer))
    out, sec = {}, {}
    for label, acc in (("numpy", False), ("compiled", True), ("compiled", True)):
        t0 = time.process_time()
        out[label] = micro_coverage(cells, seg, step.k, profile=step.profile,
                                    saturation=step.saturation, accelerate=acc)
        sec[label] = time.process_time() - t0
    sec["same"] = out["numpy"].tobytes() == out["compiled"].tobytes()
    return sec


def show(label: str, r: dict) -> None:
    print(f"{label}: {r['cells']:,} cells, {r['total']:.1f} s in all")
    for rule, sec in r["per_rule"].items():
        print(f"  {rule:18s} {sec:7.2f} s wall  {r['cpu'].get(rule, 0.0):7.2f} s CPU")
    print(f"  {r['cracks']:,} cracks, {r['modules']:,} crack modules, {r['steps']:,} CM steps; "
          f"unstable {100 * r['unstable_start']:.1f} % -> {100 * r['unstable']:.2f} %")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="~40,000 cells instead of ~330,000")
    ap.add_argument("--cells", type=int, default=0, help="target cell count (overrides --quick)")
    args = ap.parse_args()
    cells = args.cells or (40_000 if args.quick else 330_000)
    host = get_plugin_manager()
    base = run_plate(host, cells // 8)
    show("baseline (1/8 of the cells)", base)
    full = run_plate(host, cells)
    show("plate 5.10", full)
    for kind in ("per_rule", "cpu"):
        crack = full[kind].get("cracks.propagate", 0.0) + full[kind].get("cracks.stress", 0.0)
        crack_b = base[kind].get("cracks.propagate", 0.0) + base[kind].get("cracks.stress", 0.0)
        ratio = (crack / full["cells"]) / max(crack_b / base["cells"], 1e-12)
        what = "wall" if kind == "per_rule" else "CPU"
        print(f"stress + propagation ({what}): {crack:.1f} s (target < 60 s); time per cell vs "
              f"baseline x{ratio:.2f}; thesis 20 min / ours = x{THESIS_SECONDS / max(crack, 1e-9):.0f}")
    # cracks.render's work follows the micro-cells the cracks cover (widths are absolute, so
    # they grow faster than the cells): its time per covered micro-cell should stay flat
    per = {label: r["cpu"].get("cracks.render", 0.0) / max(r["covered"], 1) for label, r in
           (("baseline", base), ("full", full))}
    for label, r in (("baseline", base), ("full", full)):
        sc = r["scan"]
        print(f"cracks.render scan, {label} ({r['covered']:,} covered micro-cells): numpy "
              f"{sc['numpy']:.2f} s CPU ({1e6 * sc['numpy'] / max(r['covered'], 1):.2f} us per "
              f"micro-cell), compiled {sc['compiled']:.2f} s ({1e6 * sc['compiled'] / max(r['covered'], 1):.2f}"
              f" us), x{sc['numpy'] / max(sc['compiled'], 1e-9):.1f}; same bytes: {sc['same']}")
    for path in ("numpy", "compiled"):
        per_b = base["scan"][path] / max(base["covered"], 1)
        per_f = full["scan"][path] / max(full["covered"], 1)
        print(f"  {path} scan: time per covered micro-cell, full / baseline x{per_f / max(per_b, 1e-12):.2f}")
    print(f"cracks.render: {full['covered']:,} covered micro-cells ({base['covered']:,} at the "
          f"baseline, x{full['covered'] / max(base['covered'], 1):.1f} for x"
          f"{full['cells'] / base['cells']:.1f} cells); {1e6 * per['full']:.2f} us CPU per covered "
          f"micro-cell, x{per['full'] / max(per['baseline'], 1e-12):.2f} the baseline's")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak memory {peak:.0f} MB")


if __name__ == "__main__":
    main()
