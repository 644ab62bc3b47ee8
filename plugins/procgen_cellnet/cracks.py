"""The crack-like border derivative: region borders become dark sleeping cells (Table 1, Figure 9).

Section 5.2: a Voronoi diagram grown from random seeds, then one application of a colour
derivative: a cell with a sending neighbour of another region becomes a crack cell (dark) and
goes to sleep.  Labels are compared, not rendered colours, so a second application changes
nothing.  The symmetric test marks both sides (cracks two cells wide); ``width = "one"`` marks
only the side with the larger label.  Crack cells that become INFLUENCING instead of SLEEPING
keep sending their dark colour, which then bleeds into the regions under diffusion (the marble
of Figure 1(h)); SLEEPING cracks stay sharp under diffusion (Figure 10(f)).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, State, param

from .cellrule import EXAMPLE_NET, CellRule, Next
from .colour import COLOR, COLORED, colours
from .states import INFLUENCING, LABEL_FIELD, SLEEPING, STATE_FIELD, states

CRACK = "crack__mask"


def crack_cells(net, label: np.ndarray, send: np.ndarray, update: np.ndarray,
                width: str) -> np.ndarray:
    """Receiving labelled cells with a sending neighbour of another label (``one``: larger side)."""
    g = net.graph
    other = label[g.indices]
    mine = label[g.rows]
    differs = send[g.indices] & (other > 0) & (other != mine)
    if width == "one":
        differs &= mine > other
    hit = np.bincount(g.rows, weights=differs, minlength=net.n_cells) > 0
    return hit & update & (label > 0)


@dataclass(kw_only=True)
class CrackDerivative(CellRule):
    """Crack-like pattern: cells on region borders turn dark and sleep (Table 1 "Crack-like")."""

    name: ClassVar[str] = "cellnet.crack"
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(LABEL_FIELD, domain="{cells}", at="cell", intent="in", doc="region label"),
        FieldSpec(CRACK, domain="{cells}", at="cell", intent="out", doc="crack cells"),
        FieldSpec("surface__color", domain="{cells}", at="cell", intent="out", units="rgb", doc="RGB colour"),
        FieldSpec("cell__state", domain="{cells}", at="cell", intent="out", doc="general state"),
        FieldSpec("cell__colored", domain="{cells}", at="cell", intent="out", doc="colour is not null"),
    )
    example: ClassVar[tuple[dict, ...]] = EXAMPLE_NET + (
        {"rule": "ca.voronoi", "params": {"seeds": 4}, "iterations": 30},
        {"rule": "cellnet.crack"},)

    color: list[float] = param([0.1, 0.1, 0.1], doc="crack colour (RGB in 0..1)")
    width: str = param("two", choices=("two", "one"), doc="mark both sides of a border or one")
    crack_state: str = param("sleeping", choices=("sleeping", "influencing"),
                             doc="general state of crack cells (influencing: veins that bleed)")

    def validate(self) -> None:
        if len(self.color) != 3 or min(self.color) < 0 or max(self.color) > 1:
            raise ValueError("color must be [r, g, b] in 0..1")

    def advance(self, net, send: np.ndarray, update: np.ndarray) -> Next:
        """Writes only the cells it marks (``written`` = the new crack cells)."""
        label = np.asarray(net[LABEL_FIELD], np.int64)
        hit = crack_cells(net, label, send, update, self.width)
        old = np.asarray(net[CRACK], bool) if CRACK in net else np.zeros(net.n_cells, bool)
        color, colored = (a.copy() for a in colours(net))
        color[hit] = self.color
        colored[hit] = True
        gs = states(net).copy()
        gs[hit] = SLEEPING if self.crack_state == "sleeping" else INFLUENCING
        return Next(hit, {COLOR: color, COLORED: colored, STATE_FIELD: gs, CRACK: old | hit})

    def reports(self, net) -> dict[str, float]:
        return {"crack_fraction": float(np.asarray(net[CRACK]).mean())}

    def step(self, state: State) -> bool:
        net = self.network(state)
        nxt = self.advance(net, *self.gates(net))
        self.commit(state, net, nxt)
        return bool(nxt.written.any())
