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
On a shared or oversubscribed machine, busy-waiting OpenMP threads steal the time of the
others, so unless the user set it, ``OMP_WAIT_POLICY`` is made ``PASSIVE`` (idle threads
sleep) before the first kernel module loads, and local worker pools (gallery, sweep) give each
worker process an equal share of the cores (:func:`share_cores`).
"""
from __future__ import annotations

import functools
import importlib
import importlib.util
import os
from types import ModuleType

from .errors import InputError

ENV = "PROCGEN_ACCELERATE"

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


@functools.cache
def _load(module: str) -> ModuleType | None:
    if importlib.util.find_spec("numba") is None:
        return None
    os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
    return importlib.import_module(module)
