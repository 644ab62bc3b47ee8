"""Peeling speed (3DSCA thesis 5.3.2, Figure 5.28): ~1.8 M surface cells, groups, levels, order.

The thesis's peeling-group determination on about 1.8 million cells converged (99.9 %) in 28
steps and about 11 minutes (SGI Indigo2, R10000 175 MHz).  This script builds a 3DSCA lattice
of about that many cells with a paint layer and an imposed crack network (``cracks.imposed``),
then times

* the ``cracks.peel`` rule end to end: analysis + one iteration per level pass + one iteration
  per peeling step, each publishing its fields (the project target: under 30 s);
* its analysis alone (:func:`procgen_cracks.peel.plan_peeling`: scipy csgraph components and
  multi-source BFS on the CSR graph);
* in the same run, the baseline the thesis describes and rejects as "very long to stabilize"
  (SCA-Function 5.2): every peeling cell takes the smallest id among its peeling neighbours,
  synchronously, until no id changes - vectorised, but one pass per ring of the widest group.
  Its labels are checked against the components.

Prints the cell count, times, passes, ratios and the peak resident memory.

    python benchmarks/peeling.py            # ~1.8 M cells
    python benchmarks/peeling.py --quick    # ~180 k cells
"""
from __future__ import annotations

import argparse
import resource
import time

import numpy as np

from procgen import State, TriMesh
from procgen.testing import drive_rule
from procgen_cracks.imposed import ImposedCracks
from procgen_cracks.peel import Peel, plan_peeling, sharp_links
from procgen_layers.rules import StackLayers
from procgen_surface.domain import SurfaceCells
from procgen_surface.primitives import lattice

THESIS_SECONDS, THESIS_CELLS, THESIS_STEPS, TARGET_SECONDS = 11 * 60, 1.8e6, 28, 30.0


def peak_rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0


def min_id_ca(graph, inside: np.ndarray, keep: np.ndarray, max_passes: int) -> tuple[np.ndarray, int]:
    """SCA-Function 5.2: synchronous smallest-id exchange between peeling neighbours until stable."""
    r, c = graph.rows, graph.indices
    e = inside[r] & inside[c] & keep
    r, c = r[e], c[e]
    ids = np.where(inside, np.arange(graph.n_cells), -1)
    for k in range(1, max_passes + 1):
        new = ids.copy()
        np.minimum.at(new, r, ids[c])
        np.minimum.at(new, c, ids[r])           # links read both ways, as the components do
        if np.array_equal(new, ids):
            return ids, k
        ids = new
    return ids, max_passes


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a tenth of the cells")
    ap.add_argument("--max-passes", type=int, default=150, help="cap on the baseline's passes")
    a = ap.parse_args()
    target = int(THESIS_CELLS / (10 if a.quick else 1))

    t0 = time.perf_counter()
    v, f = lattice((3, 3, 1), 3, 2.0)
    sc = SurfaceCells.from_mesh(v, f, target_cells=target)
    t_cells = time.perf_counter() - t0
    st = State(seed=1)
    st.add_domain("mesh", TriMesh(v, f))
    st.add_domain("cells", sc)
    st.iteration = 0
    t0 = time.perf_counter()
    StackLayers(layers=["copper", {"preset": "paint", "thickness": 0.5}]).step(st)
    ImposedCracks(seeds=int(1200 * target / THESIS_CELLS) + 20, gaps=0.1).step(st)
    t_setup = time.perf_counter() - t0
    print(f"cells: {sc.n_cells:,} on a {len(f)}-triangle lattice (built in {t_cells:.1f} s; "
          f"stack + imposed cracks {t_setup:.1f} s)")

    # the rule end to end: analysis, level passes, peeling steps
    rule = Peel()
    t0, c0 = time.perf_counter(), time.process_time()
    it = drive_rule(rule, st)
    t_rule, c_rule = time.perf_counter() - t0, time.process_time() - c0
    p = rule._plan
    paint = sc["layers__thickness"][:, 1]
    print(f"cracks.peel: {t_rule:.2f} s wall ({c_rule:.2f} s CPU: on a shared machine the wall time "
          f"includes waiting) for {it} iterations ({p.passes} level passes + "
          f"{p.n_steps} peeling steps), {int((p.depth > 0).sum()):,} groups, "
          f"paint left {float(paint.max()):.3g}")
    print(f"  thesis: {THESIS_STEPS} passes, ~{THESIS_SECONDS // 60} min for 1.8 M cells -> "
          f"x{THESIS_SECONDS * sc.n_cells / THESIS_CELLS / t_rule:,.0f} (wall, scaled to this cell count); "
          f"target {TARGET_SECONDS:.0f} s: {'met' if t_rule < TARGET_SECONDS else 'MISSED'} (wall), "
          f"{'met' if c_rule < TARGET_SECONDS else 'MISSED'} (CPU)")

    # analysis alone, and the plain-CA baseline on the same inputs
    graph = sc.cell_graph("von_neumann")
    width = sc["crack__width"][:, 1]
    keep = ~sharp_links(sc, graph, 30.0)
    t0 = time.process_time()
    plan = plan_peeling(graph, width > 0, np.ones(sc.n_cells, bool), keep)
    t_plan = time.process_time() - t0
    inside = width <= 0
    t0 = time.process_time()
    ids, passes = min_id_ca(graph, inside, keep, a.max_passes)
    t_ca = time.process_time() - t0
    same = len(np.unique(ids[inside])) == int(plan.group.max()) + 1
    print(f"analysis (components + BFS levels + order): {t_plan:.2f} s CPU")
    print(f"baseline min-id CA (SCA-Function 5.2): {t_ca:.2f} s CPU, {passes} passes"
          f"{' (capped: not converged, the ratio is a lower bound)' if passes >= a.max_passes else ''}, "
          f"same groups: {same} -> analysis x{t_ca / t_plan:.1f} faster")
    print(f"peak RSS: {peak_rss_mb():,.0f} MB")


if __name__ == "__main__":
    main()
