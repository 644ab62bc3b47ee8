"""Wood weathering speed: the thesis's final run, 432 steps of 25/2356 on ~390,000 bunny cells.

The thesis (Pentium D 2.66 GHz, 2007) took "less than 7 minutes" for its Fig. 4.16 run of 432
steps on 389,942 cells; the project target is 15 s here.  Prints absolute times, cell updates
per second, the ratio to the thesis, a baseline in the same run (a plain numpy Life by array
rolls on a torus grid of the same cell count), and the peak resident memory.  Also times the
grain texture, texgen, palette + composition, and the sun/rain exposure ray casts.

    python benchmarks/wood.py            # full size (~390,000 cells)
    python benchmarks/wood.py --quick    # a tenth of the cells
"""
from __future__ import annotations

import argparse
import resource
import time

import numpy as np

from procgen.builtin.meshes import clean_mesh, load_mesh_file, resolve_mesh_path
from procgen.ca.lifelike import life_step, next_age, parse_rule
from procgen_surface.domain import SurfaceCells
from procgen_wood import exposure as ex
from procgen_wood.compose import compose
from procgen_wood.grain import wood_texture
from procgen_wood.palette import THRESHOLDS, default_colors, palette_colors
from procgen_wood.texgen import sample_bilinear, texture_coordinates

THESIS_SECONDS = 7 * 60
TARGET_SECONDS = 15.0
STEPS = 432


def timed(fn, *a, **k):
    t = time.perf_counter()
    out = fn(*a, **k)
    return out, time.perf_counter() - t


def run_life(graph, n: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    lut = parse_rule("25/2356", "table").lut(int(graph.degree.max()))
    alive = rng.random(n) < 0.01
    ever = alive.copy()
    age = np.where(alive, rng.integers(1, 21, n), 0).astype(np.int32)
    for _ in range(STEPS):
        alive = life_step(graph, alive, lut)
        ever |= alive
        age = next_age(age, alive, ever, "cumulative")
    return alive, age


def roll_life(side: int, rng: np.random.Generator) -> np.ndarray:
    """Baseline: a plain numpy outer-totalistic step by eight array rolls (torus)."""
    lut = parse_rule("25/2356", "table").lut()
    a = rng.random((side, side)) < 0.01
    for _ in range(STEPS):
        cnt = sum(np.roll(np.roll(a, dy, 0), dx, 1).astype(np.int8)
                  for dy in (-1, 0, 1) for dx in (-1, 0, 1) if dy or dx)
        a = lut[cnt, a.astype(np.intp)]
    return a


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="a tenth of the cells")
    args = ap.parse_args()
    target = 39_000 if args.quick else 390_000
    rng = np.random.default_rng(1)
    mesh = clean_mesh(load_mesh_file(resolve_mesh_path("bunny-4k.obj", None)))
    v, f = mesh.vertices, mesh.faces
    v = (v - (v.min(0) + v.max(0)) / 2) / float(np.ptp(v, axis=0).max())
    sc, t_build = timed(SurfaceCells.from_mesh, v, f, target_cells=target)
    n = sc.n_cells
    print(f"cells: {n:,} on {len(f):,} bunny triangles ({n / len(f):.1f} per triangle; thesis 389,942 "
          f"on 4,968), built in {t_build:.2f} s")
    (alive, age), t_life = timed(run_life, sc.graph, n, rng)
    ups = n * STEPS / t_life
    print(f"ca.life 25/2356, {STEPS} steps: {t_life:.2f} s = {ups / 1e6:.1f} M cell updates/s; "
          f"live {alive.mean():.3f}, mean value {age.mean():.0f}")
    side = int(round(np.sqrt(n)))
    _, t_roll = timed(roll_life, side, np.random.default_rng(1))
    print(f"baseline numpy-roll Life on a {side} x {side} torus, {STEPS} steps: {t_roll:.2f} s "
          f"(ours / baseline time = {t_life / t_roll:.2f})")
    img, t_tex = timed(wood_texture, 256, 256)
    st, t_map = timed(lambda: sample_bilinear(img / 255.0, texture_coordinates(sc.center3d, sc.normal)))
    cols = np.asarray(default_colors(), float)
    out, t_pal = timed(lambda: compose(st, palette_colors(age, THRESHOLDS, cols), age, blend="lerp",
                                       fresh=cols[0] / 255))
    print(f"grain 256^2 {t_tex:.2f} s, texgen + sampling {t_map:.2f} s, palette + lerp {t_pal:.2f} s")
    total = t_build + t_life + t_tex + t_map + t_pal
    print(f"build + 432 steps + colour: {total:.1f} s (target {TARGET_SECONDS:.0f} s; thesis < "
          f"{THESIS_SECONDS} s, {THESIS_SECONDS / total:.0f}x faster)")
    up, south = np.array([0, 1.0, 0]), np.array([0, 0, 1.0])
    try:
        rays = ex.intersector(sc.vertices, sc.faces)
    except Exception as exc:                                # no ray engine installed
        print(f"exposure: skipped ({exc})")
    else:
        dirs = np.vstack([ex.sun_directions(12, 45.0, up, south), ex.cone_directions(16, 25.0, up)])
        n_rays = int(sum(np.count_nonzero(sc.normal @ d > 0) for d in dirs))
        _, t_exp = timed(ex.exposure, sc.center3d, sc.normal, dirs, rays=rays)
        print(f"exposure ({type(rays).__module__.rsplit('.', 1)[-1]}): {len(dirs)} directions, "
              f"{n_rays:,} rays in {t_exp:.2f} s = {n_rays / t_exp / 1e6:.2f} M rays/s")
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"peak resident memory: {peak:.0f} MiB")


if __name__ == "__main__":
    main()
