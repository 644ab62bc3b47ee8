"""Water particles on the 2.5D multi-layer surface, as one batch (thesis 2.4.2, digest 4, 17 #9).

All drops of a step are updated together with numpy; whatever several drops do to one cell in
one step (absorb, erode, deposit) is gathered with ``np.bincount`` and capped per cell, then
shared back in proportion to each drop's demand, so conservation never depends on order.

Choices for the thesis's unstated equations (the thesis gives the rules in words only):

* motion: horizontal velocity v; gravity along the slope a = -g grad(h) / (1 + |grad h|^2)
  (a bead on an incline); viscous ``friction`` damps v each step; Coulomb friction with the
  exposed material's ``roughness`` opposes motion with strength mu (g cos(theta) + adhesion),
  where adhesion = ``adhesion`` * contact area / volume of a spherical drop whose contact disc
  has radius r sin(``contact_angle``): small drops cling more.  Speed is capped at
  ``max_speed`` (cells/step) so drops do not skip cells.
* stabilised: a drop slower than ``stable_speed`` whose driving force cannot beat friction (or
  older than ``max_age``) stops moving for good; it keeps seeping into the cell beneath.
* absorption into the exposed layer under the drop: demand = V absorption_rate (1 - w/cap)
  / (1 + speed/speed_ref), cap = capacity * thickness * cell area; shared per cell so w <= cap.
* deposition by absorption: a drop losing dV deposits (S/V) dV (its concentration is kept).
* erosion by moving drops of the exposed layer, only if its material is erodible and the cell's
  saturation w/cap exceeds the weakness threshold theta (non-absorbent material: saturation 1):
  dE = erosion_rate * (w/cap - theta)+ / (1 - theta) * (V + w), the liquid involved being the
  drop plus the water already released in the cell; capped by the thickness present, by the
  drop's sediment capacity (optional, k V speed max(slope, min_slope): classic terrain
  erosion) and by the concentration limit S <= max_concentration V.  With a capacity, a drop
  never erodes more than the height it just descended, and a drop moving uphill first fills
  the hollow it leaves (the usual particle-erosion rules that stop self-dug pits).
  Optionally (``capacity_fade``) the capacity fades linearly with age to 0 at ``max_age``:
  the drop-level stand-in for the evaporating drops of classic erosion, since the thesis's
  drops never evaporate.  Water held in eroded
  solid beyond the new capacity is released into the eroding drops.
* one sediment type per drop: the first layer it erodes; it erodes only that material.
  Deposits rejoin their source layer (so deposited patina renders as thin patina), and are
  tracked in a deposit map.  With a sediment capacity, a drop carrying more than its capacity
  drops ``deposition_rate`` of the excess.
* evaporation: water held in a cell evaporates at ``evaporation`` per unit of true surface
  area (cell area * sqrt(1 + |grad h|^2)), top-most wet layer first; drops never evaporate.
* drops leaving the grid are drained (their water and sediment go to the drain ledgers);
  on a periodic (torus) grid nothing drains: a drop leaving an edge comes back at the opposite
  one, and gradients, interpolation and footprints wrap too, so the maps tile.

Ledgers (exact to float rounding at every step):
  water:    sum(drop volume) + sum(held) + sum(evaporated) + sum(drained water) = sum(emitted)
  sediment: sum(thickness * cell area) + sum(carried) + sum(drained sediment) - sum(source)
            = baseline  (``source`` records solid made or destroyed by other processes, e.g.
            corrosion turning metal into oxide)
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING

import numpy as np

from procgen import arena, portable
from procgen.accel import MIN_DROPS, kernels
from procgen.errors import InputError

if TYPE_CHECKING:                      # the drop model's numbers are the water.drops rule's parameters
    from .rules import WaterDrops


@dataclass
class Surface:
    """Views of the grid fields the drops act on; (ncell, L) arrays are cell-major."""

    shape: tuple[int, int]
    spacing: float
    base: np.ndarray                  # (ncell,)
    thickness: np.ndarray             # (ncell, L)
    held: np.ndarray                  # (ncell, L) water held in each layer
    deposit: np.ndarray               # (ncell, L) deposited thickness (part of thickness)
    emitted: np.ndarray               # (ncell,) cumulative water emitted here
    evaporated: np.ndarray            # (ncell,) cumulative water evaporated here
    drained: np.ndarray               # (ncell,) water drained off the grid from here
    drained_sediment: np.ndarray      # (ncell,) sediment drained off the grid from here
    source: np.ndarray                # (ncell,) solid made (+) / destroyed (-) by other rules
    path: np.ndarray                  # (ncell,) moving-drop visits
    # per-layer material arrays (L,)
    absorption_rate: np.ndarray = field(default_factory=lambda: np.zeros(0))
    capacity: np.ndarray = field(default_factory=lambda: np.zeros(0))
    erosion_rate: np.ndarray = field(default_factory=lambda: np.zeros(0))
    threshold: np.ndarray = field(default_factory=lambda: np.zeros(0))
    roughness: np.ndarray = field(default_factory=lambda: np.zeros(0))
    absorbs: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    erodible: np.ndarray = field(default_factory=lambda: np.zeros(0, bool))
    steps: int = 0                    # step() calls on this surface (a cache knows if it is current)
    periodic: bool = False            # a torus: neighbours, drops and footprints wrap at the edges

    @property
    def ncell(self) -> int:
        return self.shape[0] * self.shape[1]

    @property
    def n_layers(self) -> int:
        return self.thickness.shape[1]

    @property
    def cell_area(self) -> float:
        return self.spacing * self.spacing

    def height(self) -> np.ndarray:
        """Top surface height per cell (ncell,)."""
        h = self.base.copy()
        for l in range(self.thickness.shape[1]):     # column adds beat a short-axis reduction
            h += self.thickness[:, l]
        return h

    def wet_cells(self) -> np.ndarray:
        """Cells holding water in any layer."""
        wet = self.held[:, 0] != 0
        for l in range(1, self.held.shape[1]):
            wet |= self.held[:, l] != 0
        return np.flatnonzero(wet)

    def top_layer(self, cells: np.ndarray | slice = slice(None)) -> np.ndarray:
        """Index of the highest layer with thickness > 0 at ``cells`` (-1 where none: a hole)."""
        t = self.thickness[cells]
        top = np.full(t.shape[0], -1, dtype=np.int64)
        for l in range(t.shape[1]):             # a handful of layers: one vector op each
            top[t[:, l] > 0] = l
        return top

    def capacity_of(self, cells: np.ndarray, layers: np.ndarray) -> np.ndarray:
        """Water a (cell, layer) can hold: capacity * thickness * cell area (0 for layer -1)."""
        ok = layers >= 0
        lk = np.where(ok, layers, 0)
        return np.where(ok, self.capacity[lk] * self.thickness[cells, lk] * self.cell_area, 0.0)


@dataclass
class Drops:
    """The drop batch.  Positions in cell units (x in [0, nx), y in [0, ny)); velocity in
    length/step (horizontal); volume and sediment in volume units; kind = sediment layer (-1)."""

    pos: np.ndarray
    vel: np.ndarray
    volume: np.ndarray
    sediment: np.ndarray
    kind: np.ndarray
    moving: np.ndarray
    age: np.ndarray

    @classmethod
    def empty(cls) -> "Drops":
        return cls(np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0), np.zeros(0),
                   np.zeros(0, np.int64), np.zeros(0, bool), np.zeros(0, np.int64))

    def __len__(self) -> int:
        return len(self.volume)

    def take(self, keep: np.ndarray) -> "Drops":
        return Drops(self.pos[keep], self.vel[keep], self.volume[keep], self.sediment[keep],
                     self.kind[keep], self.moving[keep], self.age[keep])

    def in_cell_order(self, shape: tuple[int, int]) -> "Drops":
        """The drops in the canonical order every step returns: by cell (row-major), drops of
        one cell in their previous order (a stable sort).  Both step paths keep it, so the
        compiled path walks the grid and the drops front to back without reordering them
        twice; a drop's index is therefore not kept across steps."""
        cell = _cell_of(self.pos, shape)
        if cell.size < 2 or not np.any(cell[1:] < cell[:-1]):
            return self
        return self.take(np.argsort(cell, kind="stable"))

    def concat(self, other: "Drops") -> "Drops":
        return Drops(*(np.concatenate([a, b]) for a, b in zip(
            (self.pos, self.vel, self.volume, self.sediment, self.kind, self.moving, self.age),
            (other.pos, other.vel, other.volume, other.sediment, other.kind, other.moving, other.age))))


# --------------------------------------------------------------------------------------------
# ledgers

def water_ledger(s: Surface, d: Drops) -> dict[str, float]:
    """The water balance; ``error`` = |in drops + held + evaporated + drained - emitted|."""
    parts = {"drops": float(d.volume.sum()), "held": float(s.held.sum()),
             "evaporated": float(s.evaporated.sum()), "drained": float(s.drained.sum()),
             "emitted": float(s.emitted.sum())}
    parts["error"] = abs(parts["drops"] + parts["held"] + parts["evaporated"] + parts["drained"]
                         - parts["emitted"])
    return parts


def sediment_ledger(s: Surface, d: Drops, baseline: float) -> dict[str, float]:
    """The solid balance; ``deposited`` is the part of ``solid`` that drops laid down."""
    a = s.cell_area
    solid = float(s.thickness.sum() * a)
    parts = {"solid": solid, "deposited": float(s.deposit.sum() * a),
             "carried": float(d.sediment.sum()), "drained": float(s.drained_sediment.sum()),
             "source": float(s.source.sum()), "baseline": float(baseline)}
    parts["error"] = float(abs(solid + parts["carried"] + parts["drained"] - parts["source"] - baseline))
    return parts


# --------------------------------------------------------------------------------------------
# helpers

def _bilinear_corners(pos: np.ndarray, shape: tuple[int, int], periodic: bool = False
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Cells (n, 4) and weights (n, 4) of bilinear interpolation between cell centres
    (on a torus the last centre interpolates with the first across the edge)."""
    ny, nx = shape
    u = pos[:, 0] - 0.5
    v = pos[:, 1] - 0.5
    if periodic:
        fi, fj = np.floor(u), np.floor(v)
        fu, fv = u - fi, v - fj
        i0, j0 = fi.astype(np.int64) % nx, fj.astype(np.int64) % ny
        i1, j1 = (i0 + 1) % nx, (j0 + 1) % ny
        cells = np.stack([j0 * nx + i0, j0 * nx + i1, j1 * nx + i0, j1 * nx + i1], axis=1)
        w = np.stack([(1 - fu) * (1 - fv), fu * (1 - fv), (1 - fu) * fv, fu * fv], axis=1)
        return cells, w
    i0 = np.clip(np.floor(u), 0, nx - 2).astype(np.int64)
    j0 = np.clip(np.floor(v), 0, ny - 2).astype(np.int64)
    fu = np.clip(u - i0, 0.0, 1.0)
    fv = np.clip(v - j0, 0.0, 1.0)
    c00 = j0 * nx + i0
    cells = np.stack([c00, c00 + 1, c00 + nx, c00 + nx + 1], axis=1)
    w = np.stack([(1 - fu) * (1 - fv), fu * (1 - fv), (1 - fu) * fv, fu * fv], axis=1)
    return cells, w


def _cell_of(pos: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    ny, nx = shape
    ix = np.clip(np.floor(pos[:, 0]), 0, nx - 1).astype(np.int64)
    iy = np.clip(np.floor(pos[:, 1]), 0, ny - 1).astype(np.int64)
    return iy * nx + ix


def _share(keys: np.ndarray, demand: np.ndarray, available: np.ndarray, n: int
           ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per-key totals capped by ``available`` (given per entry, equal for equal keys), shared
    back in proportion to demand.  Works on the touched keys only (not all ``n``).

    Returns (granted per entry, touched keys, granted total per touched key).
    """
    tot = np.bincount(keys, weights=demand, minlength=n)
    tk = tot[keys]
    got_e = np.minimum(tk, np.maximum(available, 0.0))
    with np.errstate(invalid="ignore", divide="ignore"):
        granted = np.where(tk > 0, demand * (got_e / np.where(tk > 0, tk, 1.0)), 0.0)
    per_key = np.zeros(n)
    per_key[keys] = got_e                       # equal for equal keys: any writer wins
    uk = np.flatnonzero(tot > 0)                # keys with demand (others get nothing)
    return granted, uk, per_key[uk]


def surface_gradient(s: Surface, h: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """dh/dx, dh/dy (ny, nx) of the top surface by central differences (one-sided at edges,
    across them on a periodic grid)."""
    h = (s.height() if h is None else h).reshape(s.shape)
    if s.periodic:
        two = 2.0 * s.spacing
        return ((np.roll(h, -1, axis=1) - np.roll(h, 1, axis=1)) / two,
                (np.roll(h, -1, axis=0) - np.roll(h, 1, axis=0)) / two)
    gy, gx = np.gradient(h, s.spacing)
    return gx, gy


# --------------------------------------------------------------------------------------------
# emission

def emit(s: Surface, p: "WaterDrops", rng: np.random.Generator, n: int, mode: str = "uniform",
         band: float = 0.1, weights: np.ndarray | None = None) -> Drops:
    """``n`` new drops at rest: uniform, in the top band (largest y), or with cell weights."""
    ny, nx = s.shape
    if n <= 0:
        return Drops.empty()
    if mode == "uniform":
        pos = rng.uniform(0.0, 1.0, (n, 2)) * np.array([nx, ny])
    elif mode == "top":
        rows = max(1, int(round(band * ny)))
        pos = rng.uniform(0.0, 1.0, (n, 2)) * np.array([nx, rows]) + np.array([0.0, ny - rows])
    elif mode == "weights":
        w = np.asarray(weights, dtype=float).ravel()
        if w.size != s.ncell or np.any(~np.isfinite(w)) or np.any(w < 0) or w.sum() <= 0:
            raise InputError("emission weights must be a finite, non-negative, non-zero cell map")
        cells = rng.choice(s.ncell, size=n, p=w / w.sum())
        pos = np.stack([cells % nx, cells // nx], axis=1) + rng.uniform(0.0, 1.0, (n, 2))
    else:
        raise InputError(f"emission mode {mode!r} unknown (uniform, top, weights)")
    pos = np.minimum(pos, np.array([nx, ny]) * (1 - 1e-12))
    vol = np.full(n, p.drop_volume)
    s.emitted += np.bincount(_cell_of(pos, s.shape), weights=vol, minlength=s.ncell)
    return Drops(pos, np.zeros((n, 2)), vol, np.zeros(n), np.full(n, -1, np.int64),
                 np.ones(n, bool), np.zeros(n, np.int64))


# --------------------------------------------------------------------------------------------
# one step

def release_excess(s: Surface) -> float:
    """Water above a layer's capacity (after another rule thinned it) leaves as evaporation."""
    wet = s.wet_cells()
    if wet.size == 0:
        return 0.0
    cap = s.capacity[None, :] * s.thickness[wet] * s.cell_area
    excess = np.maximum(s.held[wet] - cap, 0.0)
    tot = float(excess.sum())
    if tot > 0:
        s.held[wet] -= excess
        s.evaporated[wet] += excess.sum(axis=1)
    return tot


def _height_at(h: np.ndarray, pos: np.ndarray, shape: tuple[int, int], periodic: bool = False) -> np.ndarray:
    cells, w = _bilinear_corners(pos, shape, periodic)
    return np.sum(h[cells] * w, axis=1)


def _length(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """|(x, y)| as sqrt(x^2 + y^2): IEEE-754 fixes each of these operations to the bit, where
    ``hypot`` is the C library's own (glibc changed its algorithm in 2.35), so the compiled
    path (kernels.py) and every machine get the same numbers.  Speeds, accelerations and slopes
    are far from where the squares over- or underflow."""
    return np.sqrt(x * x + y * y)


def move(s: Surface, d: Drops, p: "WaterDrops", gx: np.ndarray, gy: np.ndarray,
         h: np.ndarray | None = None) -> tuple[Drops, np.ndarray, np.ndarray]:
    """Advance moving drops one step; drain those that leave.

    Returns (drops, speed, dh) with dh the change of surface height under each drop (0 for
    drops that did not move).
    """
    ny, nx = s.shape
    m = np.flatnonzero(d.moving)
    speed = _length(d.vel[:, 0], d.vel[:, 1])
    dh = np.zeros(len(d))
    if m.size == 0:
        return d, speed, dh
    pos = d.pos[m]
    cells4, w4 = _bilinear_corners(pos, s.shape, s.periodic)
    gxi = np.sum(gx.ravel()[cells4] * w4, axis=1)
    gyi = np.sum(gy.ravel()[cells4] * w4, axis=1)
    s2 = gxi * gxi + gyi * gyi
    ax = -p.gravity * gxi / (1.0 + s2)
    ay = -p.gravity * gyi / (1.0 + s2)
    amag = _length(ax, ay)
    cell = _cell_of(pos, s.shape)
    top = s.top_layer(cell)
    mu = np.where(top >= 0, s.roughness[np.maximum(top, 0)], 0.0)
    vol = np.maximum(d.volume[m], 1e-300)
    r = portable.cbrt(3.0 * vol / (4.0 * np.pi))
    adh = p.adhesion * 0.75 * np.sin(np.radians(p.contact_angle)) ** 2 / r
    grip = mu * (p.gravity / np.sqrt(1.0 + s2) + adh)          # Coulomb deceleration
    v = d.vel[m] * (1.0 - p.friction) + np.stack([ax, ay], axis=1)
    sp = _length(v[:, 0], v[:, 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        keep = np.where(sp > grip, 1.0 - grip / np.where(sp > 0, sp, 1.0), 0.0)
    v *= keep[:, None]
    sp = sp * keep
    vmax = p.max_speed * s.spacing
    over = sp > vmax
    if np.any(over):
        v[over] *= (vmax / sp[over])[:, None]
        sp = np.minimum(sp, vmax)
    new_pos = pos + v / s.spacing
    if s.periodic:                    # re-enter at the opposite edge: nothing leaves a torus
        new_pos = wrap_positions(new_pos, s.shape)
    h = s.height() if h is None else h
    dh[m] = _height_at(h, np.clip(new_pos, 0, np.array([nx, ny]) * (1 - 1e-12)), s.shape, s.periodic) \
        - _height_at(h, pos, s.shape, s.periodic)
    age = d.age[m] + 1
    stop = (sp < p.stable_speed * s.spacing) & (amag <= grip)
    if p.max_age > 0:
        stop |= age >= p.max_age
    d.pos[m] = new_pos
    d.vel[m] = np.where(stop[:, None], 0.0, v)
    d.age[m] = age
    d.moving[m] = ~stop
    speed[m] = np.where(stop, 0.0, sp)
    # drain drops that left the grid, at the last cell they were in
    out = (new_pos[:, 0] < 0) | (new_pos[:, 0] >= nx) | (new_pos[:, 1] < 0) | (new_pos[:, 1] >= ny)
    if np.any(out):
        gone = m[out]
        s.drained += np.bincount(cell[out], weights=d.volume[gone], minlength=s.ncell)
        s.drained_sediment += np.bincount(cell[out], weights=d.sediment[gone], minlength=s.ncell)
        keep_mask = np.ones(len(d), bool)
        keep_mask[gone] = False
        d = d.take(keep_mask)
        speed = speed[keep_mask]
        dh = dh[keep_mask]
    return d, speed, dh


def wrap_positions(pos: np.ndarray, shape: tuple[int, int]) -> np.ndarray:
    """Positions (n, 2) in cell units brought into [0, nx) x [0, ny) on the torus (a tiny
    negative x modulo nx rounds to nx itself: that one is put at 0)."""
    ny, nx = shape
    ext = np.array([nx, ny], dtype=float)
    out = np.mod(pos, ext)
    return np.where(out >= ext, 0.0, out)


def _disc_offsets(radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    r = int(np.ceil(radius))
    oy, ox = np.mgrid[-r:r + 1, -r:r + 1]
    w = np.clip(radius - np.hypot(ox, oy), 0.0, None)
    keep = w > 0
    return oy[keep], ox[keep], w[keep]


def _footprint(pos: np.ndarray, shape: tuple[int, int], mode: Footprint, radius: float = 2.5,
               periodic: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """Cells (n, k) and weights (n, k) summing to 1 that a drop erodes from / deposits on."""
    if mode == "bilinear":
        return _bilinear_corners(pos, shape, periodic)
    if mode == "disc":
        ny, nx = shape
        oy, ox, w = _disc_offsets(radius)
        ix = np.floor(pos[:, 0]).astype(np.int64)[:, None] + ox[None, :]
        iy = np.floor(pos[:, 1]).astype(np.int64)[:, None] + oy[None, :]
        if periodic:
            ix, iy = ix % nx, iy % ny
        inside = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
        ww = np.where(inside, w[None, :], 0.0)
        ww /= ww.sum(axis=1, keepdims=True)
        return np.where(inside, iy * nx + ix, 0), ww
    return _cell_of(pos, shape)[:, None], np.ones((len(pos), 1))


def _deposit(s: Surface, d: Drops, idx: np.ndarray, amount: np.ndarray, p: "WaterDrops") -> None:
    """Lay ``amount`` of sediment from drops ``idx`` onto their footprint, into their kind layer."""
    sel = amount > 0
    idx, amount = idx[sel], amount[sel]
    if idx.size == 0:
        return
    cells, w = _footprint(d.pos[idx], s.shape, p.footprint, p.brush_radius, s.periodic)
    layer = np.repeat(d.kind[idx], cells.shape[1])
    if np.any(layer < 0):
        raise AssertionError("a drop carrying sediment has no sediment kind")
    flat = cells.ravel() * s.n_layers + layer
    vol = (amount[:, None] * w).ravel()
    add = np.bincount(flat, weights=vol, minlength=s.thickness.size) / s.cell_area
    s.thickness.ravel()[:] += add          # thickness is C-contiguous (ncell, L)
    s.deposit.ravel()[:] += add
    d.sediment[idx] -= amount


def _fade(age: np.ndarray, p: "WaterDrops") -> np.ndarray | float:
    """Capacity factor 1 - age/max_age with ``capacity_fade`` (drops lay their load gradually
    and reach max_age nearly empty instead of dumping it where they stop), else 1."""
    if not p.capacity_fade or p.max_age <= 0:
        return 1.0
    return np.clip(1.0 - age / p.max_age, 0.0, 1.0)


def interact(s: Surface, d: Drops, p: "WaterDrops", speed: np.ndarray, gx: np.ndarray,
             gy: np.ndarray, dh: np.ndarray | None = None) -> Drops:
    """Absorption, deposition, erosion for every drop with water; removes empty drops."""
    n = len(d)
    if n == 0:
        return d
    a = s.cell_area
    L = s.n_layers
    cell = _cell_of(d.pos, s.shape)
    top = s.top_layer(cell)
    tk = np.maximum(top, 0)
    # --- absorption into the exposed layer -------------------------------------------------
    absorbs = (top >= 0) & s.absorbs[tk]
    ai = np.flatnonzero(absorbs & (d.volume > 0))
    if ai.size:
        c, l = cell[ai], tk[ai]
        cap = s.capacity_of(c, l)
        w = s.held[c, l]
        sat = np.where(cap > 0, np.clip(w / np.where(cap > 0, cap, 1.0), 0, 1), 1.0)
        demand = d.volume[ai] * s.absorption_rate[l] * (1.0 - sat) / (1.0 + speed[ai] / p.speed_ref)
        flat = c * L + l
        granted, uk, got = _share(flat, demand, cap - w, s.thickness.size)
        s.held.ravel()[uk] += got
        v_old = d.volume[ai].copy()
        d.volume[ai] = np.maximum(v_old - granted, 0.0)
        # deposition by concentration: the absorbed fraction of the drop leaves its sediment
        with np.errstate(invalid="ignore", divide="ignore"):
            frac = np.where(v_old > 0, granted / v_old, 0.0)
        dep = np.where(d.volume[ai] <= 0, d.sediment[ai], d.sediment[ai] * frac)
        _deposit(s, d, ai, dep, p)
    # --- erosion by moving drops -------------------------------------------------------------
    eroders = d.moving | p.erode_stabilised
    ei = np.flatnonzero(eroders & (d.volume > 0))
    if ei.size:
        cand = np.where(d.kind[ei] >= 0, d.kind[ei], top[ei])
        ok = cand >= 0
        ok[ok] &= s.erodible[cand[ok]]
        ei, cand = ei[ok], cand[ok]
    if ei.size:
        cells, wts = _footprint(d.pos[ei], s.shape, p.footprint, p.brush_radius, s.periodic)
        k = cells.shape[1]
        pc = cells.ravel()
        pl = np.repeat(cand, k)
        pd = np.repeat(np.arange(ei.size), k)
        ptop = s.top_layer(pc)
        elig = (ptop == pl) & (wts.ravel() > 0)
        cap = s.capacity_of(pc, pl)
        held = s.held[pc, pl]
        sat = np.where(cap > 0, held / np.where(cap > 0, cap, 1.0), 1.0)
        th = s.threshold[pl]
        weak = np.where(th < 1.0, np.clip(sat - th, 0.0, None) / np.where(th < 1.0, 1.0 - th, 1.0), 0.0)
        liquid = d.volume[ei][pd] + held
        demand = np.where(elig, wts.ravel() * s.erosion_rate[pl] * weak * liquid, 0.0)
        # per-drop limits: sediment capacity and concentration
        per_drop = np.bincount(pd, weights=demand, minlength=ei.size)
        room = p.max_concentration * d.volume[ei] - d.sediment[ei]
        if p.sediment_capacity is not None:
            slope = _length(gx.ravel()[cell[ei]], gy.ravel()[cell[ei]])
            capd = p.sediment_capacity * d.volume[ei] * speed[ei] * np.maximum(slope, p.min_slope)
            capd = capd * _fade(d.age[ei], p)
            room = np.minimum(room, capd - d.sediment[ei])
        if p.sediment_capacity is not None and dh is not None:
            # never dig deeper than the drop just went down (no self-dug pits)
            room = np.minimum(room, np.maximum(-dh[ei], 0.0) * a)
        room = np.maximum(room, 0.0)
        with np.errstate(invalid="ignore", divide="ignore"):
            lim = np.where(per_drop > room, room / np.where(per_drop > 0, per_drop, 1.0), 1.0)
        demand *= lim[pd]
        flat = pc * L + pl
        granted, uk, got = _share(flat, demand, s.thickness[pc, pl] * a, s.thickness.size)
        pos_ = got > 0
        hit, got = uk[pos_], got[pos_]
        if hit.size:
            t_old = s.thickness.ravel()[hit]
            t_new = np.maximum(t_old - got / a, 0.0)
            actual = (t_old - t_new) * a
            s.thickness.ravel()[hit] = t_new
            dep_old = s.deposit.ravel()[hit]
            s.deposit.ravel()[hit] = np.maximum(dep_old - (t_old - t_new), 0.0)
            # share the exact removed volume back to the pairs
            corr = np.zeros(s.thickness.size)
            corr[hit] = actual / got
            granted = granted * corr[flat]
            # water held beyond the thinner layer's capacity goes into the eroding drops
            hc, hl = hit // L, hit % L
            capn = s.capacity_of(hc, hl)
            excess = np.where(actual > 0, np.maximum(s.held.ravel()[hit] - capn, 0.0), 0.0)
            rel = np.zeros(s.thickness.size)
            if np.any(excess > 0):
                s.held.ravel()[hit] -= excess
                rel[hit] = excess / np.where(actual > 0, actual, 1.0)
            taken = np.bincount(pd, weights=granted, minlength=ei.size)
            water_back = np.bincount(pd, weights=granted * rel[flat], minlength=ei.size)
            d.sediment[ei] += taken
            d.volume[ei] += water_back
            got_any = taken > 0
            d.kind[ei[got_any]] = cand[got_any]
    # --- deposition of sediment beyond the capacity (classic terrain erosion) --------------
    if p.sediment_capacity is not None:
        slope = _length(gx.ravel()[cell], gy.ravel()[cell])
        capd = p.sediment_capacity * d.volume * speed * np.maximum(slope, p.min_slope) * _fade(d.age, p)
        extra = np.maximum(d.sediment - capd, 0.0) * p.deposition_rate
        extra = np.where(d.moving, extra, d.sediment)      # a stopped drop lays its whole load
        if dh is not None:
            # a drop that climbed out of a hollow first fills it (up to what it carries)
            extra = np.maximum(extra, np.minimum(np.maximum(dh, 0.0) * a, d.sediment))
        _deposit(s, d, np.flatnonzero(extra > 0), extra[extra > 0], p)
    # --- empty drops leave (they deposited everything above) ------------------------------
    alive = d.volume > 0
    if not np.all(alive):
        dead = np.flatnonzero(~alive & (d.sediment > 0))
        if dead.size:
            _deposit(s, d, dead, d.sediment[dead].copy(), p)
        d = d.take(alive)
    d.sediment = np.maximum(d.sediment, 0.0)
    return d


def evaporate(s: Surface, p: "WaterDrops", gx: np.ndarray, gy: np.ndarray) -> None:
    """Held water evaporates at ``evaporation`` per unit of true surface area of the cell,
    taken from the top-most wet layer first (a thin deposit does not seal the layer below)."""
    if p.evaporation <= 0:
        return
    wet = s.wet_cells()
    if wet.size == 0:
        return
    area = s.cell_area * np.sqrt(1.0 + gx.ravel()[wet] ** 2 + gy.ravel()[wet] ** 2)
    budget = p.evaporation * area
    total = np.zeros(wet.size)
    for l in range(s.n_layers - 1, -1, -1):      # a handful of layers, each a vector op
        e = np.minimum(s.held[wet, l], budget)
        s.held[wet, l] -= e
        budget -= e
        total += e
    s.evaporated[wet] += total


def step(s: Surface, d: Drops, p: "WaterDrops", accelerate: bool | None = None,
         continued: bool = False) -> Drops:
    """One time step: move, interact, evaporate; record moving-drop visits in ``path``.
    Returns the drops still on the grid with water, in cell order (:meth:`Drops.in_cell_order`).
    ``accelerate``: the numba kernels of procgen_water.kernels (same result), see procgen.accel.
    ``continued``: the caller's word that nothing but this function wrote ``s``'s base, layers,
    held water or materials since its last call on ``s`` (a rule stepping its own iterations);
    the compiled path then refreshes the height and releases excess water only where that
    call's drops were (the same numbers).  The numpy path ignores it."""
    # the compiled kernels know the bounded grid only: a torus runs the numpy path (the reference)
    kern = None if s.periodic else kernels("procgen_water.kernels", accelerate, len(d), MIN_DROPS)
    d = kern.step(s, d, p, continued) if kern is not None else _step(s, d, p)
    s.steps += 1
    return d


def _step(s: Surface, d: Drops, p: "WaterDrops") -> Drops:
    """The numpy step (the reference)."""
    release_excess(s)
    h = s.height()
    gx, gy = surface_gradient(s, h)
    d, speed, dh = move(s, d, p, gx, gy, h)
    if np.any(d.moving):
        s.path += np.bincount(_cell_of(d.pos[d.moving], s.shape), minlength=s.ncell)
    d = interact(s, d, p, speed, gx, gy, dh)
    evaporate(s, p, gx, gy)          # start-of-step slope: the area changes little in a step
    return d.in_cell_order(s.shape)


_MAPS = ("emitted", "evaporated", "drained", "drained_sediment", "source", "path")   # (ncell,)


def make_surface(base: np.ndarray, thickness: np.ndarray, materials, spacing: float = 1.0,
                 held: np.ndarray | None = None) -> Surface:
    """A Surface owning fresh arrays: base (ny, nx), thickness (ny, nx, L), a MaterialTable."""
    base = np.asarray(base, dtype=float)
    ny, nx = base.shape
    t = np.ascontiguousarray(thickness, dtype=float).reshape(ny * nx, -1)
    L = t.shape[1]
    if len(materials) != L:
        raise InputError(f"make_surface: {L} thickness layers but {len(materials)} materials")
    # the maps start at zero and the steps write them sparsely: one allocation (huge pages)
    w, dep, *maps = arena.zeros([((ny * nx, L), float)] * 2 + [(ny * nx, float)] * 6)
    if held is not None:
        w[...] = np.asarray(held, float).reshape(ny * nx, L)
    return Surface(shape=(ny, nx), spacing=float(spacing), base=base.ravel().copy(),
                   thickness=t.copy(), held=w, deposit=dep, **dict(zip(_MAPS, maps)),
                   **material_arrays(materials))


def material_arrays(materials) -> dict[str, np.ndarray]:
    """The per-layer material arrays a Surface needs, from a MaterialTable."""
    return dict(absorption_rate=materials.array("absorption_rate"),
                capacity=materials.array("capacity"), erosion_rate=materials.array("erosion_rate"),
                threshold=materials.array("weakness_threshold"),
                roughness=materials.array("roughness"), absorbs=materials.absorbs,
                erodible=materials.erodible)
