"""Where an export's time goes: run a recipe's steps once, then profile each output apart.

Why: benchmarks/export_share.py says how long each output takes; this says in which functions
(cProfile, cumulative time, the top ``--top`` rows per output), to find what to make faster.

    python benchmarks/profile_export.py meshes/plate-5-10 --only crack_glb crack_png
"""
from __future__ import annotations

import argparse
import cProfile
import io
import pstats
import time

from procgen import get_plugin_manager, load_recipe, run
from procgen.runner import provenance, render_output


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recipe")
    ap.add_argument("--only", nargs="*", default=[], help="formats to profile (default: all)")
    ap.add_argument("--top", type=int, default=25)
    ap.add_argument("--set", action="append", default=[], help="recipe overrides, as procgen run --set")
    args = ap.parse_args()
    host = get_plugin_manager()
    recipe = load_recipe(args.recipe, host, args.set)
    t0 = time.perf_counter()
    res = run(recipe, host, progress=False)
    print(f"steps {time.perf_counter() - t0:.2f} s")
    prov = provenance(recipe, recipe.seed, host)
    for spec in recipe.outputs:
        if args.only and spec.format not in args.only:
            continue
        prof = cProfile.Profile()
        t = time.perf_counter()
        prof.enable()
        render_output(res.state, spec, host, prov)
        prof.disable()
        print(f"\n=== {spec.format} {spec.file}: {time.perf_counter() - t:.2f} s")
        buf = io.StringIO()
        pstats.Stats(prof, stream=buf).sort_stats("cumulative").print_stats(args.top)
        print("\n".join(line for line in buf.getvalue().splitlines()[6:] if line.strip()))


if __name__ == "__main__":
    main()
