"""Benchmark: batched water drops vs the one-drop-at-a-time loop of the same rule, and the
numpy step vs the compiled (numba) step vs a trivial kernel with the same memory traffic.

50,000 drops on a 512x512 three-layer surface (absorbent stone, soil patches, patina spots;
absorption, erosion, deposition, evaporation all active) for 100 steps, then the Python loop
reference (procgen_water.reference) on a subsample of drops from the same start state, in the
same process.  Prints drop-steps per second for both, their ratio, and absolute times.

``--paths`` instead runs the same 100 steps once per path, each in its own process (own peak
RSS), one after the other: the numpy step (``accelerate=False``), the compiled step
(procgen_water.kernels; numba import and kernel load/compile are timed apart, on a warm-up step)
and the machine's limit: a trivial compiled kernel doing the least memory traffic a step needs,
in the order that costs least (the compiled path's own order): each cell holding water at the
step's start (as an untimed compiled run of the workload found them) has its held water read and
written back and its height read (evaporation's least traffic: a continued step needs no other
pass over the grid); the drops counting-sorted by cell (int32 slots); per drop, in cell order,
its state read and written back, the 4x4 cells of its gradient stencil and its cell's layers
read and written back; no arithmetic to speak of.  Two rows: ``drops`` on one thread, timed in
CPU time (``time.process_time``: the machine is shared by several jobs on 2 cores, and CPU time
survives load better than wall time), and ``drops-2t``, the compiled
path and the limit kernel on numba's 2 threads (the same loops split over cells / drops),
timed in wall time (``time.perf_counter``) beside the single-threaded numpy path's wall time;
a loaded machine makes wall times, and most of all 2-thread ones, long.  Each path runs twice,
alternating, and keeps its faster child.  The table gives time per drop-step, the ratio, and
the compiled path's distance from the limit; both paths' final thickness/held/drops are hashed
to show they agree bit for bit (and with 2 threads as with one).  A third row, ``rule-2t``, runs
the water.drops rule through procgen's runner (same sizes, a surface of its own draw): what a
user's recipe spends per drop-step, the rule's own work and its one publish at the end included.
Usage: python benchmarks/water.py [--steps 100] [--drops 50000] [--size 512] [--paths]
                                  [--baseline /work/venv-main/bin/python]
With --baseline, the previous version of this benchmark runs after it under that interpreter
(the previous code), so the two sets of figures print side by side from one run.
The steps after the first are ``continued``, as the water.drops rule makes them (nothing else
writes the surface between its iterations): the compiled path then refreshes the height only
at the last step's drop cells; the numpy path (the reference) recomputes it.
"""
from __future__ import annotations

import argparse
import copy
import hashlib
import resource
import time

import numpy as np

import _paths
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
    ap.add_argument("--paths", action="store_true", help="numpy vs compiled vs limit (see above)")
    add_arguments(ap)
    _paths.add_arguments(ap)
    a = ap.parse_args()
    if a.path:
        return path_child(a)
    if a.paths:
        text = f"drops {a.drops:,} on {a.size}^2 x 3 layers, {a.steps} steps (per drop-step)"
        _paths.compare([("drops", text + ", 1 thread, CPU"), ("drops-2t", text + ", 2 threads, wall"),
                        ("rule-2t", "the water.drops rule in a recipe, the same sizes, 2 threads, wall")],
                       ["--steps", str(a.steps), "--drops", str(a.drops), "--size", str(a.size)])
        return
    s, d, p = build(a.size, a.drops)
    s0, d0 = copy.deepcopy(s), copy.deepcopy(d)
    t0 = time.process_time()
    drop_steps = 0
    for _ in range(a.steps):
        drop_steps += len(d)
        d = P.step(s, d, p)
    t_batch = time.process_time() - t0
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024       # Linux: KiB
    wl = P.water_ledger(s, d)
    # loop baseline: the same start state, a subsample of the drops
    sub = d0.take(np.arange(0, len(d0), max(1, len(d0) // a.sub))[: a.sub])
    t0 = time.process_time()
    loop_steps = 0
    for _ in range(a.sub_steps):
        loop_steps += len(sub)
        sub = step_loop(s0, sub, p)
    t_loop = time.process_time() - t0
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


def path_child(a) -> None:
    """One path of ``--paths`` in this process: time per drop-step and figures, as JSON."""
    threads = 2 if a.part.endswith("-2t") else 1
    clock = time.perf_counter if threads > 1 else time.process_time
    if a.path != "numpy":                 # (the numpy child never imports numba: its RSS)
        from procgen.accel import wait_policy
        wait_policy()                     # (as the kernel modules' loading does)
        import numba
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    s, d, p = build(a.size, a.drops)
    n0, fig = len(d), {"threads": 1 if a.path == "numpy" else threads}
    if a.part == "rule-2t" and a.path != "limit":
        return rule_child(a, fig)
    if a.path == "limit":
        from procgen_water.kernels import bytes_per_cell
        wet = _wet_cells(s, d, p, a.steps)
        run = _limit_kernel()
        h = s.height()
        counts, order = np.empty(s.ncell + 1, np.int32), np.empty(n0, np.int32)
        args = (s.thickness, s.held, h, d.pos, s.shape[0], s.shape[1], counts, order)
        run(*args, wet[0])                                                          # compile
        t0 = clock()
        for cells in wet:
            run(*args, cells)
        t = clock() - t0
        fig["wet_cells_per_step"] = round(sum(c.size for c in wet) / len(wet))
        _paths.report(seconds=t / (a.steps * n0), bytes_per_cell_scratch=bytes_per_cell(s.n_layers, p.footprint), **fig)
        return
    accelerate = a.path == "compiled"
    if accelerate:
        ws, wd, wp = build(32, 100, seed=2)
        t0 = time.process_time()
        P.step(ws, wd, wp, accelerate=True)               # numba import + kernel load (or compile)
        fig["warmup_s"] = round(time.process_time() - t0, 2)
    t0 = clock()
    drop_steps = 0
    for it in range(a.steps):
        drop_steps += len(d)
        d = P.step(s, d, p, accelerate=accelerate, continued=it > 0)     # as water.drops does
    t = clock() - t0
    digest = hashlib.sha256()
    for arr in (s.thickness, s.held, s.deposit, s.evaporated, d.pos, d.volume, d.sediment):
        digest.update(np.ascontiguousarray(arr).tobytes())
    fig.update(hash=digest.hexdigest()[:16], drop_steps=drop_steps, ms_per_step=round(t / a.steps * 1e3, 1),
               water_ledger_error=float(f"{P.water_ledger(s, d)['error']:.2e}"),
               bytes_per_drop=sum(x.itemsize * (x.size // max(len(d), 1)) for x in
                                  (d.pos, d.vel, d.volume, d.sediment, d.kind, d.moving, d.age)))
    if accelerate:
        work = s.__dict__["_drop_kernel_work"]
        fig["scratch_bytes_per_drop"] = work.bytes_per_drop
        fig["scratch_bytes_per_cell"] = round(work.grid_bytes / s.ncell)
    _paths.report(seconds=t / drop_steps, **fig)


def rule_child(a, fig: dict) -> None:
    """The ``rule-2t`` row: water.drops run by procgen's runner on a surface like ``build``'s
    (its own fBm draw), so the time includes what the rule does around the step (emission,
    the check of water left, the one publish at the end: ledgers, derived fields, drops domain)."""
    import os
    from procgen import run
    from procgen.plugins import get_plugin_manager
    from procgen.recipes import check_recipe
    from procgen_water.rules import WaterDrops
    accelerate = a.path == "compiled"
    os.environ["PROCGEN_ACCELERATE"] = "1" if accelerate else "0"
    if accelerate:
        ws, wd, wp = build(32, 100, seed=2)
        P.step(ws, wd, wp, accelerate=True)              # numba import + kernel load, untimed
    layers = [{"preset": "stone", "thickness": 1.0, "noise": 0.1},
              {"preset": "soil", "thickness": 0.4, "noise": 0.1, "coverage": 0.5},
              {"preset": "patina", "thickness": 0.3, "n_spots": 12, "spot_radius": 0.05}]
    host = get_plugin_manager()
    recipe = check_recipe({"steps": [
        {"rule": "water.surface", "params": {"nx": a.size, "ny": a.size, "base": "fbm", "base_amplitude": 20.0,
                                             "tilt_deg": 10.0, "layers": layers}},
        {"rule": "water.drops", "iterations": a.steps,
         "params": {"drops": a.drops, "evaporation": 0.005, "adhesion": 0.1}}]}, host)
    step, drop_steps, finish_s = P.step, [0], [0.0]
    finish = WaterDrops.finish

    def counted(s_, d_, *args, **kw):
        drop_steps[0] += len(d_)
        return step(s_, d_, *args, **kw)

    def timed_finish(rule, state):
        t0 = time.perf_counter()
        finish(rule, state)
        finish_s[0] += time.perf_counter() - t0

    P.step, WaterDrops.finish = counted, timed_finish
    res = run(recipe, host, seed=1, progress=False)
    t = sum(r.seconds for r in res.state.records if r.rule == "water.drops") + finish_s[0]
    g = res.state.get("terrain")
    digest = hashlib.sha256()
    for name in ("layers__thickness", "water__held", "sediment__deposit"):
        digest.update(np.ascontiguousarray(g[name]).tobytes())
    fig.update(hash=digest.hexdigest()[:16], drop_steps=drop_steps[0], ms_per_step=round(t / a.steps * 1e3, 1),
               publish_ms=round(finish_s[0] * 1e3, 1))
    _paths.report(seconds=t / drop_steps[0], **fig)


def _wet_cells(s, d, p, steps: int) -> list[np.ndarray]:
    """Per step of the workload, the cells holding water at its start (an untimed run of the
    compiled step on copies): the cells the limit kernel must visit."""
    s, d = copy.deepcopy(s), copy.deepcopy(d)
    wet = []
    for it in range(steps):
        wet.append(np.flatnonzero(s.held.any(axis=1)).astype(np.int32))
        d = P.step(s, d, p, accelerate=True, continued=it > 0)
    return wet


def _limit_kernel():
    """The trivial kernel of ``--paths``: the step's least memory traffic, next to no arithmetic;
    the cell pass and the drop pass split over numba's threads as the compiled step's are."""
    from numba import njit, prange

    @njit(cache=True, nogil=True, parallel=True)
    def run(thickness, held, h, pos, ny, nx, counts, order, wet):
        L = thickness.shape[1]
        n = pos.shape[0]
        for k in prange(wet.size):               # the wet cells: held water and height in and
            c = wet[k]                           # held water out
            v = 0.0 * h[c]
            for l in range(L):
                held[c, l] += v
        counts[:] = 0                            # the drops by cell: a counting sort
        for i in range(n):
            counts[int(pos[i, 1]) * nx + int(pos[i, 0]) + 1] += 1
        for c in range(ny * nx):
            counts[c + 1] += counts[c]
        for i in range(n):
            c = int(pos[i, 1]) * nx + int(pos[i, 0])
            order[counts[c]] = i
            counts[c] += 1
        for o in prange(n):                      # per drop, in cell order: state + 4x4 cells
            i = order[o]
            ix = min(max(int(pos[i, 0]) - 1, 0), nx - 4)
            iy = min(max(int(pos[i, 1]) - 1, 0), ny - 4)
            v = 0.0
            for dy in range(4):
                for dx in range(4):
                    v += h[(iy + dy) * nx + ix + dx]
            c = (iy + 1) * nx + ix + 1
            for l in range(L):                   # the cell's layers: read and written back
                thickness[c, l] += 0.0 * v
                held[c, l] += 0.0 * v
            pos[i, 0] += 1e-300 * v
        return None

    return run


if __name__ == "__main__":
    main()
