"""Benchmark: cellular networks of 100k and 1M cells (seed 002, issue 12).

For each size: seeding a triangle network on a plane, building the sparse box index and the
links (27-box search) against scipy's cKDTree in the same process (ratio printed), then the
per-step cost of colour spreading, the generic Voronoi propagation (frontier only), Life
(B3/S23, outer-totalistic) and melting, as cell updates per second.  Peak memory (ru_maxrss)
is printed at the end.  The paper's bar: 100,000 cells at >= 12 steps/s (about 1.2 million
cell updates per second, rendering included, on a 2004 PC); target here >= 20 million cell
updates per second for the totalistic rules and a 1 M-cell network built in under 10 s.

    python benchmarks/cellnet.py [--sizes 100000 1000000] [--steps 20]
"""
from __future__ import annotations

import argparse
import math
import resource
import time

import numpy as np

from procgen.ca.cells import cell_graph
from procgen.ca.lifelike import life_step, parse_rule
from procgen.ca.propagation import VoronoiGrowth
from procgen_cellnet.boxes import BoxIndex, pairs_kdtree, pairs_within
from procgen_cellnet.colour import spread
from procgen_cellnet.melting import melt_step
from procgen_cellnet.network import CellNetwork
from procgen_cellnet.seeding import DENSITY, link_radius, seed_cells
from procgen_cellnet.states import ACTIVE, receives, sends


def timed(fn, *args):
    t0 = time.perf_counter()
    out = fn(*args)
    return out, time.perf_counter() - t0


def bench(n_target: int, steps: int) -> None:
    side = math.sqrt(n_target / DENSITY["triangle"])
    v = np.array([[0, 0, 0], [side, 0, 0], [side, side, 0], [0, side, 0]], float)
    f = np.array([[0, 1, 2], [0, 2, 3]])
    s, t_seed = timed(seed_cells, v, f, "triangle", 1.0)
    p = s.positions
    r = link_radius("triangle", 1.0, 0.01)
    idx, t_index = timed(BoxIndex.build, p, 2.0)
    links, t_link = timed(pairs_within, p, r, idx)
    kd, t_kd = timed(pairs_kdtree, p, r)
    assert np.array_equal(links, kd)
    net = CellNetwork(p, links, cs=1.0, grid="triangle", radius=r)
    net.add_field("cell__normal", s.normals, at="cell")
    _, t_graph = timed(lambda: net.graph)
    n = net.n_cells
    build = t_seed + t_index + t_link + t_graph
    print(f"\n{n:,} cells, {len(links):,} links, {idx.n_boxes:,} boxes (kb = 2)")
    print(f"  seeding {t_seed:.2f} s | box index {t_index:.2f} s + 27-box links {t_link:.2f} s "
          f"= {t_index + t_link:.2f} s | cKDTree links {t_kd:.2f} s | boxes/cKDTree "
          f"{(t_index + t_link) / t_kd:.2f}x | CSR graph {t_graph:.2f} s")
    print(f"  network built (seed + index + links + graph) in {build:.2f} s (target < 10 s at 1 M)")

    x = np.random.default_rng(1).random(n)
    t0 = time.perf_counter()
    for _ in range(20):
        net.matrix @ x
    spmv = (time.perf_counter() - t0) / 20
    print(f"  baseline: one sparse neighbour sum A @ x takes {spmv * 1e3:.2f} ms "
          f"({n / spmv / 1e6:.0f} M cells/s); rule steps below are also given in these units")
    global BASELINE
    BASELINE = spmv

    gs = np.full(n, ACTIVE, np.int8)
    send, update = sends(gs), receives(gs)
    rng = np.random.default_rng(0)
    color = rng.random((n, 3)).astype(np.float32)
    colored = np.ones(n, bool)
    t0 = time.perf_counter()
    for _ in range(steps):
        color, colored = spread(net, color, colored, send, update)
    report("colour spreading", n, steps, time.perf_counter() - t0)

    g = cell_graph(net)
    lut = parse_rule("B3/S23").lut(int(g.degree.max()))
    alive = rng.random(n) < 0.5
    t0 = time.perf_counter()
    for _ in range(steps):
        alive = life_step(g, alive, lut)
    report("Life B3/S23", n, steps, time.perf_counter() - t0)

    labels = np.zeros(n, np.int32)
    labels[rng.choice(n, 12, replace=False)] = np.arange(1, 13)
    grow = VoronoiGrowth(g, labels)
    t0 = time.perf_counter()
    k = 0
    while grow.step(rng):
        k += 1
    report(f"Voronoi propagation to full ({k} steps)", n, k, time.perf_counter() - t0)

    t0 = time.perf_counter()
    cur = net
    for _ in range(steps):
        pos, nrm = melt_step(cur, send, update)
        cur = cur.with_positions(pos)
        cur.add_field("cell__normal", nrm, at="cell")
    report("melting (positions + normals, new network per step)", n, steps, time.perf_counter() - t0)


BASELINE = 1.0


def report(what: str, n: int, steps: int, seconds: float) -> None:
    rate = n * steps / max(seconds, 1e-12)
    print(f"  {what}: {steps / seconds:.1f} steps/s, {rate / 1e6:.1f} M cell updates/s "
          f"({rate / 1.2e6:.1f}x the paper's ~1.2 M/s; one step = "
          f"{seconds / steps / BASELINE:.1f} neighbour sums)")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[100_000, 1_000_000])
    ap.add_argument("--steps", type=int, default=20)
    args = ap.parse_args()
    for n in args.sizes:
        bench(n, args.steps)
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\npeak memory {peak:.0f} MB")


if __name__ == "__main__":
    main()
