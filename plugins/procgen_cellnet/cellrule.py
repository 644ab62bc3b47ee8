"""What every CA rule of the family shares: the network, the selection, the gates.

A rule reads the time-t arrays, computes the t + 1 arrays for every cell at once and writes
them back (Table 1's double buffer: nothing a step writes is read by the same step).  The
selection (``materials`` / ``labels``) says which receiving cells change, so several rules run
on one network, each on its own material (Figure 1's several effects on one object).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from procgen import InputError, RuleBase, State, param

from .network import CellNetwork
from .states import STATE_FIELD, gates, put_states

#: the tiny network every example recipe starts from
EXAMPLE_NET: tuple[dict, ...] = (
    {"rule": "mesh.primitive", "params": {"shape": "plane", "size": 12.0, "subdivisions": 1}},
    {"rule": "cellnet.seed", "params": {"cs": 1.0, "grid": "triangle"}},
    {"rule": "cellnet.link"},
)


@dataclass
class Next:
    """A behaviour's time t + 1: the cells it writes, its new field arrays (whole arrays, equal
    to time t outside ``written``) and, for melting, the new positions."""

    written: np.ndarray
    fields: dict[str, np.ndarray] = field(default_factory=dict)
    positions: np.ndarray | None = None


@dataclass(kw_only=True)
class CellRule(RuleBase):
    """Base of the network CA rules: ``cells`` plus a material / label selection."""

    uses: ClassVar[dict[str, str]] = {"{cells}": "CellNetwork"}
    default_iterations: ClassVar[int] = 1

    cells: str = param("cells", doc="CellNetwork to act on")
    materials: list[int] | None = param(None, doc="only cells of these cell__material ids change")
    labels: list[int] | None = param(None, doc="only cells of these cell__label ids change")

    def network(self, state: State) -> CellNetwork:
        net = state.get(self.cells, CellNetwork)
        if not net.linked:
            raise InputError(f"{self.name}: network {self.cells!r} has no links yet "
                             "(run cellnet.link first)")
        return net

    def gates(self, net: CellNetwork) -> tuple[np.ndarray, np.ndarray]:
        """(send, update): neighbours that count; selected receiving cells that change."""
        return gates(net, self.materials, self.labels, self.name)

    def advance(self, net: CellNetwork, send: np.ndarray, update: np.ndarray) -> Next:
        """Time t + 1 of this behaviour from the time-t network, written nowhere yet: what
        ``cellnet.parallel`` merges with the other behaviours of the same step."""
        raise NotImplementedError(f"{self.name} is not a synchronous behaviour")

    def reports(self, net: CellNetwork) -> dict[str, float]:
        """Numbers for run.json after a step (key suffixes after ``{cells}.``)."""
        return {}

    def commit(self, state: State, net: CellNetwork, nxt: Next) -> bool:
        """Write ``nxt`` into the network (a new domain if positions moved) and report;
        True if it changed."""
        moved = changed_next(net, nxt)
        out = put_next(net, nxt, {s.name: s.doc for s in self.field_specs()})
        if out is not net:
            state.add_domain(self.cells, out)
        for key, value in self.reports(out).items():
            state.report(f"{self.cells}.{key}", value)
        return moved

    def step(self, state: State) -> bool:
        net = self.network(state)
        return self.commit(state, net, self.advance(net, *self.gates(net)))


def put_next(net: CellNetwork, nxt: Next, docs: dict[str, str]) -> CellNetwork:
    """The network carrying ``nxt`` (the same object unless positions moved)."""
    out = net if nxt.positions is None else net.with_positions(nxt.positions)
    for name, a in nxt.fields.items():
        if name == STATE_FIELD:
            put_states(out, a)
        else:
            out.add_field(name, a, at="cell", doc=docs.get(name, ""))
    return out


def changed_next(net: CellNetwork, nxt: Next) -> bool:
    """True when ``nxt`` differs from the time-t network anywhere."""
    if nxt.positions is not None and not np.array_equal(nxt.positions, net.positions):
        return True
    return any(name not in net or changed(np.asarray(net[name]), a) for name, a in nxt.fields.items())


def changed(old: np.ndarray, new: np.ndarray) -> bool:
    return not np.array_equal(old, new, equal_nan=np.issubdtype(np.asarray(old).dtype, np.floating))
