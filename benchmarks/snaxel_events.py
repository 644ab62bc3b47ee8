"""Benchmark: snaxel topology events (find the arriving snaxel, birth / merge) on the numpy path
vs the compiled path (procgen_snaxel.events_numba) vs a trivial kernel (issue 16).

One cloud (thesis table 4.5 scaled to the domain, like tests/test_snaxel_engine.py) grows on a
Poisson-disk tessellation; every call of ``Snake.find`` and ``Snake.birth`` is timed (CPU time)
and the total is divided by the number of births.  Each path runs in its own process (own peak
RSS), the paths alternate twice and each keeps its fastest run.  The limit replays the same
events with a trivial compiled kernel doing an event's unavoidable memory traffic: one scan of
the chain's destination column and one copy of the chain (80 bytes per snaxel) into a new one.
Both paths' final chains are hashed (they must agree bit for bit).

    python benchmarks/snaxel_events.py [--size 400] [--steps 1500]
"""
from __future__ import annotations

import argparse
import hashlib
import time

import numpy as np

import _paths
from procgen_snaxel.growth import CloudGrowth
from procgen_snaxel.params import GrowthParams
from procgen_snaxel.snake import V, Snake
from procgen_snaxel.tables import THESIS_TABLES
from procgen_snaxel.tessellate import poisson_tessellation


def build(size: float, steps: int) -> CloudGrowth:
    scale = size / 1200.0                        # the thesis's 1200 px domain scaled to ``size``
    table = [[x * scale for x in row[:-1]] + [row[-1] * scale] for row in THESIS_TABLES["4.5"]]
    cfg = GrowthParams(table=table, t_min=0.0, t_max=150 * scale, g_min=240 * scale, g_max=250 * scale,
                       c_min=6 * scale, margin=4.0, n_c=4, max_steps=steps)
    topo = poisson_tessellation(size, size, 1.6, np.random.default_rng(5))
    return CloudGrowth(topo, cfg, np.random.default_rng(1))


class Timer:
    """Wraps Snake.find / Snake.birth: CPU time inside them, and the chain length per birth."""

    def __init__(self) -> None:
        self.seconds = 0.0
        self.births = 0
        self.lengths: list[int] = []
        self.find, self.birth = Snake.find, Snake.birth
        timer = self

        def find(snake, u, v):
            t0 = time.process_time()
            try:
                return timer.find(snake, u, v)
            finally:
                timer.seconds += time.process_time() - t0

        def birth(snake, p, carry):
            timer.lengths.append(len(snake.ints))
            t0 = time.process_time()
            try:
                return timer.birth(snake, p, carry)
            finally:
                timer.seconds += time.process_time() - t0
                timer.births += 1

        Snake.find, Snake.birth = find, birth


def path_child(a) -> None:
    fig: dict = {}
    accelerate = a.path != "numpy"
    if accelerate:                               # numba import + kernel load (or compile)
        t0 = time.perf_counter()
        w = build(100.0, 30)
        w.snake.accelerate = True
        while w.step():
            pass
        fig["warmup_s"] = round(time.perf_counter() - t0, 2)
    g = build(a.size, a.steps)
    g.snake.accelerate = accelerate
    timer = Timer()
    t0 = time.process_time()
    while g.step():
        pass
    grow_s = time.process_time() - t0
    s = g.snake
    if a.path == "limit":
        from numba import njit

        @njit(cache=True, nogil=True)
        def event(ints, flts, w):
            hit = -1
            for i in range(ints.shape[0]):           # one scan of the destination column
                if ints[i, V] == w:
                    hit = i
            return ints.copy(), flts.copy(), hit     # one copy of the chain

        lengths = timer.lengths
        big = max(lengths)
        ints, flts = np.zeros((big, 3), np.int64), np.zeros((big, 7))
        event(ints[:10], flts[:10], -1)
        t0 = time.process_time()
        for n in lengths:
            event(ints[:n], flts[:n], -1)
        t = time.process_time() - t0
        _paths.report(seconds=t / len(lengths), births=len(lengths), mean_chain=round(float(np.mean(lengths))),
                      bytes_per_snaxel=int(ints.itemsize * 3 + flts.itemsize * 7))
        return
    digest = hashlib.sha256(s.ints.tobytes() + s.flts.tobytes() + s.state.tobytes()).hexdigest()[:16]
    fig.update(hash=digest, births=timer.births, merges=s.merges, holes=s.holes, N_s=len(s.ints),
               events_s=round(timer.seconds, 3), growth_s=round(grow_s, 2),
               events_share=round(timer.seconds / grow_s, 3))
    _paths.report(seconds=timer.seconds / max(timer.births, 1), **fig)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--size", type=float, default=400.0)
    ap.add_argument("--steps", type=int, default=1500)
    _paths.add_arguments(ap)
    a = ap.parse_args()
    if a.path:
        return path_child(a)
    _paths.compare([("events", f"snaxel events, cloud on {a.size:g}^2 tessellation, {a.steps} steps (per birth)")],
                   ["--size", str(a.size), "--steps", str(a.steps)])


if __name__ == "__main__":
    main()
