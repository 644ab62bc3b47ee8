"""3DSCA speed: cell construction, Voronoi to full coverage, copper patina, geodesic reference.

Prints absolute times, cell updates per second, and ratios against the thesis's timings
(Voronoi on ~250k cells: < 10 min; patina 950 steps on ~220k cells: < 20 min, SGI R10000) and
against the project targets (10 s and 60 s).  potpourri3d's heat-method geodesic Voronoi on the
same cells is timed in the same process, with the label agreement.

    python benchmarks/surface.py            # full size
    python benchmarks/surface.py --quick    # a tenth of the cells
    python benchmarks/surface.py --voronoi-baseline ../main   # also time the Voronoi kernel of
                                            # another checkout (before it moved into procgen.ca)
    python benchmarks/surface.py --quick --baseline /path/to/venv/bin/python   # + previous code
    python benchmarks/surface.py --paths    # numpy vs compiled (procgen.ca.kernels) vs limit
    python benchmarks/surface.py --paths --only life    # only the ca.life rows

Voronoi runs as the core's generic ``ca.voronoi`` kernel (procgen.ca.propagation) on the cells'
CellGraph; ``ca.life`` (25/357, table reading) is timed on the same cells. The patina part
times the attack/defence kernel alone and the whole ``layers.corrode`` rule (which publishes its
fields at frames and at the end: that once is timed apart); with --baseline the previous version of this benchmark runs
after it under that interpreter, so both print the same figures in one run.

``--paths`` runs the ``ca.life`` rule (25/357, table reading, 100 steps) and ca.voronoi (to
full coverage) on the same cylinder cells, and the patina kernel (``--path-steps`` steps on the
cup), once per path, each in its own process (own peak RSS), one after the other: the numpy step,
the compiled step (numba import and kernel load/compile timed apart, on a warm-up graph) and the
machine's limit, a trivial compiled kernel summing a uint8 per neighbour through int32 ids (the
gather every cell step needs, nothing else): over every cell in memory order for life and
patina (as fixed-length rows when every cell has the same degree, the fastest form of that
gather; the CSR loop is reported beside it), over the same frontiers in the same order for
Voronoi.  Life and patina are timed per cell-step, Voronoi per frontier entry visited (its work
is the frontier's, not the domain's; the per-graph links of the compiled step, ``graph_setup_s``,
are built before the clock, as the transposed graph both paths use is).  Single-threaded rows (numba at one thread) give CPU
time; the ``2 threads`` rows run the same workload with numba's threads on both cores and give
wall time on every path (numpy included), which on a loaded machine is the noisier figure.
Fastest of two alternating rounds; both paths' results are hashed.  The compiled patina child
also runs the workload once more with each pass of the step timed apart and prints them
(``passes``: ns per cell-step and share, "glue" = the step's Python outside the passes) with the
front per step, the part of the grid the per-entry passes work on.

The life rows' limit is the same trivial gather on the compact layout the compiled life step
reads (int16 neighbour deltas + int32 escape rows, unsigned indices: the same bytes and
indexing); the int32 fixed-row gather is printed beside it in a second life table, with the
bytes per cell each streams.  Life prints two rates that must not be confused: the dense rate (step 1, every cell evaluated;
best of 5 fresh starts) and the steady rate (steps 2-100), where the compiled rule switches to
its activity-tracking step once few cells change; ``active_share`` is the mean share of the
cells the compiled steps evaluated (1 on a dense step), so its "to limit" compares a sparse
step with the dense gather limit and can fall below 1x.  ``bytes_per_cell`` of a compiled
path is the kernel's own buffers (state, lists, neighbour table, transposed graph) per cell.
"""
from __future__ import annotations

import argparse
import hashlib
import importlib.util
import sys
import time
from pathlib import Path

import numpy as np
import trimesh

import _paths
from _baseline import add_arguments, run_previous
from procgen import State
from procgen_layers import corrosion as cz
from procgen_layers.materials import parse_materials
from procgen_layers.rules import Corrode, cell_stack_colors
from procgen_layers.stack import put_thickness, store_table
from procgen_surface.domain import SurfaceCells
from procgen_surface.primitives import cup
from procgen.ca.graph import grid_graph
from procgen.ca.lifelike import life_step, parse_rule
from procgen.ca.propagation import VoronoiGrowth, place_seeds


def timed(fn, *a, **k):
    t = time.perf_counter()
    out = fn(*a, **k)
    return out, time.perf_counter() - t


def baseline_growth(root: str) -> type:
    """VoronoiGrowth of another checkout: its procgen/ca/propagation.py, or the surface plugin's
    voronoi.py of the tree before the kernel moved into the core."""
    for rel in ("procgen/ca/propagation.py", "plugins/procgen_surface/voronoi.py"):
        path = Path(root) / rel
        if path.exists():
            spec = importlib.util.spec_from_file_location("baseline_voronoi", path)
            mod = importlib.util.module_from_spec(spec)
            sys.modules[spec.name] = mod          # dataclasses look their module up
            spec.loader.exec_module(mod)
            return mod.VoronoiGrowth
    raise SystemExit(f"--baseline {root}: no Voronoi kernel found")


def grow_to_full(cls: type, graph, labels: np.ndarray) -> tuple[np.ndarray, int, float]:
    rng = np.random.default_rng(7)
    grow = cls(graph, labels.copy())
    t0 = time.perf_counter()
    steps = 0
    while grow.step(rng):
        steps += 1
    return grow.labels, steps, time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--quick", action="store_true")
    ap.add_argument("--steps", type=int, default=950)
    ap.add_argument("--voronoi-baseline", help="checkout whose Voronoi kernel is timed beside this one")
    ap.add_argument("--paths", action="store_true", help="numpy vs compiled vs limit (see above)")
    ap.add_argument("--path-steps", type=int, default=300, help="patina steps timed by --paths")
    ap.add_argument("--only", default="", help="--paths: only the workloads whose name starts so (life, ...)")
    add_arguments(ap)
    _paths.add_arguments(ap)
    args = ap.parse_args()
    scale = 0.1 if args.quick else 1.0
    if args.path:
        return path_child(args, scale)
    if args.paths:
        n = int(250_000 * scale)
        m = int(220_000 * scale)
        work = [("life-first", f"ca.life rule 25/357 on ~{n:,} cylinder cells, step 1 = dense (per cell)"),
                ("life-first-2t", f"  step 1 = dense, 2 threads, wall time"),
                ("life", f"  steps 2-100 = steady, active share in details (per cell-step)"),
                ("life-2t", f"  steps 2-100, 2 threads, wall time"),
                ("voronoi", f"ca.voronoi 24 seeds on ~{n:,} cells to full (per frontier entry)"),
                ("voronoi-2t", f"  the same, 2 threads, wall time"),
                ("corrode", f"layers.corrode kernel, ~{m:,} cup cells, {args.path_steps} steps (per cell-step)"),
                ("corrode-2t", f"  the same, 2 threads, wall time")]
        rows = _paths.compare([w for w in work if w[0].startswith(args.only)],
                              (["--quick"] if args.quick else []) + ["--path-steps", str(args.path_steps)])
        _life_table(rows)
        return

    # -- Voronoi: a 48-triangle cylinder (plate 4.1), ~250k cells ----------------------------
    cyl = trimesh.creation.cylinder(radius=1.0, height=2.2, sections=12)
    v, f = np.asarray(cyl.vertices), np.asarray(cyl.faces)
    sc, t_build = timed(SurfaceCells.from_mesh, v, f, target_cells=int(250_000 * scale))
    rng = np.random.default_rng(1)
    labels = place_seeds(sc.n_cells, 24, rng)
    print(f"cells      : {sc.n_cells:,} cells on {len(f)} triangles built in {t_build:.2f} s "
          f"({sc.n_cells / t_build:,.0f} cells/s)")
    _, t_in = timed(lambda: sc.graph.incoming)
    print(f"graph      : transposed (incoming) links for the frontier in {t_in:.3f} s, once per graph")
    runs = [("ca.voronoi", VoronoiGrowth)] + ([("baseline", baseline_growth(args.voronoi_baseline))] if args.voronoi_baseline else [])
    results = {}
    for _ in range(2):                        # alternate twice: both see the same machine load
        for tag, cls in runs:
            lab, steps, t = grow_to_full(cls, sc.graph, labels)
            results[tag] = (lab, steps, min(t, results.get(tag, (0, 0, np.inf))[2]))
    final, steps, t_vor = results["ca.voronoi"]
    print(f"voronoi    : {steps} steps to full coverage in {t_vor:.2f} s "
          f"({sc.n_cells * steps / t_vor:,.0f} cell updates/s), best of 2")
    if args.voronoi_baseline:
        b_lab, b_steps, b_t = results["baseline"]
        print(f"  baseline ({args.voronoi_baseline}): {b_steps} steps in {b_t:.2f} s "
              f"({sc.n_cells * b_steps / b_t:,.0f} cell updates/s); this / baseline speed "
              f"{b_t / t_vor:.2f} x; identical labels: {np.array_equal(b_lab, final)}")
    grow_labels = final
    lut = parse_rule("25/357", "table").lut()
    alive = np.random.default_rng(3).random(sc.n_cells) < 0.05
    t0 = time.perf_counter()
    for _ in range(100):
        alive = life_step(sc.graph, alive, lut)
    t_life = time.perf_counter() - t0
    print(f"ca.life    : 25/357 (table) 100 steps in {t_life:.2f} s "
          f"({sc.n_cells * 100 / t_life:,.0f} cell updates/s), live fraction {alive.mean():.2f}")
    total = t_build + t_vor
    print(f"  build+voronoi {total:.2f} s: {total / 10:.2f} x the 10 s target, "
          f"{600 / total:,.0f} x faster than the thesis (< 10 min)")

    # -- geodesic reference: potpourri3d heat method on the same cells -------------------------
    import potpourri3d as pp3d
    seeds = np.nonzero(labels)[0]
    t0 = time.perf_counter()
    solver = pp3d.PointCloudHeatSolver(sc.center3d)
    dist = np.stack([solver.compute_distance(int(s)) for s in seeds])
    geo = labels[seeds][np.argmin(dist, axis=0)]
    t_geo = time.perf_counter() - t0
    print(f"potpourri3d: heat-method geodesic Voronoi ({len(seeds)} seeds) in {t_geo:.2f} s "
          f"({t_geo / t_vor:.2f} x our CA); label agreement {np.mean(geo == grow_labels):.1%}")

    # -- copper patina: a ~600-triangle cup, ~220k cells, 950 steps ---------------------------
    cv, cf = cup(sections=20, rings=5)
    sc2, t_build2 = timed(SurfaceCells.from_mesh, cv, cf, target_cells=int(220_000 * scale))
    rng = np.random.default_rng(2)
    n = sc2.n_cells
    st = cz.CorrosionState(status=np.zeros(n, np.int8), consumable=np.ones((n, 1)),
                           product=np.zeros(n), age=np.zeros(n, np.int32),
                           strong=cz.strong_mask(n, 0.3, rng))
    st.status[rng.integers(n)] = cz.CORRODED
    prm = Corrode()                                   # the rule's parameters are the kernel's
    weights = cz.direction_weights(cz.gaussian_matrix(prm.sigma))
    t0 = time.perf_counter()
    for k in range(args.steps):
        cz.corrosion_step(sc2.graph, st, prm, np.random.default_rng(k), weights=weights)
    t_pat = time.perf_counter() - t0
    cov = np.mean(st.status != cz.NORMAL)
    print(f"patina     : {args.steps} steps on {n:,} cells ({len(cf)} triangles, built in "
          f"{t_build2:.2f} s) in {t_pat:.2f} s ({n * args.steps / t_pat:,.0f} cell updates/s), "
          f"coverage {cov:.1%}")
    print(f"  {t_pat / 60:.2f} x the 60 s target, {1200 / t_pat:,.0f} x faster than the thesis (< 20 min)")

    # -- the same through the layers.corrode rule (fields published at the end) ---------------
    table = parse_materials(["copper", "patina"])
    state = State(seed=2)
    state.add_domain("cells", sc2)
    store_table(sc2, table)
    put_thickness(sc2, np.column_stack([np.ones(n), np.zeros(n)]), table)
    rule = Corrode(strong_fraction=0.3)
    state.step_index, state.rule_name, state.iteration = 0, rule.name, -1
    rule.setup(state)
    kernel, t_kernel = cz.corrosion_step, [0.0]

    def kernel_timed(*a, **k):                       # the kernel's share of the rule's step
        t = time.perf_counter()
        got = kernel(*a, **k)
        t_kernel[0] += time.perf_counter() - t
        return got

    cz.corrosion_step = kernel_timed
    t0 = time.perf_counter()
    for k in range(args.steps):
        state.iteration = k
        rule.step(state)
    t_rule = time.perf_counter() - t0
    cz.corrosion_step = kernel
    t0 = time.perf_counter()
    rule.finish(state)                               # the fields, published once
    t_publish = time.perf_counter() - t0
    per = 1e9 / (n * args.steps)
    print(f"rule       : layers.corrode, {args.steps} steps in {t_rule:.2f} s "
          f"({n * args.steps / t_rule:,.0f} cell updates/s, {t_rule / t_pat:.2f} x the kernel alone), "
          f"coverage {np.mean(sc2['corrosion__state'] != cz.NORMAL):.1%}")
    print(f"  per cell-step {t_rule * per:.1f} ns = kernel {t_kernel[0] * per:.1f} + the rule's own work "
          f"{(t_rule - t_kernel[0]) * per:.1f} ({(t_rule - t_kernel[0]) / args.steps * 1e3:.2f} ms per step); "
          f"the fields published once at the end: {t_publish * 1e3:.1f} ms")

    # -- export: textured OBJ and GLB of the patinated cup -----------------------------------
    from procgen_surface.exporters import surface_glb, surface_obj
    sc2.add_field("surface__color", cell_stack_colors(sc2, lit=False, light=np.zeros(3), eye=np.zeros(3)),
                  at="cell")
    files, t_obj = timed(surface_obj, sc2, stem="cup")
    glb, t_glb = timed(surface_glb, sc2)
    size = sum(len(b) for b in files.values()) / 1e6
    print(f"export     : OBJ+MTL+atlas {size:.1f} MB in {t_obj:.2f} s, GLB {len(glb) / 1e6:.1f} MB "
          f"in {t_glb:.2f} s")
    import resource
    print(f"peak memory: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:,.0f} MB")
    run_previous("surface.py", args.baseline, args.baseline_rev,
                 ["--steps", str(args.steps)] + (["--quick"] if args.quick else []))


def _cylinder_cells(target: int) -> SurfaceCells:
    cyl = trimesh.creation.cylinder(radius=1.0, height=2.2, sections=12)
    return SurfaceCells.from_mesh(np.asarray(cyl.vertices), np.asarray(cyl.faces), target_cells=target)


def _life_table(rows: list[dict]) -> None:
    """The ca.life rows again with both limits: the int32 fixed-row gather (as in the table
    above for the other workloads) and the same gather on the compact layout the compiled step
    reads (int16 deltas + escape rows; the distance is to this one: the same bytes per cell)."""
    life = [r for r in rows if r["part"].startswith("life")]
    if not life:
        return
    mib = 2 ** 20
    print(f"\nca.life {'':<14} {'numpy':>7} {'compiled':>8} {'ratio':>6} {'lim i32':>7} {'lim cmp':>7} "
          f"{'to lim':>6} {'RSS np':>7} {'RSS cmp':>7}   bytes/cell: lim i32, lim cmp, compiled")
    names = {"life-first": "dense 1t", "life-first-2t": "dense 2t", "life": "steady 1t", "life-2t": "steady 2t"}
    for r in life:
        n, c, lim = r["numpy"]["seconds"], r["compiled"]["seconds"], r["limit"]
        i32 = lim["fixed_rows_ns"] * 1e-9
        print(f"  {names[r['part']]:<20} {_paths._t(n)} {_paths._t(c):>8} {n / c:5.1f}x {_paths._t(i32)} "
              f"{_paths._t(lim['seconds'])} {c / lim['seconds']:5.1f}x {r['numpy']['peak_rss'] / mib:5.0f} M "
              f"{r['compiled']['peak_rss'] / mib:5.0f} M   {lim['bytes_per_cell']:.1f}, "
              f"{lim['compact_bytes_per_cell']:.1f}, {r['compiled']['streamed_bytes_per_cell']:.1f}")


def _limit_kernels():
    """The trivial gathers of the limit (compiled on first use): CSR rows, fixed-length rows
    (in parallel over the cells), and CSR rows of a list of cells (the Voronoi frontiers)."""
    from numba import njit, prange

    @njit(cache=True, nogil=True)
    def csr(indptr, indices, x, out):
        for c in range(indptr.size - 1):
            v = 0
            for e in range(indptr[c], indptr[c + 1]):
                v += x[indices[e]]
            out[c] = v

    @njit(cache=True, nogil=True, parallel=True)
    def rows(table, x, out):
        for c in prange(out.size):
            v = 0
            for s in range(table.shape[1]):
                v += x[table[c, s]]
            out[c] = v

    @njit(cache=True, nogil=True)
    def some(indptr, indices, cells, x, out):
        for c in cells:
            v = 0
            for e in range(indptr[c], indptr[c + 1]):
                v += x[indices[e]]
            out[c] = v

    return csr, rows, some


def _compact_limit_kernels():
    """The same trivial gather over the compact layout of the compiled life step
    (procgen.ca.kernels.Neighbours: int16 deltas, int32 escape rows, unsigned indices, the row
    length as a constant), and the int32 fixed rows read with unsigned indices (the indexing
    the compiled step uses: it shows what the indexing alone gains)."""
    from numba import njit, prange

    @njit(cache=True, nogil=True, parallel=True)
    def compact(ks, delta, esc_rows, esc_table, esc_ptr, block, x, out):
        n = delta.shape[0]
        for b in prange(esc_ptr.size - 1):
            lo = b * block
            hi = min(lo + block, n)
            for j in range(esc_ptr[b], esc_ptr[b + 1] + 1):
                stop = esc_rows[j] if j < esc_ptr[b + 1] else hi
                for c in range(lo, stop):
                    v = 0
                    for s in range(len(ks)):
                        v += x[np.uint64(c + delta[c, s])]
                    out[c] = v
                if stop < hi:
                    v = 0
                    for s in range(len(ks)):
                        v += x[np.uint64(esc_table[j, s])]
                    out[stop] = v
                lo = stop + 1

    @njit(cache=True, nogil=True, parallel=True)
    def rows_unsigned(ks, table, x, out):
        for c in prange(out.size):
            v = 0
            for s in range(len(ks)):
                v += x[np.uint64(table[c, s])]
            out[c] = v

    return compact, rows_unsigned


def _life_rule(dom) -> tuple:
    """The timed ca.life rule (25/357, table reading, 5 % live) set up on ``dom``."""
    from procgen.ca.lifelike import LifeLike
    state = State(seed=3)
    state.add_domain("cells", dom)
    rule = LifeLike.from_params({"rule": "25/357", "semantics": "table", "density": 0.05})
    state.rule_name, state.iteration = rule.name, 0
    rule.setup(state)
    return state, rule


def _life_warmup() -> None:
    """Load every compiled kernel the timed ca.life rule uses (dense step, tracking start,
    tracking step, age pass) on a small grid, so no kernel load falls in the timed steps."""
    from procgen import Grid
    from procgen.ca.kernels import LifeRun
    dom = Grid((40, 40))
    share, LifeRun.ACTIVE_SHARE = LifeRun.ACTIVE_SHARE, 1.0      # tracking from step 2 on
    try:
        state, rule = _life_rule(dom)
        for _ in range(3):
            rule.step(state)
    finally:
        LifeRun.ACTIVE_SHARE = share


def _bytes_per_cell(obj, n: int) -> float:
    """The numpy arrays held by a kernel's work object (one level deep; not the input graph
    both paths share), per cell."""
    seen: dict[int, int] = {}
    for k, v in vars(obj).items():
        if k == "graph":
            continue
        for a in (v if isinstance(v, tuple) else (v,)):
            if isinstance(a, np.ndarray):
                seen[id(a)] = a.nbytes
            elif hasattr(a, "__dict__") and not isinstance(a, type):
                for w in list(vars(a).values()):
                    if isinstance(w, np.ndarray):
                        seen[id(w)] = w.nbytes
    return round(sum(seen.values()) / n, 1)


def _corrode_passes(g, patina, clock, steps: int) -> dict:
    """The compiled patina run again with each pass of the step timed apart (not the timed
    run: the pass clocks cost a little): per pass ns per cell-step and its share, the step
    outside the passes ("glue": Python, argument checks), and the front per step, of which
    the per-entry passes do the work (a per-cell-step figure hides that it is a small part
    of the grid)."""
    from procgen.accel import kernels
    kern = kernels("procgen_layers.corrosion_kernels", True)
    fronts: list[int] = []
    kern.PASS_TIMES, kern.PASS_CLOCK = {}, clock
    try:
        t0 = clock()
        patina(lambda: fronts.append(g.__dict__["_corrode_kernel_work"].nfront))
        total = clock() - t0
        times = dict(kern.PASS_TIMES)
    finally:
        kern.PASS_TIMES, kern.PASS_CLOCK = None, time.perf_counter
    times["glue"] = total - sum(times.values())
    per = steps * g.n_cells
    out = {k: f"{v / per * 1e9:.2f}ns {v / total:.0%}" for k, v in sorted(times.items(), key=lambda kv: -kv[1])}
    f = np.array(fronts)
    out["front_cells_per_step"] = f"mean {f.mean():,.0f} ({f.mean() / g.n_cells:.1%} of the cells), max {f.max():,}"
    return out


def path_child(args, scale: float) -> None:
    """One path of ``--paths`` in this process: time per unit of work, as JSON."""
    part, threads = args.part.removesuffix("-2t"), 2 if args.part.endswith("-2t") else 1
    part = part if part != "life-first" or args.path != "limit" else "life"
    if args.path != "numpy":                   # (the numpy child never imports numba: its RSS)
        import numba
        numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    if part == "corrode":
        cv, cf = cup(sections=20, rings=5)
        sc = SurfaceCells.from_mesh(cv, cf, target_cells=int(220_000 * scale))
    else:
        sc = _cylinder_cells(int(250_000 * scale))
    g = sc.graph
    clock = time.perf_counter if threads > 1 else time.process_time
    if args.path == "limit":
        csr, rows, some = _limit_kernels()
        x = (np.random.default_rng(3).random(g.n_cells) < 0.5).astype(np.uint8)
        out = np.empty(g.n_cells, np.uint8)
        ind = g.indices.astype(np.int32)
        fig = {"entries_per_cell": round(g.indices.size / g.n_cells, 2),
               "bytes_per_cell": round(ind.nbytes / g.n_cells + 2, 1)}
        if part == "voronoi":              # the frontiers the growth visits, in its order
            grow = VoronoiGrowth(g, place_seeds(g.n_cells, 24, np.random.default_rng(1)), accelerate=True)
            rng, sets = np.random.default_rng(7), [grow.frontier]
            while grow.step(rng):
                sets.append(grow.frontier)
            some(g.indptr, ind, sets[0], x, out)
            t0 = clock()
            for cells in sets:
                some(g.indptr, ind, cells, x, out)
            t = clock() - t0
            _paths.report(seconds=t / sum(int(np.sum(g.degree[c])) for c in sets), **fig)
            return
        reps = 30
        times = {}
        if threads == 1:
            csr(g.indptr, ind, x, out)
            t0 = clock()
            for _ in range(reps):
                csr(g.indptr, ind, x, out)
            times["csr_loop"] = (clock() - t0) / (reps * g.n_cells)
        if np.all(g.degree == g.degree[0]):     # every row the same length: the fixed-row gather
            table = ind.reshape(g.n_cells, -1)
            rows(table, x, out)
            t0 = clock()
            for _ in range(reps):
                rows(table, x, out)
            times["fixed_rows"] = (clock() - t0) / (reps * g.n_cells)
        fig.update({k + "_ns": round(v * 1e9, 2) for k, v in times.items()})
        if part == "life":                      # + the compact layout's gather: the life limit
            from procgen.ca.kernels import neighbours
            nb = neighbours(g)
            compact, rows_unsigned = _compact_limit_kernels()
            ks = (0,) * nb.delta.shape[1]
            xs = np.append(x, np.uint8(0))
            more = {"compact": lambda: compact(*nb.layout, xs, out)}
            if "fixed_rows" in times:
                more["fixed_rows_unsigned"] = lambda: rows_unsigned(ks, table, x, out)
            for k, f in more.items():
                f()
                t0 = clock()
                for _ in range(reps):
                    f()
                fig[k + "_ns"] = round((clock() - t0) / (reps * g.n_cells) * 1e9, 2)
            fig.update(compact_bytes_per_cell=round(nb.nbytes / g.n_cells + 2, 1),
                       escape_rows=round(nb.esc_rows.size / g.n_cells, 4))
            _paths.report(seconds=fig["compact_ns"] * 1e-9, **fig)
            return
        _paths.report(seconds=min(times.values()), **fig)
        return
    import os
    os.environ["PROCGEN_ACCELERATE"] = "1" if args.path == "compiled" else "0"
    accelerate = args.path == "compiled"
    fig = {"threads": numba.get_num_threads() if accelerate else 1}   # numba's, for the kernels
    if accelerate:
        small = grid_graph(40, 40)
        t0 = time.perf_counter()
        life_step(small, np.zeros(small.n_cells, bool), parse_rule("B3/S23").lut(), accelerate=True)
        _life_warmup()
        VoronoiGrowth(small, place_seeds(small.n_cells, 2, np.random.default_rng(0)), accelerate=True
                      ).step(np.random.default_rng(0))
        st = cz.CorrosionState(status=np.ones(small.n_cells, np.int8), consumable=np.ones((small.n_cells, 1)),
                               product=np.zeros(small.n_cells), age=np.zeros(small.n_cells, np.int32),
                               strong=np.zeros(small.n_cells, bool))
        cz.corrosion_step(small, st, Corrode(), np.random.default_rng(0),
                          weights=cz.direction_weights(cz.gaussian_matrix(1.0)), accelerate=True)
        fig["warmup_s"] = round(time.perf_counter() - t0, 2)
    if part == "corrode":
        n = g.n_cells
        prm = Corrode()
        weights = cz.direction_weights(cz.gaussian_matrix(prm.sigma))

        def patina(each=None) -> cz.CorrosionState:
            rng = np.random.default_rng(2)
            st = cz.CorrosionState(status=np.zeros(n, np.int8), consumable=np.ones((n, 1)),
                                   product=np.zeros(n), age=np.zeros(n, np.int32),
                                   strong=cz.strong_mask(n, 0.3, rng))
            st.status[rng.integers(n)] = cz.CORRODED
            for k in range(args.path_steps):
                cz.corrosion_step(g, st, prm, np.random.default_rng(k), weights=weights, accelerate=accelerate)
                if each:
                    each()
            return st

        t0 = clock()
        st = patina()
        t = clock() - t0
        digest = hashlib.sha256(st.status.tobytes() + st.consumable.tobytes() + st.product.tobytes())
        if accelerate:
            fig["bytes_per_cell"] = _bytes_per_cell(g.__dict__["_corrode_kernel_work"], n)
            fig["passes"] = _corrode_passes(g, patina, clock, args.path_steps)
        fig.update(hash=digest.hexdigest()[:16], coverage=round(float(np.mean(st.status != cz.NORMAL)), 3))
        _paths.report(seconds=t / (args.path_steps * n), **fig)
        return
    if part in ("life", "life-first"):         # the whole rule step (fields published each step)
        g.incoming                             # built once per graph (the tracking step's), not timed

        def start() -> tuple:
            return _life_rule(sc)

        if accelerate:                         # neighbour layout + state read and write + age (+ ever)
            run = start()[1]._run
            fig["streamed_bytes_per_cell"] = round(
                (run.nb.nbytes + run.age.nbytes * 2 + (run.ever0.nbytes * 2 if run.ever_buf is not None else 0))
                / g.n_cells + 2, 1)
        if part == "life-first":               # the dense rate: step 1, every cell active
            best = np.inf
            for _ in range(5):
                state, rule = start()
                t0 = clock()
                rule.step(state)
                best = min(best, clock() - t0)
            fig["hash"] = hashlib.sha256(np.asarray(sc["ca__alive"]).tobytes()
                                         + np.asarray(sc["ca__age"]).tobytes()).hexdigest()[:16]
            fig["active_share"] = 1.0
            _paths.report(seconds=best / g.n_cells, **fig)
            return
        state, rule = start()                  # the steady rate: steps 2..100 after step 1
        rule.step(state)
        shares = []
        t0 = clock()
        for k in range(1, 100):
            state.iteration = k
            rule.step(state)
            if accelerate:
                shares.append(rule._run.share)
        t = clock() - t0
        alive = np.asarray(sc["ca__alive"])
        fig.update(hash=hashlib.sha256(alive.tobytes() + np.asarray(sc["ca__age"]).tobytes()).hexdigest()[:16],
                   live=round(float(alive.mean()), 3))
        if accelerate:
            fig.update(active_share=round(float(np.mean(shares)), 4),
                       tracking_steps=int(sum(s < 1 for s in shares)),
                       bytes_per_cell=_bytes_per_cell(rule._run, g.n_cells))
        _paths.report(seconds=t / (99 * g.n_cells), **fig)
        return
    g.incoming                                 # built once per graph on both paths, not timed
    if accelerate:                             # the compiled step's per-graph links, timed apart
        from procgen.ca.kernels import voronoi_links
        t0 = time.perf_counter()
        links = voronoi_links(g)
        fig["graph_setup_s"] = round(time.perf_counter() - t0, 3)
    labels = place_seeds(g.n_cells, 24, np.random.default_rng(1))
    grow = VoronoiGrowth(g, labels, accelerate=accelerate)
    rng = np.random.default_rng(7)
    fronts = []                                # (counted after the clock: not the step's work)
    t0 = clock()
    while True:
        fronts.append(grow.frontier)
        if not grow.step(rng):
            break
    t = clock() - t0
    entries = sum(int(np.sum(g.degree[f])) for f in fronts)
    fig.update(hash=hashlib.sha256(grow.labels.tobytes()).hexdigest()[:16], steps=len(fronts) - 1,
               frontier_entries=entries, seconds_total=round(t, 2))
    if accelerate:                             # the step's own arrays (not the labels, the graph)
        from procgen.ca.kernels import _ATTR
        work = grow.__dict__[_ATTR]
        arrays = [work.st, work.words, work.cand, work.ncand, links.links, links.xptr, links.xidx]
        fig["bytes_per_cell"] = round(sum(a.nbytes for a in arrays) / g.n_cells, 1)
    _paths.report(seconds=t / entries, **fig)


if __name__ == "__main__":
    main()
