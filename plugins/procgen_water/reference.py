"""The water rule written the straightforward way: one drop (and one cell) at a time in Python.

It exists to check the vectorised batch (:mod:`particles`) against an independent
implementation of the same equations and the same same-cell sharing (tests), and as the
baseline of benchmarks/water.py.  Deliberately slow: never call it on a real run.
Grid-wide operations that do not depend on drops (the height gradient) use numpy.
"""
from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from .particles import Drops, Surface, surface_gradient

if TYPE_CHECKING:
    from .rules import WaterDrops


def _cell(x: float, y: float, nx: int, ny: int) -> int:
    ix = min(max(int(math.floor(x)), 0), nx - 1)
    iy = min(max(int(math.floor(y)), 0), ny - 1)
    return iy * nx + ix


def _bilin(x: float, y: float, nx: int, ny: int) -> list[tuple[int, float]]:
    u, v = x - 0.5, y - 0.5
    i0 = min(max(int(math.floor(u)), 0), nx - 2)
    j0 = min(max(int(math.floor(v)), 0), ny - 2)
    fu = min(max(u - i0, 0.0), 1.0)
    fv = min(max(v - j0, 0.0), 1.0)
    c = j0 * nx + i0
    return [(c, (1 - fu) * (1 - fv)), (c + 1, fu * (1 - fv)), (c + nx, (1 - fu) * fv), (c + nx + 1, fu * fv)]


def _foot(x: float, y: float, nx: int, ny: int, p: "WaterDrops") -> list[tuple[int, float]]:
    if p.footprint == "bilinear":
        return _bilin(x, y, nx, ny)
    if p.footprint == "disc":
        r = int(math.ceil(p.brush_radius))
        ix0, iy0 = int(math.floor(x)), int(math.floor(y))
        out = []
        for oy in range(-r, r + 1):
            for ox in range(-r, r + 1):
                w = max(p.brush_radius - math.hypot(ox, oy), 0.0)
                ix, iy = ix0 + ox, iy0 + oy
                if w > 0 and 0 <= ix < nx and 0 <= iy < ny:
                    out.append((iy * nx + ix, w))
        tot = sum(w for _, w in out)
        return [(c, w / tot) for c, w in out]
    return [(_cell(x, y, nx, ny), 1.0)]


def _top(s: Surface, c: int) -> int:
    for l in range(s.n_layers - 1, -1, -1):
        if s.thickness[c, l] > 0:
            return l
    return -1


def _cap(s: Surface, c: int, l: int) -> float:
    return s.capacity[l] * s.thickness[c, l] * s.cell_area if l >= 0 else 0.0


def _deposit(s: Surface, d: Drops, i: int, amount: float, p: "WaterDrops") -> None:
    if amount <= 0:
        return
    ny, nx = s.shape
    k = int(d.kind[i])
    for c, w in _foot(d.pos[i, 0], d.pos[i, 1], nx, ny, p):
        s.thickness[c, k] += amount * w / s.cell_area
        s.deposit[c, k] += amount * w / s.cell_area
    d.sediment[i] -= amount


def step_loop(s: Surface, d: Drops, p: "WaterDrops") -> Drops:
    """Same semantics as :func:`particles.step`, drop by drop (and the same drop order out)."""
    ny, nx = s.shape
    a = s.cell_area
    L = s.n_layers
    # release water above capacity
    for c in np.flatnonzero(s.held.any(axis=1)):      # wet cells only (a dry cell has nothing)
        for l in range(L):
            if s.held[c, l] > 0:
                ex = s.held[c, l] - _cap(s, c, l)
                if ex > 0:
                    s.held[c, l] -= ex
                    s.evaporated[c] += ex
    gx, gy = surface_gradient(s)
    gxf, gyf = gx.ravel(), gy.ravel()
    h = s.height()
    n = len(d)
    speed = [math.hypot(d.vel[i, 0], d.vel[i, 1]) for i in range(n)]
    dh = [0.0] * n
    gone = []
    for i in range(n):
        if not d.moving[i]:
            continue
        x, y = d.pos[i]
        cs = _bilin(x, y, nx, ny)
        gxi = sum(gxf[c] * w for c, w in cs)
        gyi = sum(gyf[c] * w for c, w in cs)
        s2 = gxi * gxi + gyi * gyi
        ax, ay = -p.gravity * gxi / (1 + s2), -p.gravity * gyi / (1 + s2)
        amag = math.hypot(ax, ay)
        c0 = _cell(x, y, nx, ny)
        t = _top(s, c0)
        mu = s.roughness[t] if t >= 0 else 0.0
        vol = max(d.volume[i], 1e-300)
        r = (3 * vol / (4 * math.pi)) ** (1 / 3)
        adh = p.adhesion * 0.75 * math.sin(math.radians(p.contact_angle)) ** 2 / r
        grip = mu * (p.gravity / math.sqrt(1 + s2) + adh)
        vx = d.vel[i, 0] * (1 - p.friction) + ax
        vy = d.vel[i, 1] * (1 - p.friction) + ay
        sp = math.hypot(vx, vy)
        keep = 1 - grip / sp if sp > grip else 0.0
        vx, vy, sp = vx * keep, vy * keep, sp * keep
        vmax = p.max_speed * s.spacing
        if sp > vmax:
            vx, vy, sp = vx * vmax / sp, vy * vmax / sp, vmax
        nxp, nyp = x + vx / s.spacing, y + vy / s.spacing
        cx = min(max(nxp, 0.0), nx * (1 - 1e-12))
        cy = min(max(nyp, 0.0), ny * (1 - 1e-12))
        dh[i] = sum(h[c] * w for c, w in _bilin(cx, cy, nx, ny)) - sum(h[c] * w for c, w in cs)
        age = d.age[i] + 1
        stop = (sp < p.stable_speed * s.spacing) and (amag <= grip)
        if p.max_age > 0 and age >= p.max_age:
            stop = True
        d.pos[i] = (nxp, nyp)
        d.vel[i] = (0.0, 0.0) if stop else (vx, vy)
        d.age[i] = age
        d.moving[i] = not stop
        speed[i] = 0.0 if stop else sp
        if nxp < 0 or nxp >= nx or nyp < 0 or nyp >= ny:
            s.drained[c0] += d.volume[i]
            s.drained_sediment[c0] += d.sediment[i]
            gone.append(i)
    if gone:
        keep_mask = np.ones(n, bool)
        keep_mask[gone] = False
        d = d.take(keep_mask)
        speed = [v for v, k in zip(speed, keep_mask) if k]
        dh = [v for v, k in zip(dh, keep_mask) if k]
        n = len(d)
    for i in range(n):
        if d.moving[i]:
            s.path[_cell(d.pos[i, 0], d.pos[i, 1], nx, ny)] += 1
    cell = [_cell(d.pos[i, 0], d.pos[i, 1], nx, ny) for i in range(n)]
    top = [_top(s, c) for c in cell]
    # absorption: demands, then per (cell, layer) sharing
    demand, tot = {}, {}
    for i in range(n):
        t = top[i]
        if t >= 0 and s.absorbs[t] and d.volume[i] > 0:
            c = cell[i]
            cap = _cap(s, c, t)
            w = s.held[c, t]
            sat = min(max(w / cap, 0.0), 1.0) if cap > 0 else 1.0
            dm = d.volume[i] * s.absorption_rate[t] * (1 - sat) / (1 + speed[i] / p.speed_ref)
            demand[i] = dm
            tot[(c, t)] = tot.get((c, t), 0.0) + dm
    got = {k: min(v, max(_cap(s, *k) - s.held[k], 0.0)) for k, v in tot.items()}
    for k, g in got.items():
        s.held[k] += g
    for i, dm in demand.items():
        k = (cell[i], top[i])
        g = dm * (got[k] / tot[k]) if tot[k] > 0 else 0.0
        v_old = d.volume[i]
        d.volume[i] = max(v_old - g, 0.0)
        dep = d.sediment[i] if d.volume[i] <= 0 else d.sediment[i] * (g / v_old if v_old > 0 else 0.0)
        _deposit(s, d, i, dep, p)
    # erosion by moving drops
    pairs = []                                  # (drop, cell, layer, demand)
    for i in range(n):
        if not ((d.moving[i] or p.erode_stabilised) and d.volume[i] > 0):
            continue
        cand = int(d.kind[i]) if d.kind[i] >= 0 else top[i]
        if cand < 0 or not s.erodible[cand]:
            continue
        mine = []
        for c, w in _foot(d.pos[i, 0], d.pos[i, 1], nx, ny, p):
            dm = 0.0
            if _top(s, c) == cand and w > 0:
                cap = _cap(s, c, cand)
                held = s.held[c, cand]
                sat = held / cap if cap > 0 else 1.0
                th = s.threshold[cand]
                weak = max(sat - th, 0.0) / (1 - th) if th < 1 else 0.0
                dm = w * s.erosion_rate[cand] * weak * (d.volume[i] + held)
            mine.append([i, c, cand, dm])
        per = sum(m[3] for m in mine)
        room = p.max_concentration * d.volume[i] - d.sediment[i]
        if p.sediment_capacity is not None:
            c = cell[i]
            slope = math.hypot(gxf[c], gyf[c])
            fade = min(max(1 - d.age[i] / p.max_age, 0.0), 1.0) if p.capacity_fade and p.max_age > 0 else 1.0
            room = min(room, p.sediment_capacity * d.volume[i] * speed[i] * max(slope, p.min_slope) * fade
                       - d.sediment[i])
            room = min(room, max(-dh[i], 0.0) * a)
        room = max(room, 0.0)
        lim = room / per if per > room and per > 0 else 1.0
        for m in mine:
            m[3] *= lim
        pairs += mine
    etot = {}
    for i, c, l, dm in pairs:
        etot[(c, l)] = etot.get((c, l), 0.0) + dm
    scale, water = {}, {}
    for (c, l), e in etot.items():
        g = min(e, max(s.thickness[c, l] * a, 0.0))
        if g <= 0:
            scale[(c, l)] = 0.0
            continue
        t_old = s.thickness[c, l]
        t_new = max(t_old - g / a, 0.0)
        actual = (t_old - t_new) * a
        s.thickness[c, l] = t_new
        s.deposit[c, l] = max(s.deposit[c, l] - (t_old - t_new), 0.0)
        scale[(c, l)] = actual / e
        ex = max(s.held[c, l] - _cap(s, c, l), 0.0) if actual > 0 else 0.0
        if ex > 0:
            s.held[c, l] -= ex
        water[(c, l)] = ex / actual if actual > 0 else 0.0
    for i, c, l, dm in pairs:
        g = dm * scale.get((c, l), 0.0)
        if g > 0:
            d.sediment[i] += g
            d.volume[i] += g * water.get((c, l), 0.0)
            d.kind[i] = l
    if p.sediment_capacity is not None:
        for i in range(n):
            c = cell[i]
            slope = math.hypot(gxf[c], gyf[c])
            fade = min(max(1 - d.age[i] / p.max_age, 0.0), 1.0) if p.capacity_fade and p.max_age > 0 else 1.0
            capd = p.sediment_capacity * d.volume[i] * speed[i] * max(slope, p.min_slope) * fade
            extra = max(d.sediment[i] - capd, 0.0) * p.deposition_rate
            if not d.moving[i]:
                extra = d.sediment[i]
            extra = max(extra, min(max(dh[i], 0.0) * a, d.sediment[i]))
            _deposit(s, d, i, extra, p)
    alive = [i for i in range(n) if d.volume[i] > 0]
    for i in range(n):
        if d.volume[i] <= 0 and d.sediment[i] > 0:
            _deposit(s, d, i, d.sediment[i], p)
    if len(alive) < n:
        mask = np.zeros(n, bool)
        mask[alive] = True
        d = d.take(mask)
    d.sediment = np.maximum(d.sediment, 0.0)
    # evaporation, top-most wet layer first
    if p.evaporation > 0:
        for c in np.flatnonzero(s.held.any(axis=1)):
            budget = p.evaporation * a * math.sqrt(1 + gxf[c] ** 2 + gyf[c] ** 2)
            tot_e = 0.0
            for l in range(L - 1, -1, -1):
                e = min(s.held[c, l], budget)
                s.held[c, l] -= e
                budget -= e
                tot_e += e
            s.evaporated[c] += tot_e
    return d.in_cell_order(s.shape)
