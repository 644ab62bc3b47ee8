"""Export time as a share of a recipe's run: steps vs every output, each timed apart.

Why: a mesh recipe should spend its time simulating, not formatting text or re-packing the same
texture atlas for every output format (issue 35: plate 5.10 and Fig. 4.16 exported for longer
than they ran).  The recipe's steps run once (``run`` without an output folder), then each
``[[outputs]]`` entry is rendered in turn through the runner's own ``render_output`` (bytes in
memory, nothing written) and timed, with the size of what it produced.

    python benchmarks/export_share.py meshes/plate-5-10 weathering/fig-4-16
    python benchmarks/export_share.py meshes/cup --json        # one JSON line per recipe

Run it on two checkouts (or before/after a change) to compare; the figures are wall times of
one run on whatever the machine is doing, so compare shares rather than seconds on a busy box
(the line ends with the 1-minute load average).  A module imported by the first output that
needs it (trimesh) is timed there.
"""
from __future__ import annotations

import argparse
import json
import os
import time

from procgen import PluginHost, get_plugin_manager, load_recipe, run
from procgen.runner import provenance, render_output


def measure(name: str, host: PluginHost) -> dict:
    recipe = load_recipe(name, host)
    t0 = time.perf_counter()
    res = run(recipe, host, progress=False)
    steps_s = time.perf_counter() - t0
    prov = provenance(recipe, recipe.seed, host)
    rows = []
    for spec in recipe.outputs:
        t = time.perf_counter()
        files = render_output(res.state, spec, host, prov)
        rows.append({"file": spec.file, "format": spec.format, "seconds": round(time.perf_counter() - t, 3),
                     "bytes": sum(len(b) for b in files.values())})
    export_s = sum(r["seconds"] for r in rows)
    return {"recipe": name, "steps_s": round(steps_s, 3), "export_s": round(export_s, 3),
            "load": round(os.getloadavg()[0], 2),
            "export_share": round(export_s / max(steps_s + export_s, 1e-9), 3), "outputs": rows}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("recipes", nargs="+", help="built-in recipe names or .toml paths")
    ap.add_argument("--json", action="store_true", help="one JSON line per recipe")
    args = ap.parse_args()
    host = get_plugin_manager()
    for name in args.recipes:
        rep = measure(name, host)
        if args.json:
            print(json.dumps(rep, sort_keys=True), flush=True)
            continue
        print(f"{name}: steps {rep['steps_s']:.2f} s, outputs {rep['export_s']:.2f} s "
              f"({100 * rep['export_share']:.0f} % of the run, "
              f"{rep['export_s'] / max(rep['steps_s'], 1e-9):.2f} x the steps' time; "
              f"load average {rep['load']:.1f})")
        for r in rep["outputs"]:
            print(f"    {r['seconds']:8.2f} s  {r['bytes'] / 1e6:8.2f} MB  {r['format']:<14} {r['file']}")


if __name__ == "__main__":
    main()
