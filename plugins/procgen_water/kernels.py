"""Compiled (numba) water-drop step: the same batch semantics as ``particles.step``, in loops.

Why: the numpy step spends ~1.7 us per drop-step in temporaries and gathers, and a compiled
loop that visits the drops in a random order reads the grid at random (a few cache misses per
drop, ~250 ns on this machine).  Both paths keep the drops in cell order (the order every step
returns, :meth:`particles.Drops.in_cell_order`), so here each step is one compiled call that
walks the grid and the drops front to back: the drops are moved (read from the caller's
arrays in their order: the last step's cell order, plus any drops appended since), placed in
their new cell order into a packed buffer (one 64-byte float row and one 20-byte int row per
drop; a counting sort, skipped when no drop left the grid or now sits before its
predecessor's cell; a drop at rest is packed there straight from the caller's arrays),
interact there, and the survivors are written back into the caller's arrays front to back.
Imported only through :func:`procgen.accel.kernels` (needs numba).

Same numbers, bit for bit: the phases of ``particles.step`` run one after the other over all
drops (move, drain, absorb + deposit, erode, deposit beyond capacity, lay and remove the empty
drops, evaporate), each expression is evaluated in the same order, and every ``np.bincount``
becomes an accumulator summing the same terms in the same order from 0 before adding the total
to its target (tests/test_water_kernels.py checks array equality on all three footprints, 1
and 2 threads).  With the one-cell footprint a key (cell, layer) only hears the drops of its own
cell, and the stable sort keeps them in drop order, so sorting by cell changes no sum; the wider
footprints (a key hears drops of several cells) interact in drop order and are sorted by cell
afterwards, as numpy's ``in_cell_order`` does.  The surface gradient is evaluated where needed
from a start-of-step height buffer (``np.gradient``'s formulas).  The release of excess water
runs first, as in ``particles.step``, in the pass that computes that height; when the caller
says the step is ``continued`` (nothing else wrote the surface since this path's last step on
it) and that step had the one-cell footprint, only the cells its drops were in are refreshed:
elsewhere the layers did not change and the water only evaporated.  With the one-cell
footprint a cell's water is final once its drops have interacted (absorption wets only a
drop's own cell), so the cells without drops evaporate in a grid pass before the interaction
and the drops' cells at the end of their interaction, while their rows are in cache (with the
budgets the grid pass left them: it has their heights in cache).  Once fewer than a third of
the cells hold water or a drop, that pass lists them, and the continued steps after it visit
only the listed cells and the drops' cells (merged in cell order), listing those that stay wet:
a dry cell without a drop stays dry.  A power-of-two spacing's divisions are multiplications by
its exact inverse (``_div``: the same bits).

Speed (a loop like this one mostly waits for memory and for mispredicted branches): the
footprint, whether drops have a sediment capacity and the layer count are tuple-length tags, so
numba compiles each combination on its own, the others' branches vanish from the interaction (a
third faster) and the layer loops unroll; the interaction walks a list of the occupied cells'
first drops and prefetches (procgen.prefetch) the grid lines of the cell ``_AHEAD`` cells on,
the move those of the drop ``_AHEAD`` drops on if it moves: the occupied cells are sorted but
sparse, a pattern the hardware does not guess.  The one-cell footprint's interaction is one loop
with its phases written out: numba often increfs and decrefs (atomic calls) the arrays an
inlined helper with branches receives, at each call (check the assembly for NRT_incref), which
cost that loop about 40% of its time.

Threads (numba's, see procgen.accel): the grid passes run in chunks of cells or rows, the drops'
move and placing in chunks of drops, and with the one-cell footprint the interaction in chunks
of whole cells (each with its own key rows and scratch), each chunk writing its drops back while
they are in cache (then the chunks close up), the counting sort in bands of keys; every number
belongs to one cell or one drop, so the result does not depend on the thread count.  The drain
and the wider footprints' interaction stay serial.

Memory: per cell the height, a 4-byte counting-sort slot and two 4-byte wet-cell lists (this
step's, the next's), and with a footprint wider than one cell per (cell, layer) key one 32-byte
row (sum, value, phase stamp, deposit sum), all allocated once per Surface; per thread a cell's
key rows, 128 bytes from the next thread's (a cache line both threads wrote at every cell cost
the step about 4%); per drop two packed rows in each of two buffers and the pair scratch, grown
geometrically: a step allocates nothing (``bytes_per_cell``, ``Work.bytes_per_drop``).  Each
group is one allocation (:mod:`procgen.arena`), and so are the Surface's maps, which the drops
write sparsely: the first step on a fresh 512 x 512 x 3 surface faulted in 6,300 pages of 4 KiB
at 6-8 us each in the benchmark's virtual machine (53 ms, the step itself 12 ms); with huge
pages 16-47 ms.  The drain sorts its few (cell, drop) keys instead of summing into grid-sized
key rows, whose pages along the grid's edges it was the first to touch.

The drop's radius is :func:`procgen.portable.cbrt` and every length sqrt(x^2 + y^2), on both
paths: IEEE-754 fixes those operations to the bit, where libm's ``cbrt`` and ``hypot`` were
function calls (each made the compiled code save and restore every live floating-point
register) and ``np.cbrt`` is not libm's on AVX-512 machines.
"""
from __future__ import annotations

import math

import numpy as np
import numba
from numba import njit, prange

from procgen import arena, portable
from procgen.pairwise import pairwise_sum
from procgen.prefetch import prefetch

from . import particles as P

_FOOTPRINTS = {"cell": 0, "bilinear": 1, "disc": 2}
_ATTR = "_drop_kernel_work"
_MIN_CHUNK = 2048          # drops per thread below which the interaction runs on fewer threads
_AHEAD = 8                 # occupied cells (interaction) / drops (move) whose lines are prefetched
_SPARSE = 3.0              # evaporation visits the listed wet cells if fewer than 1 / _SPARSE

# a drop's packed rows: floats (64 bytes) and int32s (20 bytes; KIND..AGE are the Drops fields,
# CELL / TOP per-step scratch)
X, Y, VX, VY, VOL, SED, SPD, DH = range(8)
KIND, MOV, AGE, CELL, TOP = range(5)
_NF, _NI = 8, 5


class Work:
    """Scratch reused by every compiled step on one Surface: the start-of-step height, the
    counting-sort slots, the wet-cell lists, per thread one grid row's occupied flags,
    evaporation budgets and tiled capacities, and per-drop / per-pair arrays grown geometrically
    with the drop count, each group carved from one allocation (:mod:`procgen.arena`: huge
    pages).  With a wider footprint than one cell, also per key (cell, layer) one 32-byte row
    (sum, value, phase stamp, deposit sum); the one-cell footprint keeps its key rows per
    thread (``cell_sk``) and needs none."""

    def __init__(self, ncell: int, n_layers: int, nx: int, keyed: bool) -> None:
        self.ncell, self.n_layers, self.nx = ncell, n_layers, nx
        self.sk = np.zeros((ncell * n_layers if keyed else 0, 4))
        threads = numba.config.NUMBA_NUM_THREADS            # the most a step can use
        (self.h, self.counts, self.wet, self.wout, self.occs, self.bufs) = arena.zeros([
            (ncell, np.float64),
            (ncell + 1, np.int32),
            (ncell, np.int32),                    # the cells that may hold water, in order ...
            (ncell, np.int32),                    # ... and the next step's list
            ((threads, nx), np.int32),            # per thread: a row's occupied cells
            ((threads, (n_layers + 1) * nx), np.float64)])   # per thread: budgets, capacities
        # per thread: one cell's key rows, 128 bytes apart (no line shared: written per cell)
        self.cell_sk = np.zeros((threads, n_layers + 4, 4))
        self.stamps = np.zeros(1)                           # sk's phase stamp
        self.chunks = np.empty(threads + 1, np.int64)       # per thread: its first packed drop
        self.kept = np.empty(threads + 1, np.int64)         # per thread: drops kept; sort band
        self.occupied = np.full(1, -1, np.int64)  # cells the last step's drops were in (-1: unknown)
        self.nwet = np.full(1, -1, np.int64)      # the wet-cell list's length (-1: unknown)
        self.wseg = np.zeros((threads, 2), np.int64)   # per thread: its part of wout (first, count)
        self.current_at = -1                      # Surface.steps at which h is current
        self.cap = 0
        self.pcap = 0
        self.grow(1024, 1)

    def fits(self, s: "P.Surface", keyed: bool) -> bool:
        return ((self.ncell, self.n_layers, self.nx) == (s.ncell, s.n_layers, s.shape[1])
                and (self.sk.shape[0] > 0 or not keyed))

    def grow(self, n: int, k: int) -> None:
        if n <= self.cap and n * k <= self.pcap:
            return
        self.occupied[0] = -1                     # (the last step's cell list is in ib / starts)
        self.cap = max(n, 2 * self.cap)
        self.pcap = self.cap * max(k, 4)
        (self.fa, self.ia, self.fb, self.ib, self.rk, self.starts, self.obud, self.ent,
         self.pairs, self.pkey, self.touched, self.dtouched) = arena.zeros([
            ((self.cap, _NF), np.float64),        # packed drops, sorted by start cell
            ((self.cap, _NI), np.int32),
            ((self.cap, _NF), np.float64),        # packed drops, sorted by end cell
            ((self.cap, _NI), np.int32),
            ((self.cap, 2), np.int32),            # per drop index: sort key, slot
            (self.cap + 1, np.int32),             # per occupied cell: its first drop
            (self.cap, np.float64),               # per occupied cell: its evaporation budget
            ((self.cap + 1, 4), np.int64),        # per entry: drop, first pair, layer, key
            ((self.pcap, 2), np.float64),         # per pair: footprint weight, demand
            (self.pcap, np.int64),                # per pair: cell, then key
            (self.pcap, np.int64),
            (self.pcap, np.int64)])

    def _drop_arrays(self):
        return (self.fa, self.ia, self.fb, self.ib, self.rk, self.starts, self.obud, self.ent)

    @property
    def grid_bytes(self) -> int:
        return sum(a.nbytes for a in (self.sk, self.h, self.counts, self.wet, self.wout))

    @property
    def bytes_per_drop(self) -> int:
        """Scratch bytes per drop of capacity: packed rows, sort slots, entries (pairs apart)."""
        return sum(a.nbytes for a in self._drop_arrays()) // self.cap

    @property
    def nbytes(self) -> int:
        return self.grid_bytes + self.occs.nbytes + self.bufs.nbytes + sum(
            a.nbytes for a in self._drop_arrays()) + sum(
            a.nbytes for a in (self.pairs, self.pkey, self.touched, self.dtouched))


def bytes_per_cell(n_layers: int, footprint: str = "cell") -> int:
    """Scratch bytes per grid cell kept by the compiled path (height, sort slots, two wet-cell
    lists; key rows with a footprint wider than one cell)."""
    return 20 + (32 * n_layers if footprint != "cell" else 0)


def step(s: "P.Surface", d: "P.Drops", p, continued: bool = False) -> "P.Drops":
    """``particles.step`` on the compiled path (same arguments, same result)."""
    fp = _FOOTPRINTS[p.footprint]
    work = s.__dict__.get(_ATTR)
    if work is None or not work.fits(s, fp != 0):
        work = Work(s.ncell, s.n_layers, s.shape[1], fp != 0)
        s.__dict__[_ATTR] = work
    oy, ox, ow = P._disc_offsets(p.brush_radius) if fp == 2 else (np.zeros(1, np.int64),) * 2 + (np.ones(1),)
    k = ox.size if fp == 2 else (4 if fp == 1 else 1)
    n = len(d)
    work.grow(n, k)
    since = continued and work.current_at == s.steps and work.occupied[0] >= 0
    pos, vel = np.ascontiguousarray(d.pos), np.ascontiguousarray(d.vel)
    kind, moving, age = d.kind, d.moving, d.age
    volume, sediment = d.volume, d.sediment
    adh_k = p.adhesion * 0.75 * np.sin(np.radians(p.contact_angle)) ** 2   # as in particles.move
    cap_k = -1.0 if p.sediment_capacity is None else float(p.sediment_capacity)
    fade = 1 if (p.capacity_fade and p.max_age > 0) else 0
    sp = float(s.spacing)
    m = _step(s.shape[0], s.shape[1], sp, _exact_inverse(sp), s.base, s.thickness, s.held,
              s.deposit, s.evaporated, s.drained, s.drained_sediment, s.path,
              s.absorption_rate, s.capacity, s.erosion_rate, s.threshold, s.roughness,
              s.absorbs, s.erodible,
              pos, vel, volume, sediment, kind, moving, age, n,
              float(p.gravity), float(p.friction), float(adh_k), float(p.max_speed),
              float(p.stable_speed), int(p.max_age), float(p.speed_ref), float(p.evaporation),
              cap_k, float(p.min_slope), float(p.deposition_rate), float(p.max_concentration),
              bool(p.erode_stabilised), fade, (0,) * (fp + 1), (0,) * int(cap_k >= 0),
              oy.astype(np.int64), ox.astype(np.int64),
              ow.astype(np.float64), work.sk, work.cell_sk, work.stamps, work.h, work.counts,
              work.chunks, work.kept, min(numba.get_num_threads(), work.chunks.size - 1),
              _MIN_CHUNK, work.fa, work.ia, work.fb, work.ib, work.rk, work.starts, work.ent, work.pairs, work.pkey,
              work.touched, work.dtouched, work.occs, work.bufs, (0,) * s.n_layers, since,
              work.occupied, work.obud, work.wet, work.wout, work.wseg, work.nwet, float(_SPARSE))
    if m < 0:        # (checked before any write; erosion sets a kind with the first sediment)
        raise AssertionError("a drop carrying sediment has no sediment kind")
    if work.nwet[0] >= 0:                         # the step's list of wet cells is the next one's
        work.wet, work.wout = work.wout, work.wet
    work.current_at = s.steps + 1                 # (P.step counts this step once it returns)
    return P.Drops(pos[:m], vel[:m], volume[:m], sediment[:m], kind[:m], moving[:m], age[:m])


# --------------------------------------------------------------------------------------------
# helpers (each mirrors one numpy expression of particles.py)

_cbrt = njit(cache=True, nogil=True, inline="always")(portable.cbrt)


@njit(cache=True, nogil=True, inline="always")
def _clip(x, lo, hi):
    return min(max(x, lo), hi)


@njit(cache=True, nogil=True, inline="always")
def _div(x, d, r):
    """x / d, as x * r when r is not 0: ``_exact_inverse(d)``, a power of two's inverse, with
    which the product is the quotient to the bit (both round the same real), in a few cycles
    where the division takes over ten."""
    return x * r if r != 0.0 else x / d


def _exact_inverse(d: float) -> float:
    """1 / d if d is a power of two (then x * (1 / d) == x / d exactly) whose inverse is a
    normal number, else 0."""
    return 1.0 / d if math.frexp(d)[0] == 0.5 and 2.0 ** -1020 < d < 2.0 ** 1020 else 0.0


@njit(cache=True, nogil=True, inline="always")
def _grad_ij(h, c, i, j, nx, ny, sp, rsp):
    """(dh/dx, dh/dy) at cell c = (column i, row j): np.gradient's central / one-sided
    differences (rsp: _exact_inverse(sp))."""
    if i == 0:
        gx = _div(h[c + 1] - h[c], sp, rsp)
    elif i == nx - 1:
        gx = _div(h[c] - h[c - 1], sp, rsp)
    else:
        gx = _div(h[c + 1] - h[c - 1], 2.0 * sp, 0.5 * rsp)
    if j == 0:
        gy = _div(h[c + nx] - h[c], sp, rsp)
    elif j == ny - 1:
        gy = _div(h[c] - h[c - nx], sp, rsp)
    else:
        gy = _div(h[c + nx] - h[c - nx], 2.0 * sp, 0.5 * rsp)
    return gx, gy


@njit(cache=True, nogil=True, inline="always")
def _grad(h, c, nx, ny, sp):
    """_grad_ij at cell c >= 0.  Its row without an integer division (tens of cycles): the float
    quotient (c + 0.5) / nx lies at least 0.5 / nx from an integer, and its rounding error is
    below c / nx * 2**-52, so the truncation is exact for every c < 2**51."""
    j = int((c + 0.5) * (1.0 / nx))
    return _grad_ij(h, c, c - j * nx, j, nx, ny, sp, 0.0)


@njit(cache=True, nogil=True, inline="always")
def _corners(x, y, nx, ny):
    u = x - 0.5
    v = y - 0.5
    i0 = int(_clip(math.floor(u), 0.0, float(nx - 2)))
    j0 = int(_clip(math.floor(v), 0.0, float(ny - 2)))
    fu = _clip(u - i0, 0.0, 1.0)
    fv = _clip(v - j0, 0.0, 1.0)
    return j0 * nx + i0, fu, fv


@njit(cache=True, nogil=True, inline="always")
def _cell_of(x, y, nx, ny):
    ix = int(_clip(math.floor(x), 0.0, float(nx - 1)))
    iy = int(_clip(math.floor(y), 0.0, float(ny - 1)))
    return iy * nx + ix


@njit(cache=True, nogil=True, inline="always")
def _top(t, c, L):
    top = -1
    for l in range(L):
        if t[c, l] > 0:
            top = l
    return top


@njit(cache=True, nogil=True, inline="always")
def _height_at(h, x, y, nx, ny):
    c, fu, fv = _corners(x, y, nx, ny)
    res = 0.0
    res += h[c] * ((1 - fu) * (1 - fv))
    res += h[c + 1] * (fu * (1 - fv))
    res += h[c + nx] * ((1 - fu) * fv)
    res += h[c + nx + 1] * (fu * fv)
    return res


@njit(cache=True, nogil=True, inline="always")
def _footprint(x, y, nx, ny, mode, oy, ox, ow, cells, w, base):
    """Cells and weights of a drop's wider footprint (bilinear, disc) at (x, y) into
    cells/w[base:base + k]; returns k."""
    if mode == 1:
        c, fu, fv = _corners(x, y, nx, ny)
        cells[base] = c
        cells[base + 1] = c + 1
        cells[base + 2] = c + nx
        cells[base + 3] = c + nx + 1
        w[base] = (1 - fu) * (1 - fv)
        w[base + 1] = fu * (1 - fv)
        w[base + 2] = (1 - fu) * fv
        w[base + 3] = fu * fv
        return 4
    k = ox.size
    fx = int(math.floor(x))
    fy = int(math.floor(y))
    for q in range(k):
        ix = fx + ox[q]
        iy = fy + oy[q]
        if ix >= 0 and ix < nx and iy >= 0 and iy < ny:
            cells[base + q] = iy * nx + ix
            w[base + q] = ow[q]
        else:
            cells[base + q] = 0
            w[base + q] = 0.0
    tot = pairwise_sum(w, base, k)
    for q in range(k):
        w[base + q] = w[base + q] / tot
    return k


@njit(cache=True, nogil=True, inline="always")
def _add(sk, stamp, touched, nt, key, x):
    """sk[key, 0] += x for this phase (``stamp``): the first touch zeroes the row's columns
    0-1 and records the key, so no pass is needed to clean up afterwards.  Without a branch
    (selects; the key is written to touched[nt] either way, kept only when new): with one, numba
    increfs sk and touched at each call."""
    new = sk[key, 2] != stamp
    touched[nt] = key
    sk[key, 0] = (0.0 if new else sk[key, 0]) + x
    sk[key, 1] = 0.0 if new else sk[key, 1]
    sk[key, 2] = stamp
    return nt + new


@njit(cache=True, nogil=True, inline="always")
def _lay(nx, ny, L, i, amount, F, I, mode, oy, ox, ow, fc, fw, sk, dtouched, nd):
    """Add drop i's deposit of ``amount`` > 0 over its wider footprint to the deposit column
    sk[:, 3] (zero at rest; only positive terms, so a key is new while its sum is 0)."""
    k = _footprint(F[i, X], F[i, Y], nx, ny, mode, oy, ox, ow, fc, fw, 0)
    for q in range(k):                # (branch-free, as _add; adding x = 0 changes no sum)
        x = amount * fw[q]
        key = fc[q] * L + I[i, KIND]
        dtouched[nd] = key
        nd += (x != 0.0) & (sk[key, 3] == 0.0)
        sk[key, 3] += x
    return nd


@njit(cache=True, nogil=True, inline="always")
def _laid(a, tf, df, sk, dtouched, nd):
    """particles._deposit's ``thickness += bincount(...) / a`` for the keys laid on (tf, df: the
    flat thickness and deposit)."""
    for t in range(nd):
        key = dtouched[t]
        add = sk[key, 3] / a
        tf[key] += add
        df[key] += add
        sk[key, 3] = 0.0


@njit(cache=True, nogil=True, inline="always")
def _unpack(F, I, o, j, pos, vel, volume, sediment, kind, moving, age):
    """Packed drop o into index j of the caller's arrays."""
    pos[j, 0] = F[o, X]
    pos[j, 1] = F[o, Y]
    vel[j, 0] = F[o, VX]
    vel[j, 1] = F[o, VY]
    volume[j] = F[o, VOL]
    sediment[j] = max(F[o, SED], 0.0)
    kind[j] = I[o, KIND]
    moving[j] = I[o, MOV] != 0
    age[j] = I[o, AGE]


@njit(cache=True, nogil=True, parallel=True)
def _counting_sort(key, n, nb, counts, slot, nt, band):
    """slot[r] = rank of r when the r < n with key[r] >= 0 are sorted by key (< nb), then by r;
    returns how many were placed.  In ``nt`` bands of keys, one per thread: each thread reads
    all n keys and counts, then ranks, those in its band, so the bands' counts (counts[k], the
    grid-sized part of the work) are their own; band[t] takes the drops of the bands before."""
    for t in prange(nt):
        b0 = nb * t // nt
        b1 = nb * (t + 1) // nt
        counts[b0:b1] = 0
        for r in range(n):
            k = key[r]
            if k >= b0 and k < b1:
                counts[k] += 1
        run = 0
        for k in range(b0, b1):               # each key's first rank within the band
            c = counts[k]
            counts[k] = run
            run += c
        band[t] = run
    tot = 0
    for t in range(nt):
        c = band[t]
        band[t] = tot
        tot += c
    for t in prange(nt):
        b0 = nb * t // nt
        b1 = nb * (t + 1) // nt
        off = band[t]
        for r in range(n):
            k = key[r]
            if k >= b0 and k < b1:
                slot[r] = counts[k] + off
                counts[k] += 1
    return tot


@njit(cache=True, nogil=True, inline="always")
def _copy_row(F, I, o, G, J, j):
    for q in range(_NF):
        G[j, q] = F[o, q]
    for q in range(_NI):
        J[j, q] = I[o, q]


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def _height_release(ny, nx, sp, base, thickness, held, capacity, evaporated, h, bufs, nt, ltag):
    """Surface.height (base plus the layers, bottom first) into ``h``, and
    particles.release_excess: one pass over the grid in ``nt`` chunks of rows, as both read the
    layers (the move reads no held water, so releasing before it changes no number).  Whether
    any cell of a row holds water above capacity is one flat pass over the row's layers, which
    the compiler vectorizes (capacity tiled along it in ``bufs[t, nx:]``); only then (rare:
    after another rule thinned a layer) do its cells release it.  ``ltag``'s length is the
    layer count, a compile-time constant, so the layer loops unroll."""
    L = len(ltag)
    a = sp * sp
    for t in prange(nt):
        capv = bufs[t, nx:]
        for k in range(nx):
            for l in range(L):
                capv[k * L + l] = capacity[l]
        for j in range(ny * t // nt, ny * (t + 1) // nt):
            r0 = j * nx
            for i in range(r0, r0 + nx):
                hc = base[i]
                for l in range(L):
                    hc += thickness[i, l]
                h[i] = hc
            hf = held.reshape(-1)[r0 * L:(r0 + nx) * L]
            tf = thickness.reshape(-1)[r0 * L:(r0 + nx) * L]
            over = False
            for k in range(nx * L):
                over |= hf[k] - capv[k] * tf[k] * a > 0
            if over:
                for i in range(r0, r0 + nx):
                    _release_at(i, thickness, held, capacity, evaporated, a, L)


@njit(cache=True, nogil=True, inline="always", error_model="numpy")
def _release_at(i, thickness, held, capacity, evaporated, a, L):
    """particles.release_excess at cell i (cell area a, L layers)."""
    tot = 0.0
    for l in range(L):
        ex = max(held[i, l] - capacity[l] * thickness[i, l] * a, 0.0)
        if ex > 0:
            held[i, l] -= ex
            tot += ex
    if tot > 0:
        evaporated[i] += tot


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def _height_release_cells(sp, base, thickness, held, capacity, evaporated, h, I, starts, ncell,
                          ltag):
    """_height_release at the ``ncell`` cells the last step's drops were in (first drops
    ``starts`` of its packed drops ``I``, in cell order), when nothing but that step wrote the
    surface since: with the one-cell footprint a drop changes the layers and the water of its
    own cell only, and elsewhere the water only evaporated (the excess stays 0), so every other
    cell's height and water are as the last pass left them.  The same expressions in the same
    order as _height_release, cell by cell (a distinct cell per k)."""
    L = len(ltag)
    a = sp * sp
    tf = thickness.reshape(-1)
    hf = held.reshape(-1)
    for k in prange(ncell):
        if k + _AHEAD < ncell:                   # (sorted but sparse cells: see _prefetch_cell)
            c = I[starts[k + _AHEAD], CELL]
            prefetch(base, c)
            prefetch(h, c)
            for r in (tf, hf):
                prefetch(r, c * L)
                prefetch(r, c * L + L - 1)
        i = I[starts[k], CELL]
        hc = base[i]
        for l in range(L):
            hc += thickness[i, l]
        h[i] = hc
        _release_at(i, thickness, held, capacity, evaporated, a, L)


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def _evaporate(ny, nx, sp, rsp, held, evaporated, h, evaporation, I, starts, nocc, occs, bufs,
               nt, ltag, obud, wout, wseg, sparse):
    """particles.evaporate at the cells that hold no drop (the ``nocc`` occupied cells, first
    drops ``starts`` of the packed drops ``I`` in cell order: with the one-cell footprint
    absorption wets only a drop's own cell, so the others' water is final here; the
    interaction evaporates the drops' cells), in ``nt`` chunks of rows.  Each cell is its own:
    neither the chunks nor the order change a number.

    Made for the hardware (measured on a 512 x 512 x 3 grid, a third of it wet, 2 threads: 2.8
    -> 1.6 ms with the release then in the same pass): every cell of a row is treated alike,
    without a branch, in loops the compiler vectorizes; a dry cell or one holding a drop
    (``occs[t]`` flags the row's occupied columns) evaporates with a budget of 0, which changes
    no bit (held and the ledger are never negative).  The budgets (``bufs[t, :nx]``: the slope's
    square root) come first in a loop of their own, then the layers take from them.

    The rows' wet layers and occupied cells are counted (a flat loop: it vectorizes); if a
    chunk has fewer than 1 / ``sparse`` of its cells (``sparse`` 0: never; below 1 / (L + 1):
    always), its cells that hold water or a drop are listed in order in ``wout`` from its first
    cell on (a second pass, run once as the grid dries), ``wseg[t]`` = (that index, their count;
    -1: not listed), for _evaporate_wet's next step."""
    L = len(ltag)
    a = sp * sp
    s2 = 2.0 * sp
    r2 = 0.5 * rsp
    hf = held.reshape(-1)
    for t in prange(nt):
        j0 = ny * t // nt
        occ = occs[t]
        bud = bufs[t, :nx]
        m = j0 * nx                              # (+ the cells that may hold water)
        wseg[t, 0] = m
        lo = _first_at(I, starts, nocc, j0 * nx)   # the first occupied cell in these rows
        q = lo
        for j in range(j0, ny * (t + 1) // nt):
            r0 = j * nx
            q0 = q
            while q < nocc and I[starts[q], CELL] < r0 + nx:
                occ[I[starts[q], CELL] - r0] = 1
                q += 1
            up = r0 - nx if j > 0 else r0            # np.gradient's rows: central, or
            dn = r0 + nx if j < ny - 1 else r0       # one-sided at the edges
            dy = s2 if up != r0 and dn != r0 else sp
            rdy = r2 if up != r0 and dn != r0 else rsp
            hr = h[r0:r0 + nx]
            hu = h[up:up + nx]
            hd = h[dn:dn + nx]
            for i in range(1, nx - 1):
                gx = _div(hr[i + 1] - hr[i - 1], s2, r2)
                gy = _div(hd[i] - hu[i], dy, rdy)
                b = evaporation * (a * math.sqrt(1.0 + gx * gx + gy * gy))
                bud[i] = 0.0 if occ[i] != 0 else b
            for i in (0, nx - 1):
                gx, gy = _grad_ij(h, r0 + i, i, j, nx, ny, sp, rsp)
                b = evaporation * (a * math.sqrt(1.0 + gx * gx + gy * gy))
                bud[i] = 0.0 if occ[i] != 0 else b
            hl = held[r0:r0 + nx]
            ev = evaporated[r0:r0 + nx]
            for i in range(nx):                      # top layer first
                budget = bud[i]
                total = 0.0
                for l in range(L - 1, -1, -1):
                    v = hl[i, l]
                    e = min(v, budget)
                    hl[i, l] = v - e
                    budget -= e
                    total += e
                ev[i] += total
            wl = hf[r0 * L:(r0 + nx) * L]           # wet layers: at least the wet cells
            for k in range(nx * L):
                m += wl[k] > 0
            m += q - q0                              # and the occupied ones
            for k in range(q0, q):              # the occupied cells: their budgets for the
                c = I[starts[k], CELL]              # interaction (this row's heights are in cache)
                occ[c - r0] = 0
                gx, gy = _grad_ij(h, c, c - r0, j, nx, ny, sp, rsp)
                obud[k] = evaporation * (a * math.sqrt(1.0 + gx * gx + gy * gy))
        wseg[t, 1] = -1                          # not listed: too many
        if sparse > 0 and (m - j0 * nx) * sparse < (ny * (t + 1) // nt - j0) * nx:
            wseg[t, 1] = _list_rows(nx, held, I, starts, nocc, lo, j0, ny * (t + 1) // nt,
                                    occ, wout, L)


@njit(cache=True, nogil=True)
def _list_rows(nx, held, I, starts, nocc, q, j0, j1, occ, wout, L):
    """_evaporate's list of rows j0..j1-1 (their first occupied cell: the q-th): the cells
    holding water or a drop, in order, from wout[j0 * nx] on; returns their count."""
    m = j0 * nx
    for j in range(j0, j1):
        r0 = j * nx
        q0 = q
        while q < nocc and I[starts[q], CELL] < r0 + nx:
            occ[I[starts[q], CELL] - r0] = 1
            q += 1
        hl = held[r0:r0 + nx]
        for i in range(nx):                      # (no branch)
            keep = occ[i] != 0
            for l in range(L):
                keep |= hl[i, l] > 0
            wout[m] = r0 + i
            m += keep
        for k in range(q0, q):
            occ[I[starts[k], CELL] - r0] = 0
    return m - j0 * nx


@njit(cache=True, nogil=True, inline="always")
def _first_at(I, starts, nocc, c):
    """The first of the ``nocc`` occupied cells (first drops ``starts`` of the packed drops I,
    in cell order) at or after cell c."""
    lo = 0
    hi = nocc
    while lo < hi:
        mid = (lo + hi) // 2
        if I[starts[mid], CELL] < c:
            lo = mid + 1
        else:
            hi = mid
    return lo


@njit(cache=True, nogil=True, parallel=True, error_model="numpy")
def _evaporate_wet(ny, nx, sp, rsp, held, evaporated, h, evaporation, I, starts, nocc, wet, nwet,
                   wout, wseg, nt, ltag, obud):
    """_evaporate in a continued step after a listed one (``wet``: the ``nwet`` cells, in
    order, that held water or a drop at the end of the last step; every other cell is dry and
    stays so, with the one-cell footprint only a drop wets a cell), visiting only the listed and
    the occupied cells, merged in order, in ``nt`` chunks of the list: a listed cell without a
    drop evaporates (the same expressions as _evaporate, so the same numbers) and stays listed
    while it holds water; an occupied cell gets its budget and is listed.  The next list goes to
    ``wout`` as _evaporate's does.  Most of the grid is dry most of the time (a sixth of it on
    average in benchmarks/water.py), so this reads a fraction of the grid pass's lines."""
    L = len(ltag)
    a = sp * sp
    nc = ny * nx
    hf = held.reshape(-1)
    for t in prange(nt):
        p = nwet * t // nt
        p1 = nwet * (t + 1) // nt
        clo = 0 if t == 0 else (wet[p] if p < nwet else nc)         # the chunk's cells:
        chi = nc if t == nt - 1 else (wet[p1] if p1 < nwet else nc)  # [clo, chi)
        k = _first_at(I, starts, nocc, clo)
        k1 = _first_at(I, starts, nocc, chi)
        m = p + k
        wseg[t, 0] = m
        cw = wet[p] if p < p1 else nc
        co = I[starts[k], CELL] if k < k1 else nc
        while p < p1 or k < k1:
            if p + _AHEAD < p1:
                c = wet[p + _AHEAD]
                prefetch(hf, c * L)
                prefetch(hf, c * L + L - 1)
                prefetch(evaporated, c)
                prefetch(h, max(c - nx, 0))
                prefetch(h, c)
                prefetch(h, min(c + nx, nc - 1))
            c = min(cw, co)
            j = int((c + 0.5) * (1.0 / nx))       # (exact: see _grad)
            gx, gy = _grad_ij(h, c, c - j * nx, j, nx, ny, sp, rsp)
            b = evaporation * (a * math.sqrt(1.0 + gx * gx + gy * gy))
            wout[m] = c
            if co <= cw:                          # a drop's cell: evaporates in the interaction
                obud[k] = b
                m += 1
                k += 1
                co = I[starts[k], CELL] if k < k1 else nc
            else:
                _evaporate_at(c, b, held, evaporated, L)
                keep = False
                for l in range(L):
                    keep |= held[c, l] > 0
                m += keep
            if cw == c:
                p += 1
                cw = wet[p] if p < p1 else nc
        wseg[t, 1] = m - wseg[t, 0]


@njit(cache=True, nogil=True)
def _close_list(wout, wseg, nt):
    """The chunks' parts of the wet-cell list (``wseg``) moved down into one; returns its
    length (-1: a chunk has none, it would have been too long)."""
    m = 0
    for t in range(nt):
        if wseg[t, 1] < 0:
            return -1
    for t in range(nt):
        lo = wseg[t, 0]
        for q in range(wseg[t, 1] if lo != m else 0):
            wout[m + q] = wout[lo + q]
        m += wseg[t, 1]
    return m


@njit(cache=True, nogil=True, parallel=True)
def _move(ny, nx, sp, rsp, h, thickness, roughness, pos, vel, volume, sediment, kind, moving,
          age, F, I, key, by_cell, n, gravity, friction, adh_k, max_speed, stable_speed, max_age):
    """particles.move of drop i of the caller's arrays (each drop on its own): its sort key
    ``key[i]`` (with ``by_cell`` the end cell, else 0; -1 for a drop that left the grid); a
    moving drop's new state into packed row i (new position, velocity, speed, dh, the end cell
    CELL, or the start cell for a drop that left).  A drop at rest keeps its state,
    so its row is not written here: ``_place`` packs it straight into its sorted row (most
    drops rest, and each row written and read again costs memory traffic).  Returns how many
    left."""
    L = thickness.shape[1]
    vmax = max_speed * sp
    hi_x = nx * (1 - 1e-12)
    hi_y = ny * (1 - 1e-12)
    nout = 0
    tf = thickness.reshape(-1)
    for i in prange(n):
        if i + _AHEAD < n and moving[i + _AHEAD]:   # the gradient stencil's rows of a
            ca = _cell_of(pos[i + _AHEAD, 0], pos[i + _AHEAD, 1], nx, ny)   # moving drop ahead
            prefetch(h, max(ca - nx - 1, 0))
            prefetch(h, ca - 1 if ca > 0 else 0)
            prefetch(h, min(ca + nx - 1, h.size - 1))
            prefetch(h, min(ca + 2 * nx - 1, h.size - 1))
            prefetch(tf, ca * L)
        x = pos[i, 0]
        y = pos[i, 1]
        if not moving[i]:
            key[i] = _cell_of(x, y, nx, ny) if by_cell else 0
            continue
        F[i, X] = x
        F[i, Y] = y
        F[i, VX] = vel[i, 0]
        F[i, VY] = vel[i, 1]
        F[i, VOL] = volume[i]
        F[i, SED] = sediment[i]
        F[i, DH] = 0.0
        I[i, KIND] = kind[i]
        I[i, MOV] = 1
        I[i, AGE] = age[i]
        vol = max(F[i, VOL], 1e-300)        # (first: its chain of arithmetic runs beside
        r = _cbrt(3.0 * vol / (4.0 * np.pi))    # the gradient's loads)
        adh = adh_k / r
        c, fu, fv = _corners(x, y, nx, ny)
        ci = c % nx
        cj = c // nx
        w0 = (1 - fu) * (1 - fv)
        w1 = fu * (1 - fv)
        w2 = (1 - fu) * fv
        w3 = fu * fv
        g0x, g0y = _grad_ij(h, c, ci, cj, nx, ny, sp, rsp)
        g1x, g1y = _grad_ij(h, c + 1, ci + 1, cj, nx, ny, sp, rsp)
        g2x, g2y = _grad_ij(h, c + nx, ci, cj + 1, nx, ny, sp, rsp)
        g3x, g3y = _grad_ij(h, c + nx + 1, ci + 1, cj + 1, nx, ny, sp, rsp)
        gxi = 0.0
        gxi += g0x * w0
        gxi += g1x * w1
        gxi += g2x * w2
        gxi += g3x * w3
        gyi = 0.0
        gyi += g0y * w0
        gyi += g1y * w1
        gyi += g2y * w2
        gyi += g3y * w3
        s2 = gxi * gxi + gyi * gyi
        ax = -gravity * gxi / (1.0 + s2)
        ay = -gravity * gyi / (1.0 + s2)
        cc = _cell_of(x, y, nx, ny)
        top = _top(thickness, cc, L)
        mu = roughness[top] if top >= 0 else 0.0
        grip = mu * (gravity / math.sqrt(1.0 + s2) + adh)
        vx = F[i, VX] * (1.0 - friction) + ax
        vy = F[i, VY] * (1.0 - friction) + ay
        spd = math.sqrt(vx * vx + vy * vy)
        keep = 1.0 - grip / spd if spd > grip else 0.0
        vx *= keep
        vy *= keep
        spd = spd * keep
        if spd > vmax:
            f = vmax / spd
            vx *= f
            vy *= f
            spd = min(spd, vmax)
        nxp = x + _div(vx, sp, rsp)
        nyp = y + _div(vy, sp, rsp)
        F[i, DH] = _height_at(h, _clip(nxp, 0.0, hi_x), _clip(nyp, 0.0, hi_y), nx, ny) \
            - _height_at(h, x, y, nx, ny)
        ag = I[i, AGE] + 1
        stop = (spd < stable_speed * sp) and (math.sqrt(ax * ax + ay * ay) <= grip)
        if max_age > 0:
            stop = stop or ag >= max_age
        F[i, X] = nxp
        F[i, Y] = nyp
        F[i, VX] = 0.0 if stop else vx
        F[i, VY] = 0.0 if stop else vy
        I[i, AGE] = ag
        I[i, MOV] = 0 if stop else 1
        F[i, SPD] = 0.0 if stop else spd
        if nxp < 0 or nxp >= nx or nyp < 0 or nyp >= ny:
            I[i, CELL] = cc
            key[i] = -1
            nout += 1
        else:
            I[i, CELL] = _cell_of(nxp, nyp, nx, ny)
            key[i] = I[i, CELL] if by_cell else 0
    return nout


@njit(cache=True, nogil=True, parallel=True)
def _place(F, I, key, slot, placed, pos, vel, volume, sediment, kind, moving, age, G, J, n, nx,
           ny):
    """Drop i (not left the grid) into packed row ``slot[i]`` of G / J (row i if ``placed``:
    the drops are in sort order already): a moving drop's row from F / I (``_move``'s), a drop
    at rest packed from the caller's arrays, as particles.move leaves it (speed from its
    velocity, dh 0)."""
    for i in prange(n):
        if key[i] < 0:
            continue
        r = np.int64(i) if placed else np.int64(slot[i])    # (prange's index may be unsigned)
        if moving[i]:
            _copy_row(F, I, i, G, J, r)
            continue
        vx = vel[i, 0]
        vy = vel[i, 1]
        G[r, X] = pos[i, 0]
        G[r, Y] = pos[i, 1]
        G[r, VX] = vx
        G[r, VY] = vy
        G[r, VOL] = volume[i]
        G[r, SED] = sediment[i]
        G[r, SPD] = math.sqrt(vx * vx + vy * vy)
        G[r, DH] = 0.0
        J[r, KIND] = kind[i]
        J[r, MOV] = 0
        J[r, AGE] = age[i]
        J[r, CELL] = _cell_of(pos[i, 0], pos[i, 1], nx, ny)


@njit(cache=True, nogil=True)
def _drain(F, I, skey, n, order, drained, drained_sed):
    """Drained water and sediment of the drops that left (key -1; their rows are ``_move``'s),
    summed per start cell in drop order from 0 (as ``np.bincount``), then added.  The few drops
    that left are listed as sorted (cell, drop) keys in ``order``: no grid-sized scratch, whose
    pages the first steps on a fresh Surface would fault in along the grid's edges (about 0.5 ms
    each for the huge pages numpy asks for: 20-50 ms at 512x512x3)."""
    k = 0
    for i in range(n):
        if skey[i] < 0:
            order[k] = np.int64(I[i, CELL]) * n + i
            k += 1
    order[:k].sort()
    o = 0
    while o < k:
        c = order[o] // n
        water = 0.0
        sed = 0.0
        while o < k and order[o] // n == c:
            i = order[o] - c * n
            water += F[i, VOL]
            sed += F[i, SED]
            o += 1
        drained[c] += water
        drained_sed[c] += sed


@njit(cache=True, nogil=True)
def _cell_starts(I, n, starts):
    """starts[k] = the first of the n packed drops (in cell order) in the k-th occupied cell,
    starts[m] = n; returns m.  Without a branch per drop: the slot after the last cell found is
    rewritten by every drop until one opens a new cell."""
    m = 0
    prev = -1
    for o in range(n):
        c = I[o, CELL]
        starts[m] = o
        m += c != prev
        prev = c
    starts[m] = n
    return m


@njit(cache=True, nogil=True, inline="always")
def _prefetch_cell(c, nx, L, tf, hf, df, path, evaporated, h, slope):
    """Prefetch the lines the interaction reads of cell c (its layers, held water, deposit, path
    and evaporation ledger; with ``slope``, the gradient's three height rows).  A cell's L
    layers may span two lines (with L = 3, one cell in four): both ends are prefetched (a
    quarter less time)."""
    for r in (tf, hf, df):
        prefetch(r, c * L)
        prefetch(r, c * L + L - 1)
    prefetch(path, c)
    prefetch(evaporated, c)
    if slope:
        prefetch(h, c)
        prefetch(h, max(c - nx, 0))
        prefetch(h, min(c + nx, h.size - 1))


@njit(cache=True, nogil=True, inline="always")
def _drop_capacity(F, I, i, ms, cap_k, max_age, fade):
    """particles.interact's sediment capacity of packed drop i, ms = max(slope, min_slope) at
    its cell: cap_k V speed ms, faded with age (``fade``)."""
    capd = cap_k * F[i, VOL] * F[i, SPD] * ms
    return capd * (_clip(1.0 - I[i, AGE] / max_age, 0.0, 1.0) if fade else 1.0)


@njit(cache=True, nogil=True, inline="always")
def _erode_key(key, got, a, cap, tf, df, hf):
    """particles.interact's removal of ``got`` > 0 volume from key (cell, layer) (tf, df, hf:
    the flat thickness, deposit and held water; cap: the layer's capacity per thickness): the
    layer and its deposit thin, the water held beyond the thinner layer's capacity is released
    (taken from hf).  Returns (removed / got, released water, removed volume)."""
    t_old = tf[key]
    t_new = max(t_old - got / a, 0.0)
    actual = (t_old - t_new) * a
    tf[key] = t_new
    df[key] = max(df[key] - (t_old - t_new), 0.0)
    excess = max(hf[key] - cap * t_new * a, 0.0) if actual > 0 else 0.0
    if excess > 0:
        hf[key] -= excess
    return actual / got, excess, actual


@njit(cache=True, nogil=True, inline="always")
def _cell_laid(c0, L, a, tf, df, rows):
    """particles._deposit's ``thickness += bincount(...) / a`` at cell c0: the layers' deposit
    sums rows[:, 3] (only positive terms: a layer was laid on iff its sum is not 0), reset."""
    for l in range(L):
        x = rows[l, 3]
        if x != 0.0:
            add = x / a
            tf[c0 * L + l] += add
            df[c0 * L + l] += add
            rows[l, 3] = 0.0


# (error_model "numpy": every division below is guarded, so no zero-division checks and their
# raise paths are compiled in)
@njit(cache=True, nogil=True, error_model="numpy")
def _interact_cells(ny, nx, sp, thickness, held, tf, hf, df, path, absorption_rate, capacity,
                    erosion_rate, threshold, absorbs, erodible, F, I, speed_ref, cap_k, min_slope,
                    deposition_rate, max_concentration, erode_stabilised, max_age, fade, captag,
                    rows, h, dem, lay, starts, k0, k1, evaporated, evaporation, ltag, out, obud):
    """_interact with the one-cell footprint, cell by cell: a key (cell, layer) hears only its
    own cell's drops, in drop order, so no number changes.  All drops of a cell absorb into one
    key (c0, top0): its demand sum is a scalar, its capacity, held water and saturation the same
    for every drop (computed once); the erosion and deposit keys are (c0, layer): the sums are
    the L rows of ``rows`` (columns: erosion demand, then got / demand; removed / got; water
    released per removed volume; deposit).  Per drop scratch: dem (demand), lay (eroded layer).
    The phases are written out in this one loop, not in helpers: numba often increfs the arrays
    a helper with branches receives, at each call (two atomic calls per array, per cell).
    The lines of the cell _AHEAD cells on are prefetched.  Each cell's drops with water are
    then written back, in order, into the caller's arrays ``out`` (pos, vel, volume, sediment,
    kind, moving, age) from index starts[k0] on (never past the drop being written: no other
    chunk's range is touched), while their rows are in cache; returns how many."""
    capacity_on = len(captag) > 0     # (compile-time constants, as in _interact)
    L = len(ltag)
    a = sp * sp
    for k in range(k0, min(k0 + _AHEAD, k1)):
        _prefetch_cell(I[starts[k], CELL], nx, L, tf, hf, df, path, evaporated, h, capacity_on)
    Ff = F.reshape(-1)
    If = I.reshape(-1)
    pos, vel, volume, sediment, kind, moving, age = out
    j = starts[k0]
    for k in range(k0, k1):
        lo = starts[k]
        hi = starts[k + 1]
        if k + _AHEAD < k1:             # that cell's lines, and its first drop's packed rows
            o = starts[k + _AHEAD]
            _prefetch_cell(I[o, CELL], nx, L, tf, hf, df, path, evaporated, h, capacity_on)
            prefetch(Ff, o * F.shape[1])
            prefetch(If, o * I.shape[1])
        c0 = I[lo, CELL]
        top0 = _top(thickness, c0, L)           # (one cell: one exposed layer)
        nmov = 0
        for i in range(lo, hi):
            nmov += I[i, MOV]
        if nmov:
            path[c0] += nmov                    # (the bincount of moving drops)
        ms = 0.0                                # max(slope, min_slope) at the cell
        if capacity_on:
            gx, gy = _grad(h, c0, nx, ny, sp)
            ms = max(math.sqrt(gx * gx + gy * gy), min_slope)
        # --- absorption into (c0, top0), deposition by concentration -----------------------------
        if top0 >= 0 and absorbs[top0]:
            cap = capacity[top0] * thickness[c0, top0] * a
            w = held[c0, top0]
            dry = 1.0 - (_clip(w / cap, 0.0, 1.0) if cap > 0 else 1.0)
            rate = absorption_rate[top0]
            tot = 0.0
            for i in range(lo, hi):
                v = F[i, VOL]
                if v > 0:
                    d = v * rate * dry / (1.0 + F[i, SPD] / speed_ref)
                    dem[i - lo] = d
                    tot += d
            if tot > 0:        # (demands are >= 0: else none wants water, nothing changes)
                got = min(tot, max(cap - w, 0.0))
                hf[c0 * L + top0] += got
                share = got / tot
                laid = False
                for i in range(lo, hi):
                    v_old = F[i, VOL]
                    if v_old > 0:
                        g = dem[i - lo] * share
                        v = max(v_old - g, 0.0)
                        F[i, VOL] = v
                        sed = F[i, SED]
                        if sed > 0:            # (else sed * frac is not > 0: no deposit)
                            dep = sed if v <= 0 else sed * (g / v_old)
                            if dep > 0:
                                rows[I[i, KIND], 3] += dep
                                F[i, SED] = sed - dep
                                laid = True
                if laid:
                    _cell_laid(c0, L, a, tf, df, rows)
        # --- erosion by moving drops: demand per layer -------------------------------------------
        top1 = _top(thickness, c0, L)           # the exposed layer after those deposits
        for l in range(L):
            rows[l, 0] = 0.0
        lc = -1                                 # the last eroded layer, its numbers:
        el = False                              # exposed, held water, rate * weakness
        hd = 0.0
        rw = 0.0
        ne = 0
        for i in range(lo, hi):
            lay[i - lo] = -1
            v = F[i, VOL]
            if not ((I[i, MOV] or erode_stabilised) and v > 0):
                continue
            cd = I[i, KIND] if I[i, KIND] >= 0 else top0
            if not (cd >= 0 and erodible[cd]):
                continue
            if cd != lc:
                lc = cd
                el = top1 == cd
                hd = held[c0, cd]
                capl = capacity[cd] * thickness[c0, cd] * a
                sat = hd / capl if capl > 0 else 1.0
                th = threshold[cd]
                weak = max(sat - th, 0.0) / (1.0 - th) if th < 1.0 else 0.0
                rw = erosion_rate[cd] * weak    # (times the footprint weight 1 first: same bits)
            pd = rw * (v + hd) if el else 0.0
            rm = max_concentration * v - F[i, SED]
            if capacity_on:
                rm = min(rm, _drop_capacity(F, I, i, ms, cap_k, max_age, fade) - F[i, SED])
                rm = min(rm, max(-F[i, DH], 0.0) * a)
            rm = max(rm, 0.0)
            if pd > rm:                         # (the drop's demand sum is its one demand)
                pd *= rm / pd
            rows[cd, 0] += pd
            dem[i - lo] = pd
            lay[i - lo] = cd
            ne += 1
        # --- erosion: per layer what is removed, then shared back to the drops -------------------
        hit = False
        if ne:
            for l in range(L):
                tot = rows[l, 0]
                share = 0.0
                corr = 0.0
                rel = 0.0
                if tot > 0:
                    key = c0 * L + l
                    got = min(tot, max(tf[key] * a, 0.0))
                    share = got / tot
                    if got > 0:
                        hit = True
                        corr, excess, actual = _erode_key(key, got, a, capacity[l], tf, df, hf)
                        if excess > 0:
                            rel = excess / actual
                rows[l, 0] = share
                rows[l, 1] = corr
                rows[l, 2] = rel
        if hit:                # (numpy shares nothing back when no key lost solid)
            for i in range(lo, hi):
                cd = lay[i - lo]
                if cd >= 0:    # its one pair: sums of one term (>= 0, so 0 + g is g)
                    g = dem[i - lo] * rows[cd, 0] * rows[cd, 1]
                    F[i, SED] += g
                    F[i, VOL] += g * rows[cd, 2]
                    if g > 0:
                        I[i, KIND] = cd
        # --- deposition beyond the capacity -------------------------------------------------------
        if capacity_on:
            laid = False
            for i in range(lo, hi):
                extra = max(F[i, SED] - _drop_capacity(F, I, i, ms, cap_k, max_age, fade), 0.0) * deposition_rate
                if not I[i, MOV]:
                    extra = F[i, SED]
                extra = max(extra, min(max(F[i, DH], 0.0) * a, F[i, SED]))
                if extra > 0:
                    rows[I[i, KIND], 3] += extra
                    F[i, SED] -= extra
                    laid = True
            if laid:
                _cell_laid(c0, L, a, tf, df, rows)
        # --- empty drops lay what they carry ------------------------------------------------------
        laid = False
        for i in range(lo, hi):
            if not F[i, VOL] > 0 and F[i, SED] > 0:
                rows[I[i, KIND], 3] += F[i, SED]
                F[i, SED] -= F[i, SED]
                laid = True
        if laid:
            _cell_laid(c0, L, a, tf, df, rows)
        if evaporation > 0:     # the cell's water is final: evaporate it now, with the budget
            wet = False         # the grid pass left (written out: a helper with an early return
            for l in range(L):  # costs numba's increfs)
                wet |= held[c0, l] != 0
            if wet:
                _evaporate_at(c0, obud[k], held, evaporated, L)
        for i in range(lo, hi):     # (branch-free: an empty drop is overwritten by the next)
            _unpack(F, I, i, j, pos, vel, volume, sediment, kind, moving, age)
            j += F[i, VOL] > 0
    return j - starts[k0]


@njit(cache=True, nogil=True)
def _interact(ny, nx, sp, thickness, held, tf, hf, df, path, absorption_rate, capacity,
              erosion_rate, threshold, absorbs, erodible, F, I, speed_ref, cap_k, min_slope,
              deposition_rate, max_concentration, erode_stabilised, max_age, fade, fptag, captag,
              oy, ox, ow, sk, cell_sk, stamps, h, ent, pairs, pkey, touched, dtouched, starts, k0,
              k1, evaporated, evaporation, ltag, out, obud):
    """particles.interact (and the path count) over the groups k0..k1-1 of packed drops, group k
    being drops starts[k]..starts[k + 1] - 1.  With the one-cell footprint a group is an
    occupied cell's drops (in drop order): _interact_cells, on the rows of ``cell_sk``.
    Otherwise one group holds all drops in drop order and the phases run once over them, each
    key's sum in row ``key`` of the grid's rows ``sk``: empty drops are left with volume 0 (the
    caller drops them), and 0 is returned."""
    mode = len(fptag) - 1             # the footprint and whether drops have a sediment capacity:
    capacity_on = len(captag) > 0     # tuple lengths, so each combination compiles on its own
    if mode == 0:                     # and the branches of the others vanish from its loops
        return _interact_cells(ny, nx, sp, thickness, held, tf, hf, df, path, absorption_rate,
                               capacity, erosion_rate, threshold, absorbs, erodible, F, I,
                               speed_ref, cap_k, min_slope, deposition_rate, max_concentration,
                               erode_stabilised, max_age, fade, captag, cell_sk, h, pairs[:, 1],
                               touched, starts, k0, k1, evaporated, evaporation, ltag, out, obud)
    L = thickness.shape[1]
    a = sp * sp
    fc = pkey
    fw = pairs[:, 0]
    pdem = pairs[:, 1]
    for k in range(k0, k1):
        lo = starts[k]
        hi = starts[k + 1]
        for i in range(lo, hi):
            c = I[i, CELL]
            I[i, TOP] = _top(thickness, c, L)
            if I[i, MOV]:
                path[c] += 1.0
        # --- absorption (demand per key, grant, deposition by concentration) ---------------------
        stamps[0] += 1.0
        st = stamps[0]
        nt = 0
        na = 0
        wants = False
        for i in range(lo, hi):
            tp = I[i, TOP]
            tk = max(tp, 0)
            if not (tp >= 0 and absorbs[tk] and F[i, VOL] > 0):
                continue
            c = I[i, CELL]
            cap = capacity[tk] * thickness[c, tk] * a
            w = held[c, tk]
            sat = _clip(w / cap, 0.0, 1.0) if cap > 0 else 1.0
            demand = F[i, VOL] * absorption_rate[tk] * (1.0 - sat) / (1.0 + F[i, SPD] / speed_ref)
            key = c * L + tk
            pairs[na, 1] = demand
            ent[na, 0] = i
            ent[na, 3] = key
            na += 1
            nt = _add(sk, st, touched, nt, key, demand)
            wants = wants or demand > 0
        if wants:             # (no demand: nothing granted, no volume or sediment changes)
            for t in range(nt):                       # per key: the granted total, into held
                key = touched[t]
                c = key // L
                l = key % L
                cap = capacity[l] * thickness[c, l] * a
                got = min(sk[key, 0], max(cap - held[c, l], 0.0))
                sk[key, 1] = got
                if sk[key, 0] > 0:
                    hf[key] += got
            nd = 0
            for e in range(na):
                i = ent[e, 0]
                key = ent[e, 3]
                tk_ = sk[key, 0]
                g = pairs[e, 1] * (sk[key, 1] / tk_) if tk_ > 0 else 0.0
                v_old = F[i, VOL]
                F[i, VOL] = max(v_old - g, 0.0)
                frac = g / v_old if v_old > 0 else 0.0
                dep = F[i, SED] if F[i, VOL] <= 0 else F[i, SED] * frac
                if dep > 0:
                    nd = _lay(nx, ny, L, i, dep, F, I, mode, oy, ox, ow, fc, fw, sk, dtouched, nd)
                    F[i, SED] -= dep
            _laid(a, tf, df, sk, dtouched, nd)
        # --- erosion by moving drops --------------------------------------------------------------
        stamps[0] += 1.0
        st = stamps[0]
        nt = 0
        kk = 0
        ne = 0
        for i in range(lo, hi):
            if not ((I[i, MOV] or erode_stabilised) and F[i, VOL] > 0):
                continue
            cd = I[i, KIND] if I[i, KIND] >= 0 else I[i, TOP]
            if not (cd >= 0 and erodible[cd]):
                continue
            k = _footprint(F[i, X], F[i, Y], nx, ny, mode, oy, ox, ow, fc, fw, kk)
            per_drop = 0.0
            for q in range(kk, kk + k):
                pc = fc[q]
                cap = capacity[cd] * thickness[pc, cd] * a
                hd = held[pc, cd]
                sat = hd / cap if cap > 0 else 1.0
                th = threshold[cd]
                weak = max(sat - th, 0.0) / (1.0 - th) if th < 1.0 else 0.0
                liquid = F[i, VOL] + hd
                if _top(thickness, pc, L) == cd and fw[q] > 0:
                    pdem[q] = fw[q] * erosion_rate[cd] * weak * liquid
                else:
                    pdem[q] = 0.0
                per_drop += pdem[q]
            rm = max_concentration * F[i, VOL] - F[i, SED]
            if capacity_on:
                gx, gy = _grad(h, I[i, CELL], nx, ny, sp)
                ms = max(math.sqrt(gx * gx + gy * gy), min_slope)
                rm = min(rm, _drop_capacity(F, I, i, ms, cap_k, max_age, fade) - F[i, SED])
                rm = min(rm, max(-F[i, DH], 0.0) * a)
            rm = max(rm, 0.0)
            lim = rm / per_drop if per_drop > rm else 1.0
            for q in range(kk, kk + k):
                pdem[q] *= lim
                key = fc[q] * L + cd
                fc[q] = key
                nt = _add(sk, st, touched, nt, key, pdem[q])
            ent[ne, 0] = i
            ent[ne, 1] = kk
            ent[ne, 2] = cd
            ne += 1
            kk += k
        ent[ne, 1] = kk
        if ne:
            # per key: what is removed; then sk[:, 0] = got / total, sk[:, 1] = removed / got,
            # sk[:, 3] = water released per removed volume (reset below)
            nrel = 0
            for t in range(nt):
                key = touched[t]
                tot = sk[key, 0]
                got = min(tot, max(tf[key] * a, 0.0)) if tot > 0 else 0.0
                sk[key, 0] = got / tot if tot > 0 else 0.0
                corr = 0.0
                if got > 0:
                    corr, excess, actual = _erode_key(key, got, a, capacity[key % L], tf, df, hf)
                    if excess > 0:
                        sk[key, 3] = excess / actual
                        dtouched[nrel] = key
                        nrel += 1
                sk[key, 1] = corr
            for e in range(ne):
                i = ent[e, 0]
                taken = 0.0
                back = 0.0
                for q in range(ent[e, 1], ent[e + 1, 1]):
                    key = fc[q]
                    g = pdem[q] * sk[key, 0] * sk[key, 1]
                    taken += g
                    back += g * sk[key, 3]
                F[i, SED] += taken
                F[i, VOL] += back
                if taken > 0:
                    I[i, KIND] = ent[e, 2]
            for t in range(nrel):
                sk[dtouched[t], 3] = 0.0
        # --- deposition beyond the capacity -------------------------------------------------------
        if capacity_on:
            nd = 0
            for i in range(lo, hi):
                gx, gy = _grad(h, I[i, CELL], nx, ny, sp)
                ms = max(math.sqrt(gx * gx + gy * gy), min_slope)
                extra = max(F[i, SED] - _drop_capacity(F, I, i, ms, cap_k, max_age, fade), 0.0) * deposition_rate
                if not I[i, MOV]:
                    extra = F[i, SED]
                extra = max(extra, min(max(F[i, DH], 0.0) * a, F[i, SED]))
                if extra > 0:
                    nd = _lay(nx, ny, L, i, extra, F, I, mode, oy, ox, ow, fc, fw, sk, dtouched, nd)
                    F[i, SED] -= extra
            _laid(a, tf, df, sk, dtouched, nd)
        # --- empty drops lay what they carry ------------------------------------------------------
        nd = 0
        for i in range(lo, hi):
            if not F[i, VOL] > 0 and F[i, SED] > 0:
                s_ = F[i, SED]
                nd = _lay(nx, ny, L, i, s_, F, I, mode, oy, ox, ow, fc, fw, sk, dtouched, nd)
                F[i, SED] -= s_
        _laid(a, tf, df, sk, dtouched, nd)
    return 0


@njit(cache=True, nogil=True, parallel=True)
def _step(ny, nx, sp, rsp, base, thickness, held, deposit, evaporated, drained, drained_sed, path,
          absorption_rate, capacity, erosion_rate, threshold, roughness, absorbs, erodible,
          pos, vel, volume, sediment, kind, moving, age, n0,
          gravity, friction, adh_k, max_speed, stable_speed, max_age, speed_ref, evaporation,
          cap_k, min_slope, deposition_rate, max_concentration, erode_stabilised, fade, fptag,
          captag, oy, ox, ow, sk, cell_sk, stamps, h, counts, chunks, kept, nth, min_chunk,
          fa, ia, fb, ib, rk, starts, ent, pairs, pkey, touched, dtouched, occs, bufs, ltag,
          since, occupied, obud, wet, wout, wseg, nwet, sparse):
    mode = len(fptag) - 1                         # compile-time constants (see _interact)
    L = thickness.shape[1]
    nb = ny * nx if mode == 0 else 1              # sort buckets: cells, or one (drop order)
    key = rk[:, 0]
    slot = rk[:, 1]
    tf = thickness.reshape(-1)
    hf = held.reshape(-1)
    df = deposit.reshape(-1)
    bad = 0
    for i in prange(n0):
        bad += (sediment[i] > 0) & (kind[i] < 0)
    if bad:
        return -1
    if since:                                     # only the last step's cells changed
        _height_release_cells(sp, base, thickness, held, capacity, evaporated, h, ib, starts,
                              occupied[0], ltag)
    else:
        _height_release(ny, nx, sp, base, thickness, held, capacity, evaporated, h, bufs, nth,
                        ltag)
    # --- move (reading the caller's arrays, in their order: the cell order of the last step
    # plus any drops appended since) into packed rows, drain -----------------------------------
    nout = _move(ny, nx, sp, rsp, h, thickness, roughness, pos, vel, volume, sediment, kind,
                 moving, age, fa, ia, key, mode == 0, n0, gravity, friction, adh_k, max_speed,
                 stable_speed, max_age)
    if nout:
        _drain(fa, ia, key, n0, touched, drained, drained_sed)
    # --- the one-cell footprint interacts in end-cell order (ties in drop order: a stable
    # counting sort, skipped when the drops are in that order already); the others in drop order
    unsorted = 0
    if mode == 0 and not nout:
        for o in prange(1, n0):
            if key[o] < key[o - 1]:
                unsorted += 1
    n = n0
    if nout or unsorted:
        n = _counting_sort(key, n0, nb, counts, slot, min(nth, nb), kept)
    _place(fa, ia, key, slot, not (nout or unsorted), pos, vel, volume, sediment, kind, moving,
           age, fb, ib, n0, nx, ny)
    if mode == 0:                                 # the occupied cells' first drops
        ncell = _cell_starts(ib, n, starts)
    else:                                         # one group: all drops
        ncell = 1
        starts[0] = 0
        starts[1] = n
    # --- with the one-cell footprint, evaporate the cells without drops: the wet ones listed by
    # the last step if it was listed, else the grid; list the cells that may hold water after ---
    if mode == 0 and evaporation > 0:
        if since and 0 <= nwet[0] and nwet[0] * sparse < ny * nx:
            _evaporate_wet(ny, nx, sp, rsp, held, evaporated, h, evaporation, ib, starts, ncell,
                           wet, nwet[0], wout, wseg, nth, ltag, obud)
        else:
            _evaporate(ny, nx, sp, rsp, held, evaporated, h, evaporation, ib, starts, ncell, occs,
                       bufs, nth, ltag, obud, wout, wseg, sparse)
        nwet[0] = _close_list(wout, wseg, nth)
    else:
        nwet[0] = -1
    # --- interact: with the one-cell footprint in chunks of whole cells, one per thread, each
    # writing its drops with water back into the caller's arrays from its first drop on -------
    nt = max(1, min(nth, n // min_chunk)) if mode == 0 else 1
    chunks[0] = 0                                 # per thread: whole cells, about n / nt drops
    for t in range(1, nt):
        chunks[t] = max(np.searchsorted(starts[:ncell], n * t // nt), chunks[t - 1])
    chunks[nt] = ncell
    out = (pos, vel, volume, sediment, kind, moving, age)
    for t in prange(nt):
        lo = starts[chunks[t]]
        hi = starts[chunks[t + 1]]
        e = hi + 1 if mode == 0 else ent.shape[0]     # scratch of the other footprints: all of it
        q = hi + 1 if mode == 0 else pairs.shape[0]
        kept[t] = _interact(ny, nx, sp, thickness, held, tf, hf, df, path, absorption_rate,
                            capacity, erosion_rate, threshold, absorbs, erodible, fb, ib,
                            speed_ref, cap_k, min_slope, deposition_rate, max_concentration,
                            erode_stabilised, max_age, fade, fptag, captag, oy, ox, ow, sk,
                            cell_sk[t], stamps, h, ent[lo:e], pairs[lo:q], pkey[lo:q],
                            touched[lo:q], dtouched[lo:q], starts, chunks[t], chunks[t + 1],
                            evaporated, evaporation, ltag, out, obud)
    # --- the drops with water, in end-cell order, front to back in the caller's arrays: with the
    # one-cell footprint each chunk's are moved down to close the gaps (the empty drops of the
    # chunks before: few); else unpacked in sorted order ---------------------------------------
    if mode == 0:
        m = 0
        for t in range(nt):
            lo = starts[chunks[t]]
            for o in range(kept[t] if lo != m else 0):   # (dest < source: a forward copy)
                pos[m + o, 0] = pos[lo + o, 0]
                pos[m + o, 1] = pos[lo + o, 1]
                vel[m + o, 0] = vel[lo + o, 0]
                vel[m + o, 1] = vel[lo + o, 1]
                volume[m + o] = volume[lo + o]
                sediment[m + o] = sediment[lo + o]
                kind[m + o] = kind[lo + o]
                moving[m + o] = moving[lo + o]
                age[m + o] = age[lo + o]
            m += kept[t]
    else:
        for o in prange(n):
            key[o] = ib[o, CELL] if fb[o, VOL] > 0 else -1
        m = _counting_sort(key, n, ny * nx, counts, slot, nth, kept)
        for o in prange(n):
            if key[o] >= 0:
                _unpack(fb, ib, o, slot[o], pos, vel, volume, sediment, kind, moving, age)
    if evaporation > 0 and mode != 0:
        _evaporate(ny, nx, sp, rsp, held, evaporated, h, evaporation, ib, starts, 0, occs, bufs,
                   nth, ltag, obud, wout, wseg, 0.0)
    occupied[0] = ncell if mode == 0 else -1     # (wider footprints change cells around drops)
    return m


@njit(cache=True, nogil=True, inline="always")
def _evaporate_at(c, budget, held, evaporated, L):
    """particles.evaporate at wet cell c (of L layers) with its budget (_evaporate's)."""
    total = 0.0
    for l in range(L - 1, -1, -1):
        e = min(held[c, l], budget)
        held[c, l] -= e
        budget -= e
        total += e
    evaporated[c] += total
