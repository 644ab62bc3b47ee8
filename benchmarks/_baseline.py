"""Run the previous version of a benchmark script, in the same run, for side-by-side figures.

``--baseline PYTHON`` names an interpreter that has the previous code installed (e.g. a scratch
venv with the last release or main: ``/work/venv-main/bin/python``); the script it runs is this
benchmark as it was at ``--baseline-rev`` (git), so both print the same figures.
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def add_arguments(ap) -> None:
    ap.add_argument("--baseline", metavar="PYTHON", default="",
                    help="interpreter with the previous code installed: run its version of this benchmark too")
    ap.add_argument("--baseline-rev", default="main", help="git revision of the previous benchmark script")


def run_previous(script: str, python: str, rev: str, argv: list[str]) -> None:
    """Print the previous version's output of ``benchmarks/<script>`` under ``python``."""
    if not python:
        return
    src = subprocess.run(["git", "-C", str(ROOT), "show", f"{rev}:benchmarks/{script}"],
                         capture_output=True, text=True, check=True).stdout
    print(f"--- previous code ({rev}, {python}) ---", flush=True)
    out = subprocess.run([python, "-", *argv], input=src, text=True, capture_output=True, cwd="/")
    sys.stdout.write(out.stdout + out.stderr)
