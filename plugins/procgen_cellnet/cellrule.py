"""What every CA rule of the family shares: the network, the selection, the gates.

A rule reads the time-t arrays, computes the t + 1 arrays for every cell at once and writes
them back (Table 1's double buffer: nothing a step writes is read by the same step).  The
selection (``materials`` / ``labels``) says which receiving cells change, so several rules run
on one network, each on its own material (Figure 1's several effects on one object).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import InputError, RuleBase, State, param

from .network import CellNetwork
from .states import gates

#: the tiny network every example recipe starts from
EXAMPLE_NET: tuple[dict, ...] = (
    {"rule": "mesh.primitive", "params": {"shape": "plane", "size": 12.0, "subdivisions": 1}},
    {"rule": "cellnet.seed", "params": {"cs": 1.0, "grid": "triangle"}},
    {"rule": "cellnet.link"},
)


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


def changed(old: np.ndarray, new: np.ndarray) -> bool:
    return not np.array_equal(old, new, equal_nan=np.issubdtype(np.asarray(old).dtype, np.floating))
