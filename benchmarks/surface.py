"""3DSCA speed: cell construction, Voronoi to full coverage, copper patina, geodesic reference.

Prints absolute times, cell updates per second, and ratios against the thesis's timings
(Voronoi on ~250k cells: < 10 min; patina 950 steps on ~220k cells: < 20 min, SGI R10000) and
against the project targets (10 s and 60 s).  potpourri3d's heat-method geodesic Voronoi on the
same cells is timed in the same process, with the label agreement.

    python benchmarks/surface.py            # full size
    python benchmarks/surface.py --quick    # a tenth of the cells
    python benchmarks/surface.py --baseline ../main   # also time the Voronoi kernel of another
                                            # checkout (e.g. before it moved into procgen.ca)

Voronoi runs as the core's generic ``ca.voronoi`` kernel (procgen.ca.propagation) on the cells'
CellGraph; ``ca.life`` (25/357, table reading) is timed on the same cells.
"""
from __future__ import annotations

import argparse
import importlib.util
import sys
import time
from pathlib import Path

import numpy as np
import trimesh

from procgen.ca import corrosion as cz
from procgen_surface.domain import SurfaceCells
from procgen_surface.primitives import cup
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
    ap.add_argument("--baseline", help="checkout whose Voronoi kernel is timed beside this one")
    args = ap.parse_args()
    scale = 0.1 if args.quick else 1.0

    # -- Voronoi: a 48-triangle cylinder (plate 4.1), ~250k cells ----------------------------
    cyl = trimesh.creation.cylinder(radius=1.0, height=2.2, sections=12)
    v, f = np.asarray(cyl.vertices), np.asarray(cyl.faces)
    sc, t_build = timed(SurfaceCells.from_mesh, v, f, target_cells=int(250_000 * scale))
    rng = np.random.default_rng(1)
    labels = place_seeds(sc.n_cells, 24, rng)
    print(f"cells      : {sc.n_cells:,} cells on {len(f)} triangles built in {t_build:.2f} s "
          f"({sc.n_cells / t_build:,.0f} cells/s)")
    runs = [("ca.voronoi", VoronoiGrowth)] + ([("baseline", baseline_growth(args.baseline))] if args.baseline else [])
    results = {}
    for _ in range(2):                        # alternate twice: both see the same machine load
        for tag, cls in runs:
            lab, steps, t = grow_to_full(cls, sc.graph, labels)
            results[tag] = (lab, steps, min(t, results.get(tag, (0, 0, np.inf))[2]))
    final, steps, t_vor = results["ca.voronoi"]
    print(f"voronoi    : {steps} steps to full coverage in {t_vor:.2f} s "
          f"({sc.n_cells * steps / t_vor:,.0f} cell updates/s), best of 2")
    if args.baseline:
        b_lab, b_steps, b_t = results["baseline"]
        print(f"  baseline ({args.baseline}): {b_steps} steps in {b_t:.2f} s "
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
    prm = cz.CorrosionParams()
    t0 = time.perf_counter()
    for k in range(args.steps):
        cz.corrosion_step(sc2.graph, st, prm, np.random.default_rng(k))
    t_pat = time.perf_counter() - t0
    cov = np.mean(st.status != cz.NORMAL)
    print(f"patina     : {args.steps} steps on {n:,} cells ({len(cf)} triangles, built in "
          f"{t_build2:.2f} s) in {t_pat:.2f} s ({n * args.steps / t_pat:,.0f} cell updates/s), "
          f"coverage {cov:.1%}")
    print(f"  {t_pat / 60:.2f} x the 60 s target, {1200 / t_pat:,.0f} x faster than the thesis (< 20 min)")

    # -- export: textured OBJ and GLB of the patinated cup -----------------------------------
    from procgen_surface.exporters import surface_glb, surface_obj
    from procgen_surface.rules import cell_colors
    from procgen.materials import parse_materials
    sc2.set_materials(parse_materials(["copper", "patina"]))
    sc2.add_field("layers__thickness", np.column_stack([st.consumable[:, 0], st.product]), at="cell")
    sc2.add_field("surface__rgb", cell_colors(sc2, "layers", lit=False, light=np.zeros(3),
                                              eye=np.zeros(3)), at="cell")
    files, t_obj = timed(surface_obj, sc2, stem="cup")
    glb, t_glb = timed(surface_glb, sc2)
    size = sum(len(b) for b in files.values()) / 1e6
    print(f"export     : OBJ+MTL+atlas {size:.1f} MB in {t_obj:.2f} s, GLB {len(glb) / 1e6:.1f} MB "
          f"in {t_glb:.2f} s")
    import resource
    print(f"peak memory: {resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024:,.0f} MB")


if __name__ == "__main__":
    main()
