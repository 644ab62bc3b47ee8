"""Corrosion / patina as a strategic attack-defence CA (thesis ch. 2.4 and 4.2, Appendix A).

One kernel for both plugins: the 2.5-D surface runs it on the grid graph of its raster (with an
extra downhill tilt per neighbour entry and covered metal blocked), the mesh-surface plugin on
its cross-edge cell graph.

States: NORMAL (0), CORRODED (1), HOLE (2, the thesis's NO_MORE_CELL).  Per synchronous step:

1. new seeds: Binomial(n, seed_rate) weak normal cells, until ``max_seeds`` in total;
2. every corroded cell attacks n_a = f1(age) = clamp(1 + age // age_step, 1, min(n_VC, 7)) of its
   n_VC valid (normal) neighbours, drawn without replacement with weights from a 3x3 Gaussian
   matrix over the 8 directions;
3. an attack succeeds when  a0 + a1*age + a2*(corroded neighbours of the attacker) + noise*U
   > b0 + b1*(strong neighbours of the defender) + strong_bonus*[defender is strong]   (f2);
4. every cell corroded at the start of the step loses k1 of consumable thickness (top layer
   first), gains k2 of product (oxide) capped at k3, and ages by one; it becomes a HOLE exactly
   when its consumable thickness reaches <= 0.

The age function A is the step count since corrosion, i.e. proportional to the oxide thickness
until the k3 cap (thesis: "A proportional to oxide thickness").
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import InputError

from .graph import MOORE, CellGraph, weighted_top_k

NORMAL, CORRODED, HOLE = 0, 1, 2


def gaussian_matrix(sigma: float) -> np.ndarray:
    """3x3 direction weights exp(-(di^2 + dj^2) / (2 sigma^2)), centre 0."""
    d = np.arange(-1, 2)
    w = np.exp(-(d[None, :] ** 2 + d[:, None] ** 2) / (2.0 * sigma ** 2))
    w[1, 1] = 0.0
    return w


@dataclass(frozen=True)
class CorrosionParams:
    """Numbers of the attack/defence model (defaults are ours: the thesis gives none)."""

    k1: float = 0.0005         # consumable (metal) lost per step by a corroded cell
    k2: float = 0.02          # product (oxide) gained per step
    k3: float = 1.0           # product cap
    seed_rate: float = 1e-6   # expected new seeds per cell per step
    max_seeds: int = 60
    max_attacks: int = 7
    age_step: float = 12.0    # steps of age per extra attack (f1)
    a0: float = 1.0
    a1: float = 0.02          # attack per step of age
    a2: float = 0.15          # attack per corroded helper of the attacker
    b0: float = 1.9
    b1: float = 0.35          # defence per strong helper of the defender
    strong_bonus: float = 1.5
    noise: float = 1.0        # attack += noise * U(0, 1)
    gaussian: tuple[tuple[float, ...], ...] = field(
        default_factory=lambda: tuple(map(tuple, gaussian_matrix(1.0))))
    seeding: str = "binomial"  # new seeds per step: Binomial(n, rate) or "fixed" floor(rate * n)

    def check(self) -> None:
        g = np.asarray(self.gaussian, dtype=float)
        if g.shape != (3, 3) or np.any(~np.isfinite(g)) or np.any(g < 0) or g.sum() <= g[1, 1]:
            raise InputError("corrosion: gaussian must be a 3x3 matrix of non-negative weights "
                             "with some weight off the centre")
        if not 1 <= self.max_attacks <= 7:
            raise InputError(f"corrosion: max_attacks must be in 1..7 (never 8), got {self.max_attacks}")
        if self.seeding not in ("binomial", "fixed"):
            raise InputError(f"corrosion: seeding must be 'binomial' or 'fixed', got {self.seeding!r}")

    def direction_weights(self) -> np.ndarray:
        """Weight of each Moore slot (di, dj), read from the 3x3 matrix [dj + 1, di + 1]."""
        g = np.asarray(self.gaussian, dtype=float)
        return g[MOORE[:, 1] + 1, MOORE[:, 0] + 1]


@dataclass
class CorrosionState:
    """Per-cell arrays of the model (mutated by :func:`corrosion_step`)."""

    status: np.ndarray        # int8 NORMAL / CORRODED / HOLE
    consumable: np.ndarray    # (n, Lc) thickness of the consumed layers, bottom first
    product: np.ndarray       # (n,) oxide / patina / char thickness
    age: np.ndarray           # (n,) int32 steps since corrosion
    strong: np.ndarray        # (n,) bool
    seeds_used: int = 0
    attacks: np.ndarray | None = None   # (n,) attacks made by each cell in the last step
    valid_neighbours: np.ndarray | None = None  # (n,) n_VC of each cell in the last step


@dataclass
class StepStats:
    """What one step did (for ledgers, reports and the tests' invariants)."""

    changed: int = 0
    new_seeds: int = 0
    seed_cells: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    newly_corroded: int = 0
    new_holes: int = 0
    attacks: int = 0
    max_attacks_per_cell: int = 0
    max_allowed_violation: int = 0   # cells that attacked more than min(n_VC, max_attacks): must be 0


def corrosion_step(graph: CellGraph, st: CorrosionState, prm: CorrosionParams, rng: np.random.Generator,
                   *, edge_logw: np.ndarray | None = None, blocked: np.ndarray | None = None) -> StepStats:
    """One synchronous step of every cell; ``st`` is updated in place.

    ``edge_logw``: extra log-weight per CSR entry added to the Gaussian direction weight (the
    2.5-D surface tilts attacks downhill). ``blocked``: normal cells that can be neither attacked
    nor seeded (metal under another layer). A normal cell with no consumable left is blocked too.
    """
    n = graph.n_cells
    out = StepStats()
    status0 = st.status.copy()
    corroded = status0 == CORRODED
    normal = status0 == NORMAL
    open_ = normal & (st.consumable.sum(axis=1) > 0)
    if blocked is not None:
        open_ &= ~np.asarray(blocked, bool)
    # 1. new seeds on weak open cells
    new_corroded = np.zeros(n, bool)
    room = prm.max_seeds - st.seeds_used
    if room > 0 and prm.seed_rate > 0:
        pool = np.nonzero(open_ & ~st.strong)[0]
        want = int(rng.binomial(n, prm.seed_rate)) if prm.seeding == "binomial" else int(np.floor(prm.seed_rate * n))
        k = min(want, room, len(pool))
        if k > 0:
            out.seed_cells = rng.choice(pool, k, replace=False)
            new_corroded[out.seed_cells] = True
            st.seeds_used += k
            out.new_seeds = k
    # 2-3. attacks from corroded cells that still touch an open cell (the front)
    st.attacks = np.zeros(n, np.int64)
    st.valid_neighbours = np.zeros(n, np.int64)
    front = np.nonzero(corroded & (graph.matrix @ open_.astype(float) > 0))[0]
    if len(front):
        e = graph.entries_of(front)
        tgt = graph.indices[e]
        rows = np.repeat(np.arange(len(front)), graph.degree[front])     # local row ids
        valid = open_[tgt]
        n_vc = np.bincount(rows, weights=valid, minlength=len(front)).astype(np.int64)
        f1 = np.clip(1 + (st.age[front] // prm.age_step).astype(np.int64), 1, prm.max_attacks)
        n_a = np.minimum(f1, n_vc)
        w = prm.direction_weights()[graph.direction[e]]
        if edge_logw is not None:
            w = w * np.exp(np.asarray(edge_logw, dtype=float)[e])
        chosen = weighted_top_k(rows, np.where(valid, w, 0.0), n_a, rng)
        per = np.bincount(rows[chosen], minlength=len(front))
        st.attacks[front] = per
        st.valid_neighbours[front] = n_vc
        out.attacks, out.max_attacks_per_cell = int(per.sum()), int(per.max(initial=0))
        out.max_allowed_violation = int(np.sum(per > np.minimum(n_vc, prm.max_attacks)))
        helpers = np.bincount(rows, weights=corroded[tgt], minlength=len(front))
        a_rows, a_tgt = rows[chosen], tgt[chosen]
        targets, t_inv = np.unique(a_tgt, return_inverse=True)
        te = graph.entries_of(targets)
        t_rows = np.repeat(np.arange(len(targets)), graph.degree[targets])
        strong_normal = st.strong & normal
        strong_help = np.bincount(t_rows, weights=strong_normal[graph.indices[te]],
                                  minlength=len(targets))
        attacker = front[a_rows]
        attack = prm.a0 + prm.a1 * st.age[attacker] + prm.a2 * helpers[a_rows] \
            + prm.noise * rng.random(len(a_rows))
        defence = prm.b0 + prm.b1 * strong_help[t_inv] + prm.strong_bonus * st.strong[a_tgt]
        new_corroded[a_tgt[attack > defence]] = True
    # 4. corroded cells thin (top consumed layer first), oxidise (never above k3, never shrinking)
    if corroded.any():
        c = st.consumable[corroded]
        remove = np.full(len(c), prm.k1)
        for layer in range(c.shape[1] - 1, -1, -1):       # top layer first (few layers, not cells)
            take = np.minimum(c[:, layer], remove)
            c[:, layer] -= take
            remove -= take
        st.consumable[corroded] = c
        p = st.product[corroded]
        st.product[corroded] = np.minimum(p + prm.k2, np.maximum(p, prm.k3))
        st.age[corroded] += 1
        gone = corroded & (st.consumable.sum(axis=1) <= 0)
        st.consumable[gone] = 0.0
        st.status[gone] = HOLE
        out.new_holes = int(np.count_nonzero(gone))
    new_corroded &= open_
    st.status[new_corroded] = CORRODED
    out.newly_corroded = int(np.count_nonzero(new_corroded))
    out.changed = int(np.count_nonzero(st.status != status0))
    return out


def strong_mask(n: int, fraction: float, rng: np.random.Generator,
                noise: np.ndarray | None = None) -> np.ndarray:
    """Exactly round(fraction * n) strong cells: at random, or the highest values of ``noise``."""
    k = int(round(fraction * n))
    mask = np.zeros(n, bool)
    if k <= 0:
        return mask
    if noise is None:
        mask[rng.choice(n, k, replace=False)] = True
    else:
        mask[np.argsort(-np.asarray(noise), kind="stable")[:k]] = True
    return mask
