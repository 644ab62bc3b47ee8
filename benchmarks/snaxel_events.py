"""Benchmark: snaxel topology events (find the arriving snaxel, birth / merge) on the numpy path
vs the compiled path (procgen_snaxel.events_numba) vs a trivial kernel (issue 16).

One cloud (thesis table 4.5 scaled to the domain, like tests/test_snaxel_engine.py) grows on a
Poisson-disk tessellation; the CPU time of the event handling is summed over the run and divided
by the number of births: on the numpy path every call of ``Snake.find`` and ``Snake.birth`` (the
loop around them is not counted, which favours numpy), on the compiled path every call of
``events_numba.step_events`` (all the arrivals of a step, the numpy births it hands back
included).  Each path runs in its own process (own peak RSS), the paths alternate twice and each
keeps its fastest run.  The limit replays the same births in one compiled call doing an event's
unavoidable memory traffic: one scan of the chain's destination column and one copy of the
chain (80 bytes per snaxel) into a buffer.  Both paths' final chains are hashed (they must agree
bit for bit).

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
    """Wraps the event handling (Snake.find / Snake.birth, events_numba.step_events): CPU time
    inside it, and the chain length at every birth."""

    def __init__(self, snake_cls, compiled) -> None:
        self.seconds = 0.0
        self.lengths: list[int] = []
        self.depth = 0
        timer = self

        def wrap(cls, name):
            inner = getattr(cls, name)

            def timed(*args):
                timer.depth += 1
                t0 = time.process_time()
                try:
                    return inner(*args)
                finally:
                    timer.depth -= 1
                    if not timer.depth:            # numpy births inside step_events count once
                        timer.seconds += time.process_time() - t0
            setattr(cls, name, timed)
        wrap(snake_cls, "find")
        wrap(snake_cls, "birth")
        if compiled is not None:
            wrap(compiled, "step_events")


def _lengths(snake_cls) -> list[int]:
    """Records the chain length at every birth (the limit replays them)."""
    lengths: list[int] = []

    def count(self):
        return self.__dict__.get("_births", 0)

    def set_births(self, value):
        if value > self.__dict__.get("_births", 0):
            lengths.append(len(self.ints))
        self.__dict__["_births"] = value
    snake_cls.births = property(count, set_births)
    return lengths


def path_child(a) -> None:
    fig: dict = {}
    accelerate = a.path == "compiled"          # (the limit records every birth on the numpy path)
    compiled = None
    if accelerate:                               # numba import + kernel load (or compile)
        from procgen_snaxel import events_numba as compiled
        t0 = time.perf_counter()
        w = build(100.0, 30)
        w.snake.accelerate = True
        while w.step():
            pass
        fig["warmup_s"] = round(time.perf_counter() - t0, 2)
    lengths = _lengths(Snake) if a.path == "limit" else []
    g = build(a.size, a.steps)
    g.snake.accelerate = accelerate
    timer = Timer(Snake, compiled)
    t0 = time.process_time()
    while g.step():
        pass
    grow_s = time.process_time() - t0
    s = g.snake
    if a.path == "limit":
        from numba import njit

        @njit(cache=True, nogil=True)
        def events(lengths, ints, flts, out_i, out_f):
            hits = 0
            for n in lengths:
                for i in range(n):                  # one scan of the destination column
                    if ints[i, V] == -1:
                        hits += 1
                out_i[:n] = ints[:n]                # one copy of the chain
                out_f[:n] = flts[:n]
            return hits

        big = max(lengths)
        ints, flts = np.zeros((big, 3), np.int64), np.zeros((big, 7))
        oi, of = np.empty_like(ints), np.empty_like(flts)
        n_arr = np.asarray(lengths, np.int64)
        events(n_arr[:10], ints, flts, oi, of)
        t0 = time.process_time()
        events(n_arr, ints, flts, oi, of)
        t = time.process_time() - t0
        _paths.report(seconds=t / len(lengths), births=len(lengths), mean_chain=round(float(np.mean(lengths))),
                      bytes_per_snaxel=int(ints.itemsize * 3 + flts.itemsize * 7))
        return
    digest = hashlib.sha256(s.ints.tobytes() + s.flts.tobytes() + s.state.tobytes()).hexdigest()[:16]
    fig.update(hash=digest, births=s.births, merges=s.merges, holes=s.holes, N_s=len(s.ints),
               events_s=round(timer.seconds, 3), growth_s=round(grow_s, 2),
               events_share=round(timer.seconds / grow_s, 3))
    _paths.report(seconds=timer.seconds / max(s.births, 1), **fig)


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
