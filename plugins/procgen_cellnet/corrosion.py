"""Corrosion countdown: chosen regions lose their material potential and become holes (Table 1).

Section 5.2, Figure 11: Voronoi regions are coloured at random, the cells of the "corroded"
regions get a material potential Max_p that then decreases by Dp per step, and a cell whose
potential reaches zero becomes SLEEPING-TRANSPARENT (a hole).  Table 1's row, per receiving
cell: p > 0 -> p - Dp; p <= 0 -> sleep (transparent); otherwise (never corroded, NaN here) a
strict majority of corroding sending neighbours (kp > k/2) infects it with Max_p.  A uniform
Max_p makes a whole region vanish at once; ``noise`` (sigma) gives each cell
Max_p (1 + sigma u), u uniform in [-1, 1], so holes open progressively (impacts, pits).
A cell infected at step s is transparent at step s + ceil(Max_p / Dp) + 1 (tested).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, InputError, State, param

from .cellrule import EXAMPLE_NET, CellRule, Next
from .states import LABEL_FIELD, STATE_FIELD, TRANSPARENT, put_states, states

POTENTIAL = "corrosion__potential"


def countdown(p: np.ndarray, gs: np.ndarray, send: np.ndarray, update: np.ndarray, net,
              max_p: np.ndarray, dp: float) -> tuple[np.ndarray, np.ndarray]:
    """One synchronous corrosion step: (p, gs) at t + 1 from t."""
    g, k = net.sending(send)
    kp = g @ (p > 0).astype(float)
    new_p, new_gs = p.copy(), gs.copy()
    alive = update & (p > 0)
    new_p[alive] = p[alive] - dp
    dead = update & (p <= 0)
    new_gs[dead] = TRANSPARENT
    infect = update & np.isnan(p) & (kp > k / 2)
    new_p[infect] = max_p[infect]
    return new_p, new_gs


@dataclass(kw_only=True)
class CorrosionCountdown(CellRule):
    """Corrosion: a fraction of the regions count their potential down to holes (Figure 11)."""

    name: ClassVar[str] = "cellnet.corrode"
    default_iterations: ClassVar[int] = 100
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(LABEL_FIELD, domain="{cells}", at="cell", intent="in", doc="region label"),
        FieldSpec(POTENTIAL, domain="{cells}", at="cell", intent="out",
                  doc="material potential: NaN never corroded, > 0 corroding, <= 0 consumed"),
        FieldSpec("cell__state", domain="{cells}", at="cell", intent="out", doc="general state"),
        FieldSpec("cell__alive", domain="{cells}", at="cell", intent="out", doc="False once consumed (a hole)"),
    )
    example: ClassVar[tuple[dict, ...]] = EXAMPLE_NET + (
        {"rule": "ca.voronoi", "params": {"seeds": 4}, "iterations": 30},
        {"rule": "cellnet.corrode", "params": {"dp": 0.25}, "iterations": 6},)

    fraction_labels: float = param(0.3, ge=0.0, le=1.0, doc="share of regions that start corroded")
    max_p: float = param(1.0, gt=0.0, doc="initial potential Max_p")
    dp: float = param(0.02, gt=0.0, doc="potential lost per step")
    noise: float = param(0.0, ge=0.0, le=0.99, doc="per-cell spread sigma of the initial "
                         "potential (0 = the paper's uniform Max_p)")

    def setup(self, state: State) -> None:
        net = self.network(state)
        _, update = self.gates(net)
        label = np.asarray(net[LABEL_FIELD], np.int64)
        rng = state.rng()
        ids = np.unique(label[label > 0])
        if len(ids) == 0:
            raise InputError(f"{self.name}: network {self.cells!r} has no labelled regions")
        n = int(round(self.fraction_labels * len(ids)))
        chosen = rng.choice(ids, n, replace=False) if n else ids[:0]
        self._max_p = self.max_p * (1 + self.noise * (rng.random(net.n_cells) * 2 - 1))
        p = np.asarray(net[POTENTIAL], float).copy() if POTENTIAL in net else \
            np.full(net.n_cells, np.nan)
        start = update & np.isin(label, chosen) & np.isnan(p)
        p[start] = self._max_p[start]
        net.add_field(POTENTIAL, p, at="cell", doc="material potential (NaN: never corroded)")
        put_states(net, states(net))

    def advance(self, net, send: np.ndarray, update: np.ndarray) -> Next:
        new_p, new_gs = countdown(np.asarray(net[POTENTIAL], float), states(net), send, update,
                                  net, self._max_p, self.dp)
        return Next(update, {POTENTIAL: new_p, STATE_FIELD: new_gs})

    def reports(self, net) -> dict[str, float]:
        return {"transparent_fraction": float(np.mean(states(net) == TRANSPARENT))}
