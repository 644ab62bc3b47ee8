"""The one switch between numpy reference paths and their compiled (numba) kernels.

A per-step hot path (water drops, cell-automaton stepping, snaxel events) is written once in
numpy - the reference, and the only path without the ``fast`` extra - and once more as numba
kernels in a module of its own that imports numba at top level.  Such a module is imported only
through :func:`kernels`, so importing procgen or a plugin never loads numba
(tests/test_install.py).  Both paths give the same numbers (each kernel module says how exactly)
and CI runs the tests of both.

``accelerate``: True = the compiled kernels, or an InputError naming the missing extra;
False = numpy; None = the environment switch ``PROCGEN_ACCELERATE`` (``1``: like True, ``0``:
like False), else compiled when numba is installed and the workload is at least the path's
``min_work`` (importing numba and loading cached kernels costs ~0.5 s per process, so small
runs stay on numpy).

Threads: the kernels that update every cell independently run in parallel over numba's
threads (``NUMBA_NUM_THREADS``, default all cores; the result does not depend on the count).
Between two parallel regions numba's OpenMP threads wait as :func:`wait_policy` chooses (a
short spin, then sleep) unless the user chose, and local worker pools (gallery, sweep) give
each worker process an equal share of the cores (:func:`share_cores`), so no process's threads
wait for cores another one holds.
"""
from __future__ import annotations

import functools
import importlib
import importlib.util
import os
from types import ModuleType

from .errors import InputError

ENV = "PROCGEN_ACCELERATE"

SPIN_COUNT = 100_000
"""GNU OpenMP's spins before an idle thread sleeps (:func:`wait_policy`)."""
MIN_DROPS = 10_000
"""Drops from which ``accelerate=None`` takes the compiled water step."""
MIN_CELLS = 100_000
"""Cells from which ``accelerate=None`` takes the compiled cell-automaton steps."""
MIN_SNAXELS = 2_000
"""Chain length from which ``accelerate=None`` takes the compiled snaxel events."""
MIN_MICRO_PAIRS = 500_000
"""(crack piece, micro-cell) pairs from which ``accelerate=None`` takes the compiled crack
render scan (procgen_cracks.render_kernels)."""


def kernels(module: str, accelerate: bool | None = None, work: int = 0, min_work: int = 0
            ) -> ModuleType | None:
    """The kernel module ``module`` when the switch selects the compiled path, else None."""
    if accelerate is None:
        env = os.environ.get(ENV, "").strip().lower()
        if env in ("0", "false", "off", "no"):
            return None
        if env in ("1", "true", "on", "yes"):
            accelerate = True
        elif work < min_work:
            return None
    if accelerate is False:
        return None
    mod = _load(module)
    if mod is None and accelerate:
        raise InputError(f"accelerate = true needs numba (the 'fast' extra: pip install "
                         f"'procgen-rules[fast]'), which is not installed ({module})")
    return mod


def share_cores(processes: int) -> None:
    """Run in each of ``processes`` local worker processes before any kernel loads: numba's
    threads default to that worker's share of the cores (the user's ``NUMBA_NUM_THREADS`` wins).

    A parallel region waits for its slowest thread, so workers that each start a thread per core
    oversubscribe the machine and stall one another; an equal share keeps every core busy once.
    """
    share = max(1, (os.cpu_count() or 1) // max(1, processes))
    os.environ.setdefault("NUMBA_NUM_THREADS", str(share))


def wait_policy() -> None:
    """How numba's idle OpenMP threads wait for the next parallel region, unless the user said
    (``OMP_WAIT_POLICY``, ``GOMP_SPINCOUNT``, ``KMP_BLOCKTIME``): they spin for about a
    millisecond (GNU OpenMP: ``SPIN_COUNT`` spins; Intel's: 1 ms), then sleep.  Call before
    numba's threads start (the first kernel module to load does).

    Why: a compiled step runs several parallel regions with serial work between them (the water
    step seven, a sort between two).  On the 2-core virtual machine of benchmarks/ a region costs
    2 us when its threads spin and 70-140 us when they sleep (their wake-up), which cost the
    water step a sixth of its time while every idle thread slept at once
    (``OMP_WAIT_POLICY=PASSIVE``).  Spinning without bound (``ACTIVE``) would take a core from
    every other job for as long as the process lives; a millisecond bridges the gaps within and
    between steps, and GNU OpenMP spins less by itself when it has more threads than cores."""
    if "OMP_WAIT_POLICY" not in os.environ:
        os.environ.setdefault("GOMP_SPINCOUNT", str(SPIN_COUNT))
        os.environ.setdefault("KMP_BLOCKTIME", "1")


@functools.cache
def _load(module: str) -> ModuleType | None:
    if importlib.util.find_spec("numba") is None:
        return None
    wait_policy()
    return importlib.import_module(module)
