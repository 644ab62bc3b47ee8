"""Compiled (numba) water-drop step: the same batch semantics as ``particles.step``, in loops.

Why: the numpy step spends ~1.7 us per drop-step in temporaries and gathers; a compiled loop over
the same arithmetic is bound by memory latency (a few cache misses per drop).  Imported only
through :func:`procgen.accel.kernels` (this module needs numba).

Same numbers, bit for bit: the phases of ``particles.step`` run one after the other over all
drops (move, absorb + deposit, erode, deposit beyond capacity, lay and remove the empty drops,
evaporate), each expression is evaluated in the same order, and every ``np.bincount`` becomes
an accumulator summing the same terms in the same order from 0 before adding the total to its
target (tests/test_water_kernels.py checks array equality on all three footprints).  The
surface gradient is evaluated where needed from a start-of-step height buffer (``np.gradient``'s
formulas), not over the whole grid.  With the one-cell footprint the interaction phases visit
the drops sorted by cell (a key only hears its own cell's drops, still in drop order), so the
grid is walked in memory order instead of at random: that is what brings the step near the
memory-latency limit.

Memory: one 32-byte row per (cell, layer) key (sum, value, phase stamp, deposit sum), the
height and a counting-sort buffer are allocated once per Surface, and per-drop scratch grows
geometrically: a step allocates nothing proportional to the grid (``bytes_per_cell``).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

from . import particles as P

_FOOTPRINTS = {"cell": 0, "bilinear": 1, "disc": 2}
_ATTR = "_drop_kernel_work"


class Work:
    """Scratch reused by every compiled step on one Surface: per key (cell, layer) one 32-byte
    row (sum, value, phase stamp, deposit sum), the start-of-step height, a counting-sort
    buffer, and per-drop / per-pair arrays grown geometrically with the drop count."""

    def __init__(self, ncell: int, n_layers: int) -> None:
        self.sk = np.zeros((ncell * n_layers, 4))
        self.stamps = np.zeros(1)
        self.h = np.empty(ncell)
        self.counts = np.empty(ncell + 1, np.int64)
        self.cap = 0
        self.grow(1024, 1)

    def grow(self, n: int, k: int) -> None:
        if n < self.cap and n * k <= self.pkey.shape[0]:
            return
        self.cap = max(n + 1, 2 * self.cap)
        m = self.cap * max(k, 4)
        self.fl = np.empty((self.cap, 4))          # per drop: speed, dh, -, -
        self.il = np.empty((self.cap, 4), np.int64)  # per drop: cell, top, order, -
        self.pairs = np.empty((m, 2))              # per pair: footprint weight, demand
        self.pkey = np.empty((m, 2), np.int64)     # per pair: drop, cell / key
        self.touched = np.empty(m, np.int64)
        self.dtouched = np.empty(m, np.int64)

    @property
    def grid_bytes(self) -> int:
        return self.sk.nbytes + self.h.nbytes + self.counts.nbytes

    @property
    def nbytes(self) -> int:
        return self.grid_bytes + sum(a.nbytes for a in (self.fl, self.il, self.pairs, self.pkey,
                                                        self.touched, self.dtouched))


def bytes_per_cell(n_layers: int) -> int:
    """Scratch bytes per grid cell kept by the compiled path (key rows, height, sort counts)."""
    return 32 * n_layers + 16


def step(s: "P.Surface", d: "P.Drops", p) -> "P.Drops":
    """``particles.step`` on the compiled path (same arguments, same result)."""
    work = s.__dict__.get(_ATTR)
    if work is None or work.h.size != s.ncell or work.sk.shape[0] != s.thickness.size:
        work = Work(s.ncell, s.n_layers)
        s.__dict__[_ATTR] = work
    fp = _FOOTPRINTS[p.footprint]
    oy, ox, ow = P._disc_offsets(p.brush_radius) if fp == 2 else (np.zeros(1, np.int64),) * 2 + (np.ones(1),)
    k = ox.size if fp == 2 else (4 if fp == 1 else 1)
    n = len(d)
    work.grow(n, k)
    pos, vel = np.ascontiguousarray(d.pos), np.ascontiguousarray(d.vel)
    kind, moving, age = d.kind, d.moving, d.age
    volume, sediment = d.volume, d.sediment
    adh_k = p.adhesion * 0.75 * np.sin(np.radians(p.contact_angle)) ** 2   # as in particles.move
    cap_k = -1.0 if p.sediment_capacity is None else float(p.sediment_capacity)
    fade = 1 if (p.capacity_fade and p.max_age > 0) else 0
    m = _step(s.shape[0], s.shape[1], float(s.spacing), s.base, s.thickness, s.held, s.deposit,
              s.evaporated, s.drained, s.drained_sediment, s.path,
              s.absorption_rate, s.capacity, s.erosion_rate, s.threshold, s.roughness,
              s.absorbs, s.erodible,
              pos, vel, volume, sediment, kind, moving, age, n,
              float(p.gravity), float(p.friction), float(adh_k), float(p.max_speed),
              float(p.stable_speed), int(p.max_age), float(p.speed_ref), float(p.evaporation),
              cap_k, float(p.min_slope), float(p.deposition_rate), float(p.max_concentration),
              bool(p.erode_stabilised), fade, fp, oy.astype(np.int64), ox.astype(np.int64),
              ow.astype(np.float64), work.sk, work.stamps, work.h, work.counts, work.fl, work.il,
              work.pairs, work.pkey, work.touched, work.dtouched)
    return P.Drops(pos[:m], vel[:m], volume[:m], sediment[:m], kind[:m], moving[:m], age[:m])


# --------------------------------------------------------------------------------------------
# helpers (each mirrors one numpy expression of particles.py)

@njit(cache=True, nogil=True, inline="always")
def _clip(x, lo, hi):
    return min(max(x, lo), hi)


@njit(cache=True, nogil=True)
def _pairwise_sum(a, start, n):
    """numpy's row sum (pairwise_sum: sequential below 8 terms, 8 accumulators up to 128)."""
    if n < 8:
        res = 0.0
        for i in range(n):
            res += a[start + i]
        return res
    r = np.empty(8)
    for j in range(8):
        r[j] = a[start + j]
    i = 8
    while i < n - (n % 8):
        for j in range(8):
            r[j] += a[start + i + j]
        i += 8
    res = ((r[0] + r[1]) + (r[2] + r[3])) + ((r[4] + r[5]) + (r[6] + r[7]))
    while i < n:
        res += a[start + i]
        i += 1
    return res


@njit(cache=True, nogil=True, inline="always")
def _grad_ij(h, c, i, j, nx, ny, sp):
    """(dh/dx, dh/dy) at cell c = (column i, row j): np.gradient's central / one-sided
    differences."""
    if i == 0:
        gx = (h[c + 1] - h[c]) / sp
    elif i == nx - 1:
        gx = (h[c] - h[c - 1]) / sp
    else:
        gx = (h[c + 1] - h[c - 1]) / (2.0 * sp)
    if j == 0:
        gy = (h[c + nx] - h[c]) / sp
    elif j == ny - 1:
        gy = (h[c] - h[c - nx]) / sp
    else:
        gy = (h[c + nx] - h[c - nx]) / (2.0 * sp)
    return gx, gy


@njit(cache=True, nogil=True, inline="always")
def _grad(h, c, nx, ny, sp):
    return _grad_ij(h, c, c % nx, c // nx, nx, ny, sp)


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


@njit(cache=True, nogil=True)
def _height_at(h, x, y, nx, ny):
    c, fu, fv = _corners(x, y, nx, ny)
    res = 0.0
    res += h[c] * ((1 - fu) * (1 - fv))
    res += h[c + 1] * (fu * (1 - fv))
    res += h[c + nx] * ((1 - fu) * fv)
    res += h[c + nx + 1] * (fu * fv)
    return res


@njit(cache=True, nogil=True)
def _footprint(x, y, nx, ny, mode, oy, ox, ow, cells, w, base):
    """Cells and weights of one drop's footprint into cells/w[base:base + k]; returns k."""
    if mode == 0:
        cells[base] = _cell_of(x, y, nx, ny)
        w[base] = 1.0
        return 1
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
    tot = _pairwise_sum(w, base, k)
    for q in range(k):
        w[base + q] = w[base + q] / tot
    return k


@njit(cache=True, nogil=True, inline="always")
def _add(sk, stamp, touched, nt, key, x):
    """sk[key, 0] += x for this phase (``stamp``): the first touch zeroes the key's columns 0-1
    and records it, so no pass is needed to clean up afterwards."""
    if sk[key, 2] != stamp:
        sk[key, 2] = stamp
        sk[key, 0] = 0.0
        sk[key, 1] = 0.0
        touched[nt] = key
        nt += 1
    sk[key, 0] += x
    return nt


@njit(cache=True, nogil=True)
def _lay(nx, ny, L, i, amount, pos, kind, mode, oy, ox, ow, fc, fw, sk, dtouched, nd):
    """Add drop i's deposit of ``amount`` > 0 over its footprint to the deposit column
    sk[:, 3] (zero at rest; only positive terms, so a key is new while its sum is 0)."""
    if kind[i] < 0:
        raise AssertionError("a drop carrying sediment has no sediment kind")
    k = _footprint(pos[i, 0], pos[i, 1], nx, ny, mode, oy, ox, ow, fc, fw, 0)
    for q in range(k):
        x = amount * fw[q]
        if x != 0.0:
            key = fc[q] * L + kind[i]
            if sk[key, 3] == 0.0:
                dtouched[nd] = key
                nd += 1
            sk[key, 3] += x
    return nd


@njit(cache=True, nogil=True)
def _laid(a, thickness, deposit, sk, dtouched, nd):
    """particles._deposit's ``thickness += bincount(...) / a`` for the keys laid on."""
    tf = thickness.reshape(-1)
    df = deposit.reshape(-1)
    for t in range(nd):
        key = dtouched[t]
        add = sk[key, 3] / a
        tf[key] += add
        df[key] += add
        sk[key, 3] = 0.0


@njit(cache=True, nogil=True, inline="always")
def _shift(pos, vel, volume, sediment, kind, moving, age, m, i):
    """Drop i moves to slot m <= i (compaction keeps the drop order, as ``Drops.take``)."""
    pos[m, 0] = pos[i, 0]
    pos[m, 1] = pos[i, 1]
    vel[m, 0] = vel[i, 0]
    vel[m, 1] = vel[i, 1]
    volume[m] = volume[i]
    sediment[m] = sediment[i]
    kind[m] = kind[i]
    moving[m] = moving[i]
    age[m] = age[i]


@njit(cache=True, nogil=True)
def _sort_by_cell(pos, n, nx, ny, cell, counts, order):
    """order[:n] = drops sorted by cell, then by index (a counting sort; counts has ncell + 1)."""
    for i in range(n):
        cell[i] = _cell_of(pos[i, 0], pos[i, 1], nx, ny)
    counts[:] = 0
    for i in range(n):
        counts[cell[i] + 1] += 1
    for c in range(nx * ny):
        counts[c + 1] += counts[c]
    for i in range(n):
        order[counts[cell[i]]] = i
        counts[cell[i]] += 1


@njit(cache=True, nogil=True)
def _step(ny, nx, sp, base, thickness, held, deposit, evaporated, drained, drained_sed, path,
          absorption_rate, capacity, erosion_rate, threshold, roughness, absorbs, erodible,
          pos, vel, volume, sediment, kind, moving, age, n,
          gravity, friction, adh_k, max_speed, stable_speed, max_age, speed_ref, evaporation,
          cap_k, min_slope, deposition_rate, max_concentration, erode_stabilised, fade, mode,
          oy, ox, ow, sk, stamps, h, counts, fl, il, pairs, pkey, touched, dtouched):
    ncell = ny * nx
    L = thickness.shape[1]
    a = sp * sp
    tf = thickness.reshape(-1)
    hf = held.reshape(-1)
    # --- release_excess + height (one pass over the grid) -------------------------------------
    for c in range(ncell):
        wet = False
        for l in range(L):
            if held[c, l] != 0:
                wet = True
        if wet:
            tot = 0.0
            for l in range(L):
                ex = max(held[c, l] - capacity[l] * thickness[c, l] * a, 0.0)
                if ex > 0:
                    held[c, l] -= ex
                    tot += ex
            if tot > 0:
                evaporated[c] += tot
        hc = base[c]
        for l in range(L):
            hc += thickness[c, l]
        h[c] = hc
    # --- move (drops do not interact while moving: visited by cell, the grid in memory order) ---
    speed = fl[:, 0]
    dh = fl[:, 1]
    cell = il[:, 0]
    order = il[:, 2]
    out = il[:, 3]
    _sort_by_cell(pos, n, nx, ny, cell, counts, order)
    vmax = max_speed * sp
    hi_x = nx * (1 - 1e-12)
    hi_y = ny * (1 - 1e-12)
    nout = 0
    for o in range(n):
        i = order[o]
        dh[i] = 0.0
        out[i] = 0
        if not moving[i]:
            vx = vel[i, 0]
            vy = vel[i, 1]
            speed[i] = math.hypot(vx, vy) if (vx != 0.0 or vy != 0.0) else 0.0
            continue
        x = pos[i, 0]
        y = pos[i, 1]
        c, fu, fv = _corners(x, y, nx, ny)
        ci = c % nx
        cj = c // nx
        w0 = (1 - fu) * (1 - fv)
        w1 = fu * (1 - fv)
        w2 = (1 - fu) * fv
        w3 = fu * fv
        g0x, g0y = _grad_ij(h, c, ci, cj, nx, ny, sp)
        g1x, g1y = _grad_ij(h, c + 1, ci + 1, cj, nx, ny, sp)
        g2x, g2y = _grad_ij(h, c + nx, ci, cj + 1, nx, ny, sp)
        g3x, g3y = _grad_ij(h, c + nx + 1, ci + 1, cj + 1, nx, ny, sp)
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
        vol = max(volume[i], 1e-300)
        r = np.cbrt(3.0 * vol / (4.0 * np.pi))
        adh = adh_k / r
        grip = mu * (gravity / math.sqrt(1.0 + s2) + adh)
        vx = vel[i, 0] * (1.0 - friction) + ax
        vy = vel[i, 1] * (1.0 - friction) + ay
        spd = math.hypot(vx, vy)
        keep = 1.0 - grip / spd if spd > grip else 0.0
        vx *= keep
        vy *= keep
        spd = spd * keep
        if spd > vmax:
            f = vmax / spd
            vx *= f
            vy *= f
            spd = min(spd, vmax)
        nxp = x + vx / sp
        nyp = y + vy / sp
        dh[i] = _height_at(h, _clip(nxp, 0.0, hi_x), _clip(nyp, 0.0, hi_y), nx, ny) \
            - _height_at(h, x, y, nx, ny)
        ag = age[i] + 1
        stop = (spd < stable_speed * sp) and (math.hypot(ax, ay) <= grip)
        if max_age > 0:
            stop = stop or ag >= max_age
        pos[i, 0] = nxp
        pos[i, 1] = nyp
        vel[i, 0] = 0.0 if stop else vx
        vel[i, 1] = 0.0 if stop else vy
        age[i] = ag
        moving[i] = not stop
        speed[i] = 0.0 if stop else spd
        if nxp < 0 or nxp >= nx or nyp < 0 or nyp >= ny:
            out[i] = 1
            cell[i] = cc
            nout += 1
    if nout:
        # drained water and sediment, each summed per cell in drop order, then added
        stamps[0] += 1.0
        nt = 0
        for i in range(n):
            if out[i]:
                key = cell[i] * L
                nt = _add(sk, stamps[0], touched, nt, key, volume[i])
                sk[key, 1] += sediment[i]
        for t in range(nt):
            key = touched[t]
            drained[key // L] += sk[key, 0]
            drained_sed[key // L] += sk[key, 1]
        m = 0
        for i in range(n):
            if not out[i]:
                _shift(pos, vel, volume, sediment, kind, moving, age, m, i)
                speed[m] = speed[i]
                dh[m] = dh[i]
                m += 1
        n = m
    # --- the interaction order: by cell, then drop index ---------------------------------------
    # With the one-cell footprint every key (cell, layer) only hears drops of its own cell, so
    # this order sums each key's terms in drop order (as np.bincount does) while the grid is
    # walked in memory order; wider footprints keep the drop order.
    top_a = il[:, 1]
    _sort_by_cell(pos, n, nx, ny, cell, counts, order)
    for o in range(n):
        i = order[o]
        c = cell[i]
        top_a[i] = _top(thickness, c, L)
        if moving[i]:
            path[c] += 1.0
    if mode != 0:
        for i in range(n):
            order[i] = i
    if n == 0:
        _evaporate(ny, nx, sp, h, held, evaporated, evaporation)
        return 0
    fc = pkey[:, 1]
    fw = pairs[:, 0]
    # --- interact: absorption (demand per key, grant, deposition by concentration) ----------------
    stamps[0] += 1.0
    st = stamps[0]
    nt = 0
    na = 0
    ent = pkey[:, 0]
    for o in range(n):
        i = order[o]
        tp = top_a[i]
        tk = max(tp, 0)
        if not (tp >= 0 and absorbs[tk] and volume[i] > 0):
            continue
        c = cell[i]
        cap = capacity[tk] * thickness[c, tk] * a
        w = held[c, tk]
        sat = _clip(w / cap, 0.0, 1.0) if cap > 0 else 1.0
        demand = volume[i] * absorption_rate[tk] * (1.0 - sat) / (1.0 + speed[i] / speed_ref)
        key = c * L + tk
        pairs[na, 1] = demand
        ent[na] = i
        il[na, 3] = key
        na += 1
        nt = _add(sk, st, touched, nt, key, demand)
    if na:
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
            i = ent[e]
            key = il[e, 3]
            tk_ = sk[key, 0]
            g = pairs[e, 1] * (sk[key, 1] / tk_) if tk_ > 0 else 0.0
            v_old = volume[i]
            volume[i] = max(v_old - g, 0.0)
            frac = g / v_old if v_old > 0 else 0.0
            dep = sediment[i] if volume[i] <= 0 else sediment[i] * frac
            if dep > 0:
                nd = _lay(nx, ny, L, i, dep, pos, kind, mode, oy, ox, ow, fc, fw, sk, dtouched, nd)
                sediment[i] -= dep
        _laid(a, thickness, deposit, sk, dtouched, nd)
    # --- erosion by moving drops ------------------------------------------------------------------
    stamps[0] += 1.0
    st = stamps[0]
    nt = 0
    kk = 0
    ne = 0
    pdem = pairs[:, 1]
    first = il[:, 3]
    for o in range(n):
        i = order[o]
        if not ((moving[i] or erode_stabilised) and volume[i] > 0):
            continue
        cd = kind[i] if kind[i] >= 0 else top_a[i]
        if not (cd >= 0 and erodible[cd]):
            continue
        k = _footprint(pos[i, 0], pos[i, 1], nx, ny, mode, oy, ox, ow, fc, fw, kk)
        per_drop = 0.0
        for q in range(kk, kk + k):
            pc = fc[q]
            cap = capacity[cd] * thickness[pc, cd] * a
            hd = held[pc, cd]
            sat = hd / cap if cap > 0 else 1.0
            th = threshold[cd]
            weak = max(sat - th, 0.0) / (1.0 - th) if th < 1.0 else 0.0
            liquid = volume[i] + hd
            if _top(thickness, pc, L) == cd and fw[q] > 0:
                pdem[q] = fw[q] * erosion_rate[cd] * weak * liquid
            else:
                pdem[q] = 0.0
            per_drop += pdem[q]
        rm = max_concentration * volume[i] - sediment[i]
        if cap_k >= 0:
            gx, gy = _grad(h, cell[i], nx, ny, sp)
            slope = math.hypot(gx, gy)
            capd = cap_k * volume[i] * speed[i] * max(slope, min_slope)
            capd = capd * (_clip(1.0 - age[i] / max_age, 0.0, 1.0) if fade else 1.0)
            rm = min(rm, capd - sediment[i])
            rm = min(rm, max(-dh[i], 0.0) * a)
        rm = max(rm, 0.0)
        lim = rm / per_drop if per_drop > rm else 1.0
        for q in range(kk, kk + k):
            pdem[q] *= lim
            key = fc[q] * L + cd
            fc[q] = key
            nt = _add(sk, st, touched, nt, key, pdem[q])
        ent[ne] = i
        first[ne] = kk
        fl[ne, 2] = cd
        ne += 1
        kk += k
    first[ne] = kk
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
                t_old = tf[key]
                t_new = max(t_old - got / a, 0.0)
                actual = (t_old - t_new) * a
                tf[key] = t_new
                df = deposit.reshape(-1)
                df[key] = max(df[key] - (t_old - t_new), 0.0)
                corr = actual / got
                c = key // L
                l = key % L
                capn = capacity[l] * thickness[c, l] * a
                excess = max(hf[key] - capn, 0.0) if actual > 0 else 0.0
                if excess > 0:
                    hf[key] -= excess
                    sk[key, 3] = excess / (actual if actual > 0 else 1.0)
                    dtouched[nrel] = key
                    nrel += 1
            sk[key, 1] = corr
        for e in range(ne):
            i = ent[e]
            taken = 0.0
            back = 0.0
            for q in range(first[e], first[e + 1]):
                key = fc[q]
                g = pdem[q] * sk[key, 0] * sk[key, 1]
                taken += g
                back += g * sk[key, 3]
            sediment[i] += taken
            volume[i] += back
            if taken > 0:
                kind[i] = int(fl[e, 2])
        for t in range(nrel):
            sk[dtouched[t], 3] = 0.0
    # --- deposition beyond the capacity -------------------------------------------------------------
    if cap_k >= 0:
        nd = 0
        for o in range(n):
            i = order[o]
            gx, gy = _grad(h, cell[i], nx, ny, sp)
            slope = math.hypot(gx, gy)
            capd = cap_k * volume[i] * speed[i] * max(slope, min_slope)
            capd = capd * (_clip(1.0 - age[i] / max_age, 0.0, 1.0) if fade else 1.0)
            extra = max(sediment[i] - capd, 0.0) * deposition_rate
            if not moving[i]:
                extra = sediment[i]
            extra = max(extra, min(max(dh[i], 0.0) * a, sediment[i]))
            if extra > 0:
                nd = _lay(nx, ny, L, i, extra, pos, kind, mode, oy, ox, ow, fc, fw, sk, dtouched, nd)
                sediment[i] -= extra
        _laid(a, thickness, deposit, sk, dtouched, nd)
    # --- empty drops lay what they carry and leave ----------------------------------------------------
    nd = 0
    for o in range(n):
        i = order[o]
        if not volume[i] > 0 and sediment[i] > 0:
            s_ = sediment[i]
            nd = _lay(nx, ny, L, i, s_, pos, kind, mode, oy, ox, ow, fc, fw, sk, dtouched, nd)
            sediment[i] -= s_
    _laid(a, thickness, deposit, sk, dtouched, nd)
    m = 0
    for i in range(n):
        if volume[i] > 0:
            _shift(pos, vel, volume, sediment, kind, moving, age, m, i)
            sediment[m] = max(sediment[m], 0.0)
            m += 1
    _evaporate(ny, nx, sp, h, held, evaporated, evaporation)
    return m


@njit(cache=True, nogil=True)
def _evaporate(ny, nx, sp, h, held, evaporated, evaporation):
    """particles.evaporate with the start-of-step gradient."""
    if evaporation <= 0:
        return
    L = held.shape[1]
    a = sp * sp
    for c in range(ny * nx):
        wet = False
        for l in range(L):
            if held[c, l] != 0:
                wet = True
        if not wet:
            continue
        gx, gy = _grad(h, c, nx, ny, sp)
        budget = evaporation * (a * math.sqrt(1.0 + gx * gx + gy * gy))
        total = 0.0
        for l in range(L - 1, -1, -1):
            e = min(held[c, l], budget)
            held[c, l] -= e
            budget -= e
            total += e
        evaporated[c] += total
