"""Benchmark: batched water drops vs the one-drop-at-a-time loop of the same rule.

50,000 drops on a 512x512 three-layer surface (absorbent stone, soil patches, patina spots;
absorption, erosion, deposition, evaporation all active) for 100 steps, then the Python loop
reference (procgen_water.reference) on a subsample of drops from the same start state, in the
same process.  Prints drop-steps per second for both, their ratio, and absolute times.
Usage: python benchmarks/water.py [--steps 100] [--drops 50000] [--size 512]
                                  [--baseline /work/venv-main/bin/python]
With --baseline, the previous version of this benchmark runs after it under that interpreter
(the previous code), so the two sets of figures print side by side from one run.
"""
from __future__ import annotations

import argparse
import copy
import resource
import time

import numpy as np

from _baseline import add_arguments, run_previous
from procgen_water import particles as P
from procgen_water.layers import base_surface, layer_thickness, parse_layers
from procgen_water.reference import step_loop
from procgen_water.rules import WaterDrops


def build(size: int, n_drops: int, seed: int = 1):
    table, geos = parse_layers([
        {"preset": "stone", "thickness": 1.0, "noise": 0.1},
        {"preset": "soil", "thickness": 0.4, "noise": 0.1, "coverage": 0.5},
        {"preset": "patina", "thickness": 0.3, "n_spots": 12, "spot_radius": 0.05},
    ])
    rng = np.random.default_rng(seed)
    shape = (size, size)
    base = base_surface("fbm", shape, 1.0, rng, amplitude=20.0, tilt_deg=10.0)
    t = np.stack([layer_thickness(g, shape, rng) for g in geos], axis=-1)
    s = P.make_surface(base, t, table)
    p = WaterDrops(evaporation=0.005, adhesion=0.1)      # the rule's parameters are the model's
    d = P.emit(s, p, rng, n_drops, "uniform")
    return s, d, p


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--steps", type=int, default=100)
    ap.add_argument("--drops", type=int, default=50_000)
    ap.add_argument("--size", type=int, default=512)
    ap.add_argument("--sub", type=int, default=500, help="drops in the loop baseline")
    ap.add_argument("--sub-steps", type=int, default=3)
    add_arguments(ap)
    a = ap.parse_args()
    s, d, p = build(a.size, a.drops)
    s0, d0 = copy.deepcopy(s), copy.deepcopy(d)
    t0 = time.perf_counter()
    drop_steps = 0
    for _ in range(a.steps):
        drop_steps += len(d)
        d = P.step(s, d, p)
    t_batch = time.perf_counter() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024       # Linux: KiB
    wl = P.water_ledger(s, d)
    # loop baseline: the same start state, a subsample of the drops
    sub = d0.take(np.arange(0, len(d0), max(1, len(d0) // a.sub))[: a.sub])
    t0 = time.perf_counter()
    loop_steps = 0
    for _ in range(a.sub_steps):
        loop_steps += len(sub)
        sub = step_loop(s0, sub, p)
    t_loop = time.perf_counter() - t0
    rb, rl = drop_steps / t_batch, loop_steps / t_loop
    print(f"grid {a.size}x{a.size}, 3 layers, {a.drops} drops, {a.steps} steps")
    print(f"batch : {drop_steps} drop-steps in {t_batch:.2f} s -> {rb:,.0f} drop-steps/s "
          f"({t_batch / a.steps * 1e3:.1f} ms/step); water ledger error {wl['error']:.2e}; "
          f"peak RSS {peak / 2**20:.0f} MiB")
    print(f"loop  : {loop_steps} drop-steps in {t_loop:.2f} s -> {rl:,.0f} drop-steps/s")
    ratio = rb / rl
    print(f"ratio batch/loop: {ratio:.0f}x (target >= 20)")
    ok = ratio >= 20 and (a.steps != 100 or a.drops != 50_000 or a.size != 512 or t_batch < 10.0)
    print("targets met" if ok else "BELOW TARGET (ratio >= 20; 50k drops x 100 steps on 512^2 < 10 s)")
    run_previous("water.py", a.baseline, a.baseline_rev,
                 ["--steps", str(a.steps), "--drops", str(a.drops), "--size", str(a.size), "--sub", str(a.sub),
                  "--sub-steps", str(a.sub_steps)])
    raise SystemExit(0 if ok else 1)


if __name__ == "__main__":
    main()
