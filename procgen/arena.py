"""Zeroed arrays carved from one allocation, so that Linux can back them with huge pages.

Why: a fresh array's memory is mapped on its first write, one page fault per 4 KiB page.  In
the KVM guest the benchmarks run on, a fault costs 6-8 us, so the first step of 50,000 water
drops on a 512 x 512 x 3 surface spent 40 of its 53 ms faulting in the surface's maps and the
compiled path's scratch, which are written sparsely and one at a time.  numpy asks the kernel
for transparent huge pages (``madvise``) for allocations of 4 MiB or more; arrays of 2-3 MiB each
get none.  Carved from one buffer whose start is aligned to 2 MiB, they share 2 MiB pages: one
fault per 2 MiB (a 24 MiB group written at 50,000 random places: 14 faults and 5 ms against
6,300 and 24 ms).  Where the kernel gives no huge pages (THP off, another OS) this is one
ordinary allocation.  The arrays are views: they keep the buffer alive, and a copy or a pickle
of one is an ordinary array.
"""
from __future__ import annotations

from typing import Sequence

import numpy as np

_HUGE = 2 << 20           # x86-64 huge page
_MADVISED = 4 << 20       # numpy asks for huge pages from this size on
_LINE = 64                # each array starts on a cache line


def zeros(specs: Sequence[tuple[tuple[int, ...] | int, type | np.dtype]]) -> list[np.ndarray]:
    """Zeroed C-contiguous arrays of the given (shape, dtype)s, sharing one buffer."""
    shapes = [(s,) if isinstance(s, (int, np.integer)) else tuple(s) for s, _ in specs]
    dtypes = [np.dtype(t) for _, t in specs]
    sizes = [int(np.prod(s, dtype=np.int64)) * t.itemsize for s, t in zip(shapes, dtypes)]
    offsets = np.concatenate(([0], np.cumsum([-(-b // _LINE) * _LINE for b in sizes])))
    total = int(offsets[-1])
    slack = _HUGE if total + _HUGE >= _MADVISED else _LINE
    buf = np.zeros(total + slack, np.uint8)          # (calloc: fresh pages, nothing written)
    start = -buf.ctypes.data % slack
    return [buf[start + o: start + o + b].view(t).reshape(s)
            for o, b, s, t in zip(offsets[:-1].tolist(), sizes, shapes, dtypes)]
