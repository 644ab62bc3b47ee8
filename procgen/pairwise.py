"""numpy's pairwise summation, for compiled (numba) kernels that must give np.sum's bits.

Why: ``np.sum`` (and ``np.add.reduce`` along a contiguous row) does not add left to right: below
8 terms it does, from 128 terms it splits the row in halves, and in between it keeps eight
running sums that it adds as ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7)) before the
leftover terms.  A kernel that mirrors a numpy path bit for bit must add in that order; this is
the one place that knows it.  Like every kernel helper it needs numba and is imported only by
kernel modules.
"""
from __future__ import annotations

from numba import njit


@njit(cache=True, nogil=True, inline="always")
def pairwise_sum(a, start, n):
    """a[start:start + n].sum() as numpy computes it, for n <= 128 (numpy's block size; larger
    rows recurse on halves there, which no kernel here needs).  The eight sums are scalars, so
    nothing is allocated (an allocation would slow every kernel it is inlined in)."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[start + i]
        return res
    r0, r1, r2, r3 = a[start], a[start + 1], a[start + 2], a[start + 3]
    r4, r5, r6, r7 = a[start + 4], a[start + 5], a[start + 6], a[start + 7]
    i = 8
    while i < n - (n % 8):
        b = start + i
        r0 += a[b]
        r1 += a[b + 1]
        r2 += a[b + 2]
        r3 += a[b + 3]
        r4 += a[b + 4]
        r5 += a[b + 5]
        r6 += a[b + 6]
        r7 += a[b + 7]
        i += 8
    res = ((r0 + r1) + (r2 + r3)) + ((r4 + r5) + (r6 + r7))
    while i < n:
        res += a[start + i]
        i += 1
    return res
