"""Benchmark: the Figure 4.2(e) cloud grown on an eager and on a lazily tiled tessellation (issue 15).

Side by side, in one run, each configuration in a fresh process (so peak memory is its own):

* eager: the thesis's way (section 3.1), points.poisson_disk + mesh.delaunay over the whole
  2000 x 2000 domain, then snaxel.grow on that mesh (the baseline);
* lazy 2000 / lazy 8000: snaxel.grow making Poisson-disk Delaunay tiles only where the cloud
  grows, on a 2000 and an 8000 px domain, source at (1000, 1000) in both, so the two clouds
  are the same and only the domain differs (the outlines are compared byte for byte).

Prints wall and CPU seconds of the whole run (CPU seconds are the steadier figure on a shared
machine), cold (first run in the process: imports and numba's cached tile and event kernels loaded) and
warm (the same run again in the process, as every later cloud of a sweep or gallery run), steps,
N_v (vertices made), N_s, tiles, the tile sampler and peak RSS, then the ratios eager/lazy
(target >= 3) and lazy 8000/lazy 2000 (target <= 1.1).

    python benchmarks/clouds.py [--seeds 1 2] [--radius 4]
    python benchmarks/clouds.py --paths [--size 400] [--steps 1500]

``--paths`` instead prints the snaxel event handling on the numpy path, the compiled path and
a trivial kernel, their ratio, the distance to the limit and peak RSS (benchmarks/snaxel_events.py,
issue 16), so the cloud benchmarks print those figures too.
"""
from __future__ import annotations

import argparse
import resource
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

EAGER = """
[recipe]
name = "fig-4-2e-eager"
seed = 1

[[steps]]
rule = "points.poisson_disk"
params = {{ domain = "points", width = {size}, height = {size}, radius = {radius} }}

[[steps]]
rule = "mesh.delaunay"
params = {{ points = "points", mesh = "tessellation" }}

[[steps]]
rule = "snaxel.grow"
until = "stable"
max_iterations = 40000
[steps.params]
mesh = "tessellation"
bounds = [0.0, 0.0, {size}, {size}]
source = [1000.0, 1000.0]
v_min = 5.0
v_max = 30.0
t_min = 0.0
t_max = 150.0
g_min = 240.0
g_max = 250.0
n_c = 7
table = [[0, 50, 400], [50, 150, 1000], [150, 200, 1500], [200, 25]]
"""


def one(kind: str, size: float, seed: int, radius: float) -> dict:
    """Run one configuration twice in this fresh process: cold (imports, numba's cached kernels
    loaded on first use) then warm (as every later cloud of a sweep, a cloudscape or a gallery
    run). Wall and CPU seconds of the run, reports, outline bytes and peak RSS (MB)."""
    from procgen import get_plugin_manager, run
    from procgen.recipes import load_recipe

    host = get_plugin_manager()
    out: dict = {"kind": kind, "size": size, "seed": seed}
    for label in ("cold", "warm"):
        with tempfile.TemporaryDirectory() as tmp:
            if kind == "eager":
                p = Path(tmp) / "eager.toml"
                p.write_text(EAGER.format(size=size, radius=radius))
                rec = load_recipe(p, host)
            else:
                rec = load_recipe("clouds/fig-4-2e", host, [f"steps.grow.params.radius={radius}",
                                                           f"steps.grow.params.bounds=[0.0, 0.0, {size}, {size}]",
                                                           "steps.grow.params.source=[1000.0, 1000.0]"])
            rec.outputs.clear()
            t0, c0 = time.perf_counter(), time.process_time()
            res = run(rec, host, seed=seed, progress=False, out_dir=Path(tmp) / "out")
            out[label] = (time.perf_counter() - t0, time.process_time() - c0)
        outline = res.state.get("cloud").points.tobytes()
        assert out.setdefault("outline", outline) == outline, "same recipe and seed, other outline"
    rep = res.state.reports
    out.update(steps=rep["cloud.steps"], N_v=rep["N_v"], N_s=rep["N_s"], tiles=rep.get("cloud.tiles", 0),
               sampler=rep.get("cloud.tile_sampler", "-"),
               rss=resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024)
    return out


def main() -> None:
    if "--paths" in sys.argv or "--path" in sys.argv:    # (its children come back here too)
        import snaxel_events
        if "--paths" in sys.argv:
            sys.argv.remove("--paths")
        return snaxel_events.main()
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[1, 2])
    ap.add_argument("--radius", type=float, default=4.0)
    args = ap.parse_args()
    configs = [("eager", 2000.0), ("lazy", 2000.0), ("lazy", 8000.0)]
    print(f"Figure 4.2(e), Poisson radius {args.radius:g}, source (1000, 1000); each config in a fresh process, "
          "run cold then warm; wall s / CPU s")
    print(f"{'config':>12} {'seed':>4} {'cold wall':>9} {'cold CPU':>8} {'warm wall':>9} {'warm CPU':>8} {'steps':>6} "
          f"{'N_v':>7} {'N_s':>6} {'tiles':>6} {'sampler':>7} {'peak MB':>8}")
    rows: dict[tuple[str, float], list[dict]] = {c: [] for c in configs}
    for seed in args.seeds:
        for kind, size in configs:
            with ProcessPoolExecutor(max_workers=1) as pool:
                r = pool.submit(one, kind, size, seed, args.radius).result()
            rows[(kind, size)].append(r)
            print(f"{kind + ' ' + str(int(size)):>12} {seed:>4} {r['cold'][0]:9.2f} {r['cold'][1]:8.2f} "
                  f"{r['warm'][0]:9.2f} {r['warm'][1]:8.2f} {r['steps']:>6} {r['N_v']:>7} {r['N_s']:>6} "
                  f"{r['tiles']:>6} {r['sampler']:>7} {r['rss']:8.0f}")
        same = rows[("lazy", 2000.0)][-1]["outline"] == rows[("lazy", 8000.0)][-1]["outline"]
        print(f"{'':>12} seed {seed}: lazy 2000 and lazy 8000 outlines byte-identical: {same}")

    def mean(kind: str, size: float, label: str, k: int) -> float:
        return float(np.mean([r[label][k] for r in rows[(kind, size)]]))

    for label in ("cold", "warm"):
        for k, unit in ((0, "wall"), (1, "CPU")):
            eager, lazy, big = (mean(kind, size, label, k) for kind, size in configs)
            print(f"{label} {unit}: eager {eager:.2f} s, lazy 2000 {lazy:.2f} s, lazy 8000 {big:.2f} s; "
                  f"eager / lazy = {eager / lazy:.2f} (target >= 3); lazy 8000 / lazy 2000 = {big / lazy:.2f} "
                  "(target <= 1.1)")


if __name__ == "__main__":
    main()
