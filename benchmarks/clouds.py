"""Benchmark: the Figure 4.2(e) cloud at Poisson radius 4 on a 1200 x 1200 domain (issue 4).

Prints, per seed, the time for the tessellation (Poisson-disk + Delaunay, the core's rules),
the snake topology build, the growth, and the share of the growth spent in per-event Python
(births/merges/holes), plus steps, births, merges, holes, N_s, N_v. Baseline: the digest's
throw-away pure-Python reading needed 6-19 s for the growth alone on the same settings.

    python benchmarks/clouds.py [--seeds 1 2 3] [--radius 4]
"""
from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from procgen import get_plugin_manager, run
from procgen.recipes import load_recipe
from procgen_snaxel import snake as snake_mod
from procgen_snaxel.rules import GrowCloud
from procgen_snaxel.topology import build_topology

BASELINE_GROWTH_S = (6.0, 19.0)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    ap.add_argument("--radius", type=float, default=4.0)
    args = ap.parse_args()
    host = get_plugin_manager()
    event_time = [0.0]
    original = snake_mod.Snake.birth

    def timed_birth(self, p, carry):
        t0 = time.perf_counter()
        original(self, p, carry)
        event_time[0] += time.perf_counter() - t0

    snake_mod.Snake.birth = timed_birth
    topo_time = [0.0]
    original_build = build_topology

    def timed_build(points, faces):
        t0 = time.perf_counter()
        out = original_build(points, faces)
        topo_time[0] += time.perf_counter() - t0
        return out

    import procgen_snaxel.rules as rules_mod
    rules_mod.build_topology = timed_build
    print(f"Figure 4.2(e) recipe, 1200 x 1200, Poisson radius {args.radius:g}")
    print(f"{'seed':>4} {'tess s':>7} {'topo s':>7} {'grow s':>7} {'events s':>8} {'total s':>8} "
          f"{'steps':>6} {'births':>7} {'merges':>7} {'holes':>6} {'N_s':>6} {'N_v':>7} {'us/step':>8}")
    totals, grows = [], []
    for seed in args.seeds:
        event_time[0] = topo_time[0] = 0.0
        rec = load_recipe("clouds/fig-4-2e", host, [f"steps.0.params.radius={args.radius}",
                                                   "steps.0.params.width=1200.0", "steps.0.params.height=1200.0",
                                                   "steps.2.params.bounds=[0.0, 0.0, 1200.0, 1200.0]"])
        rec.outputs.clear()
        with tempfile.TemporaryDirectory() as tmp:
            res = run(rec, host, seed=seed, progress=False, out_dir=Path(tmp))
        secs = {s["rule"]: s["seconds"] for s in res.run_info["steps"]}
        rep = res.state.reports
        tess = secs["points.poisson_disk"] + secs["mesh.delaunay"]
        grow_s = secs[GrowCloud.name] - topo_time[0]       # the rule's setup builds the topology
        total = tess + topo_time[0] + grow_s
        totals.append(total)
        grows.append(grow_s)
        steps = rep["cloud.steps"]
        print(f"{seed:>4} {tess:7.2f} {topo_time[0]:7.2f} {grow_s:7.2f} {event_time[0]:8.2f} {total:8.2f} "
              f"{steps:>6} {rep['cloud.births']:>7} {rep['cloud.merges']:>7} {rep['cloud.holes']:>6} "
              f"{rep['N_s']:>6} {rep['N_v']:>7} {1e6 * grow_s / steps:8.0f}")
    mean, g = float(np.mean(totals)), float(np.mean(grows))
    print(f"mean whole cloud {mean:.2f} s (target < 3 s); growth {g:.2f} s, "
          f"{BASELINE_GROWTH_S[0] / g:.1f}x-{BASELINE_GROWTH_S[1] / g:.1f}x faster than the pure-Python "
          f"reading ({BASELINE_GROWTH_S[0]:g}-{BASELINE_GROWTH_S[1]:g} s)")


if __name__ == "__main__":
    main()
