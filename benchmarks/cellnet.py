"""Benchmark: cellular networks of 100k and 1M cells (seed 002, issue 12).

For each size: seeding a triangle network on a plane, building the sparse box index and the
links (27-box search) against scipy's cKDTree in the same process (ratio printed), the CSR
cell graph, then the per-step cost of colour spreading, the generic Voronoi propagation
(frontier only), Life (B3/S23, outer-totalistic), majority regrouping and melting, as cell
updates per second.  Every figure is given as wall time and as this process's CPU time (the
machine is shared: the load average is printed; CPU time is what the code costs).  One-time
costs are measured apart and printed as the warm-up: compiling or loading the numba kernels
(box search, Life, majority, Voronoi: on a 2,000-cell network first) and each rule's first step
on the big network, which builds the matrices the later steps reuse (the gated sending and
averaging matrices, the kernels' buffers); the per-step rates are the steps after it.  Peak
memory (ru_maxrss) is printed at the end.  The paper's bar: 100,000 cells at >= 12 steps/s
(about 1.2 million cell updates per second, rendering included, on a 2004 PC); targets here
>= 20 million cell updates per second for the totalistic rules and a 1 M-cell network built
in under 10 s.  ``--baseline PYTHON`` also runs the previous version of this script.

The box search is timed against cKDTree best of ``--repeat`` runs each, interleaved (the
machine is shared; the best run is the least disturbed), both through the compiled walk where
numba is installed and through the numpy-only column sweep.  Polygon orientation (Figure 8's
"any polygons", orientation.py) is timed on randomly wound triangle soups of subdivided
icosahedra (``--soups``: subdivision levels), against the quadratic all-pairs edge matching it
replaced (orientation.py as of commit ``OLD_ORIENTATION``, loaded from git) on the sizes that
one can still do, the flips checked equal and outward.

    python benchmarks/cellnet.py [--sizes 100000 1000000] [--steps 20] [--soups 3 5 6]
"""
from __future__ import annotations

import argparse
import importlib.util
import math
import os
import resource
import subprocess
import time
import types

import numpy as np
import scipy.spatial  # noqa: F401  (imported before timing: module loading is not building)
import scipy.sparse.csgraph  # noqa: F401

from _baseline import add_arguments, run_previous
from procgen.ca.cells import cell_graph
from procgen.ca.lifelike import life_step, parse_rule
from procgen.ca.majority import majority_step
from procgen.ca.propagation import VoronoiGrowth
from procgen_cellnet.boxes import BoxIndex, pairs_kdtree, pairs_within
from procgen_cellnet.colour import spread
from procgen_cellnet.melting import melt_step
from procgen_cellnet.network import CellNetwork
from procgen_cellnet.orientation import orient_polygons
from procgen_cellnet.seeding import DENSITY, link_radius, seed_cells
from procgen_cellnet.states import ACTIVE, receives, sends


class Clock:
    """Wall and CPU seconds of a block."""

    def __enter__(self) -> "Clock":
        self.w0, self.c0 = time.perf_counter(), time.process_time()
        return self

    def __exit__(self, *exc) -> None:
        self.wall = time.perf_counter() - self.w0
        self.cpu = time.process_time() - self.c0

    def __str__(self) -> str:
        return f"{self.wall:.2f} s ({self.cpu:.2f} s CPU)"


def plane(n_target: int) -> tuple[np.ndarray, np.ndarray]:
    side = math.sqrt(n_target / DENSITY["triangle"])
    v = np.array([[0, 0, 0], [side, 0, 0], [side, side, 0], [0, side, 0]], float)
    return v, np.array([[0, 1, 2], [0, 2, 3]])


def warm_up() -> None:
    """Compile or load every numba kernel the timed code takes, on a small network."""
    acc = ACCELERATE is not False and importlib.util.find_spec("numba") is not None
    s = seed_cells(*plane(2_000), "triangle", 1.0)
    r = link_radius("triangle", 1.0, 0.01)
    with Clock() as c:
        links = pairs_within(s.positions, r, BoxIndex.build(s.positions, 2.0), accelerate=acc)
        g = cell_graph(CellNetwork(s.positions, links, cs=1.0, grid="triangle", radius=r))
        alive = np.random.default_rng(0).random(g.n_cells) < 0.5
        life_step(g, alive, parse_rule("B3/S23").lut(int(g.degree.max())), accelerate=acc)
        majority_step(g, alive)
        labels = np.zeros(g.n_cells, np.int32)
        labels[:3] = [1, 2, 3]
        VoronoiGrowth(g, labels, accelerate=acc).step(np.random.default_rng(0))
    print(f"warm-up: numba kernels compiled or loaded from the cache in {c} "
          f"(once per process; not in any figure below)")


def bench(n_target: int, steps: int, repeat: int) -> dict[str, float]:
    with Clock() as t_seed:
        s = seed_cells(*plane(n_target), "triangle", 1.0)
    p = s.positions
    r = link_radius("triangle", 1.0, 0.01)
    with Clock() as t_index:
        idx = BoxIndex.build(p, 2.0)
    with Clock() as t_link:
        links = pairs_within(p, r, idx, accelerate=ACCELERATE)
    kds, nps = [], []
    for _ in range(max(repeat, 1)):         # interleaved: both see the same machine
        with Clock() as t_kd:
            kd = pairs_kdtree(p, r)
        with Clock() as t_np:
            numpy_links = pairs_within(p, r, BoxIndex.build(p, 2.0), accelerate=False)
        kds.append(t_kd)
        nps.append(t_np)
        assert np.array_equal(links, kd) and np.array_equal(numpy_links, kd)
    t_kd = min(kds, key=lambda c: c.cpu)
    t_np = min(nps, key=lambda c: c.cpu)
    with Clock() as t_graph:
        net = CellNetwork(p, links, cs=1.0, grid="triangle", radius=r)
        net.add_field("cell__normal", s.normals, at="cell")
        g = cell_graph(net)
    n = net.n_cells
    parts = (t_seed, t_index, t_link, t_graph)
    build_w, build_c = sum(c.wall for c in parts), sum(c.cpu for c in parts)
    print(f"\n{n:,} cells, {len(links):,} links, {idx.n_boxes:,} boxes (kb = 2); "
          f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")
    print(f"  seeding {t_seed} | box index {t_index} | 27-box links {t_link} | "
          f"cKDTree links {t_kd} | CSR cell graph + Moore slots {t_graph}")
    print(f"  box index + links / cKDTree: {(t_index.wall + t_link.wall) / t_kd.wall:.2f}x wall, "
          f"{(t_index.cpu + t_link.cpu) / t_kd.cpu:.2f}x CPU")
    print(f"  numpy-only box index + column sweep {t_np} vs cKDTree {t_kd} (best CPU of {len(nps)} "
          f"each): {t_np.wall / t_kd.wall:.2f}x wall, {t_np.cpu / t_kd.cpu:.2f}x CPU; "
          f"medians {np.median([c.cpu for c in nps]):.2f} s vs {np.median([c.cpu for c in kds]):.2f} s CPU")
    print(f"  network built (seed + index + links + graph) in {build_w:.2f} s "
          f"({build_c:.2f} s CPU; target < 10 s at 1 M)")

    x = np.random.default_rng(1).random(n)
    with Clock() as t_spmv:
        for _ in range(20):
            net.matrix @ x
    global BASELINE
    BASELINE = t_spmv.cpu / 20
    print(f"  baseline: one sparse neighbour sum A @ x takes {BASELINE * 1e3:.2f} ms CPU "
          f"({n / BASELINE / 1e6:.0f} M cells/s); rule steps below are also given in these units")

    gs = np.full(n, ACTIVE, np.int8)
    send, update = sends(gs), receives(gs)
    rng = np.random.default_rng(0)
    color = rng.random((n, 3)).astype(np.float32)
    colored = np.ones(n, bool)
    rates = {}
    first: dict[str, Clock] = {}

    def timed(name: str, step, x):
        """The first step (warm-up) and ``steps`` more (the rate) of ``x = step(x)``."""
        with Clock() as c0:
            x = step(x)
        first[name] = c0
        with Clock() as c:
            for _ in range(steps):
                x = step(x)
        return x, c

    _, c = timed("spreading", lambda cc: spread(net, *cc, send, update), (color, colored))
    rates["spreading"] = report("colour spreading (float32 RGB)", n, steps, c)

    lut = parse_rule("B3/S23").lut(int(g.degree.max()))
    _, c = timed("life", lambda a: life_step(g, a, lut, accelerate=ACCELERATE), rng.random(n) < 0.5)
    rates["life"] = report("Life B3/S23", n, steps, c)

    _, c = timed("majority", lambda a: majority_step(g, a), rng.random(n) < 0.5)
    rates["majority"] = report("majority regrouping", n, steps, c)

    labels = np.zeros(n, np.int32)
    labels[rng.choice(n, 12, replace=False)] = np.arange(1, 13)
    grow = VoronoiGrowth(g, labels, accelerate=ACCELERATE)
    k = 0
    with Clock() as c:
        while grow.step(rng):
            k += 1
    report(f"Voronoi propagation to full ({k} steps)", n, k, c)

    def melt(cur):
        pos, nrm = melt_step(cur, send, update)
        cur = cur.with_positions(pos)
        cur.add_field("cell__normal", nrm, at="cell")
        return cur
    _, c = timed("melting", melt, net)
    report("melting (positions + normals, new network per step)", n, steps, c)
    print("  warm-up, the first step of each (builds the cached matrices and buffers): "
          + ", ".join(f"{k} {v}" for k, v in first.items()))
    return {"build": build_w, "build_cpu": build_c, **rates}


#: the quadratic all-pairs edge matching of orientation.py, timed beside the sorted one
OLD_ORIENTATION = "d4a6916"
#: largest soup the all-pairs matching is run on (1,280 triangles: about 2 s, 0.3 GB)
OLD_MAX_POLYGONS = 1280


def previous_orientation() -> types.ModuleType | None:
    """orientation.py as of ``OLD_ORIENTATION`` (from git), or None outside a git clone."""
    root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    try:
        src = subprocess.run(["git", "-C", root, "show",
                              f"{OLD_ORIENTATION}:plugins/procgen_cellnet/orientation.py"],
                             capture_output=True, text=True, check=True).stdout
    except (OSError, subprocess.CalledProcessError):
        return None
    module = types.ModuleType("orientation_all_pairs")
    exec(compile(src, "orientation_all_pairs.py", "exec"), module.__dict__)
    return module


def bench_orientation(levels: list[int]) -> None:
    """Orient randomly wound triangle soups of subdivided icosahedra; all-pairs on the small."""
    import trimesh

    old = previous_orientation()
    rng = np.random.default_rng(7)
    print("\npolygon orientation (triangle soups, every loop wound at random):")
    for level in levels:
        m = trimesh.creation.icosphere(subdivisions=level)
        tri = m.vertices[m.faces]
        back = rng.random(len(tri)) < 0.5
        tri[back] = tri[back][:, ::-1]
        polys = [[t] for t in tri]
        with Clock() as c:
            flips = orient_polygons(polys)
        normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]) * np.where(flips, -1, 1)[:, None]
        out = bool(np.all(np.einsum("ij,ij->i", normal, m.triangles_center) > 0))
        line = (f"  {len(polys):,} polygons, {3 * len(polys):,} edges: sorted runs {c}; "
                f"all outward: {out}")
        if old is not None and len(polys) <= OLD_MAX_POLYGONS:
            with Clock() as c_old:
                same = old.orient_polygons(polys) == flips
            line += (f"; all-pairs ({OLD_ORIENTATION}) {c_old}, {c_old.cpu / c.cpu:.0f}x the CPU, "
                     f"same flips: {same}")
        print(line)


BASELINE = 1.0
#: the compiled kernels where numba is installed (procgen.accel), switched by --numpy
ACCELERATE: bool | None = None


def report(what: str, n: int, steps: int, c: Clock) -> float:
    rate, rate_cpu = n * steps / max(c.wall, 1e-12), n * steps / max(c.cpu, 1e-12)
    print(f"  {what}: {steps / c.wall:.1f} steps/s, {rate / 1e6:.1f} M cell updates/s "
          f"({rate_cpu / 1e6:.1f} M/s CPU; {rate / 1.2e6:.0f}x the paper's ~1.2 M/s; one step = "
          f"{c.cpu / steps / BASELINE:.1f} neighbour sums)")
    return rate_cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="+", default=[100_000, 1_000_000])
    ap.add_argument("--steps", type=int, default=20)
    ap.add_argument("--numpy", action="store_true", help="the numpy reference paths only (no numba)")
    ap.add_argument("--soups", type=int, nargs="*", default=[3, 5, 6],
                    help="icosphere subdivision levels of the orientation soups (20 * 4^level triangles)")
    ap.add_argument("--repeat", type=int, default=3,
                    help="interleaved runs of the cKDTree and numpy-only link searches (best reported)")
    add_arguments(ap)
    args = ap.parse_args()
    global ACCELERATE
    ACCELERATE = False if args.numpy else None
    bench_orientation(args.soups)
    warm_up()
    results = {n: bench(n, args.steps, args.repeat) for n in args.sizes}
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"\npeak memory {peak:.0f} MB")
    big = results[max(results)]
    if max(results) >= 1_000_000:
        slow = [k for k in ("spreading", "life", "majority") if big[k] < 20e6]
        print(f"targets (CPU time): build {big['build_cpu']:.1f} s < 10 s: "
              f"{'met' if big['build_cpu'] < 10 else 'MISSED'}; totalistic rules >= 20 M/s: "
              f"{'met' if not slow else 'MISSED by ' + ', '.join(slow)}")
    run_previous("cellnet.py", args.baseline, args.baseline_rev,
                 ["--sizes", *map(str, args.sizes), "--steps", str(args.steps)])


if __name__ == "__main__":
    main()
