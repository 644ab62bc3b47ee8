"""numpy path vs compiled path of one workload, each in its own child process (own peak RSS).

A benchmark calls :func:`compare` with its workload names; for every name it starts itself
again as ``script --path P --part NAME`` for P in numpy / compiled / limit, one after the other
in the same run (so the machine's load hits all of them alike), and prints one table row:
workload, numpy time, compiled time, ratio, the trivial-kernel limit, the distance of the
compiled path from it, and each child's peak RSS.  A child measures with :func:`report`; where
both paths' children report a ``hash`` of their results, the run fails unless the hashes agree.
"""
from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys

PATHS = ("numpy", "compiled", "limit")


def add_arguments(ap: argparse.ArgumentParser) -> None:
    ap.add_argument("--path", choices=PATHS, help=argparse.SUPPRESS)
    ap.add_argument("--part", default="", help=argparse.SUPPRESS)


def report(**figures) -> None:
    """Child side: print the figures and this process's peak RSS as one JSON line."""
    figures["peak_rss"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024   # Linux: KiB
    print("@@" + json.dumps(figures), flush=True)


def _child(argv: list[str], path: str, part: str) -> dict:
    out = subprocess.run([sys.executable, sys.argv[0], *argv, "--path", path, "--part", part],
                         capture_output=True, text=True)
    lines = [ln for ln in out.stdout.splitlines() if ln.startswith("@@")]
    if out.returncode or not lines:
        sys.stderr.write(out.stdout + out.stderr)
        raise SystemExit(f"{path} child of {part} failed")
    return json.loads(lines[-1][2:])


def load() -> str:
    one, five, _ = os.getloadavg()
    return f"load average {one:.1f} (1 min) / {five:.1f} (5 min) on {os.cpu_count()} cores"


def compare(parts: list[tuple[str, str]], argv: list[str], rounds: int = 2) -> list[dict]:
    """Run every (part, workload text) on the three paths; print and return the rows.  Each
    child reports ``seconds`` (per unit of work, named in the workload text) and may add more
    figures (identity checksums, warm-up time, bytes), printed under the table.  The paths run
    ``rounds`` times in turn; each keeps its fastest child (the machine is shared)."""
    print(f"machine: {load()} (before)")
    rows = []
    for part, text in parts:
        r: dict = {}
        for _ in range(rounds):          # alternate the paths: each sees the same machine load
            for p in PATHS:
                f = _child(argv, p, part)
                if p not in r or f["seconds"] < r[p]["seconds"]:
                    r[p] = f
        rows.append({"part": part, "workload": text, **r})
    print(f"machine: {load()} (after)")
    mib = 2 ** 20
    w = max(len(r["workload"]) for r in rows)
    print(f"\n{'workload':<{w}} {'numpy':>7} {'compiled':>8} {'ratio':>7} {'limit':>7} "
          f"{'to limit':>8} {'RSS numpy':>9} {'RSS compiled':>12}")
    for r in rows:
        n, c, lim = r["numpy"]["seconds"], r["compiled"]["seconds"], r["limit"]["seconds"]
        print(f"{r['workload']:<{w}} {_t(n)} {_t(c):>8} {n / c:6.1f}x {_t(lim)} {c / lim:7.1f}x "
              f"{r['numpy']['peak_rss'] / mib:6.0f} MiB {r['compiled']['peak_rss'] / mib:9.0f} MiB")
    for r in rows:
        c = r["compiled"]
        extra = {k: v for k, v in c.items() if k not in ("seconds", "peak_rss")}
        print(f"  {r['part']}: compiled-path details {json.dumps(extra)}; "
              f"numpy details {json.dumps({k: v for k, v in r['numpy'].items() if k not in ('seconds', 'peak_rss')})}")
    differ = [r["part"] for r in rows if "hash" in r["compiled"] and r["compiled"]["hash"] != r["numpy"]["hash"]]
    hashed = sum("hash" in r["compiled"] for r in rows)
    if differ:
        raise SystemExit(f"the numpy and compiled paths' results differ: {', '.join(differ)}")
    if hashed:
        print(f"both paths' results are identical (hashes agree) in {hashed} of {len(rows)} workloads")
    return rows


def _t(seconds: float) -> str:
    """A per-unit time with an SI prefix, 7 characters."""
    for scale, unit in ((1e-9, "ns"), (1e-6, "us"), (1e-3, "ms"), (1.0, "s ")):
        if seconds < 1000 * scale:
            return f"{seconds / scale:5.1f}{unit}"
    return f"{seconds:5.0f}s "
