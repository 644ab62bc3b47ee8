"""General states: who receives and who sends in one synchronous CA step (section 3.1, Table 1).

Every cell carries a communication mode (``cell__state``): SLEEPING (no communication),
RECEIVING (receives only), INFLUENCING (sends only, "distributing"), ACTIVE (both) and, from
section 5.2's corroded cells, TRANSPARENT (sleeping and not drawn).  The paper announces five
states and lists four; TRANSPARENT is the fifth.  In every rule of this family a neighbour
counts (in k, kc, kp) only if it sends, and a cell changes only if it receives and is selected
(by material and/or Voronoi label: the multi-behaviour of Figure 1).  Rules read time t and
write t + 1 for every cell at once (the paper's double buffer, Table 1 rows 1-2).
"""
from __future__ import annotations

import numpy as np

from procgen import InputError

SLEEPING, RECEIVING, INFLUENCING, ACTIVE, TRANSPARENT = range(5)
STATE_NAMES = ("sleeping", "receiving", "influencing", "active", "transparent")

STATE_FIELD = "cell__state"
MATERIAL_FIELD = "cell__material"
#: region labels 1..s (0 = none), as the generic ca.voronoi writes them
LABEL_FIELD = "voronoi__label"
#: cells that exist (the CA layer skips the others): every cell but the TRANSPARENT ones
PRESENT_FIELD = "cell__alive"


def states(net) -> np.ndarray:
    """``cell__state`` (all ACTIVE when a network has none yet)."""
    if STATE_FIELD in net:
        return np.asarray(net[STATE_FIELD], np.int8)
    return np.full(net.n_cells, ACTIVE, np.int8)


def sends(gs: np.ndarray) -> np.ndarray:
    return (gs == ACTIVE) | (gs == INFLUENCING)


def receives(gs: np.ndarray) -> np.ndarray:
    return (gs == ACTIVE) | (gs == RECEIVING)


def selection(net, materials: list[int] | None, labels: list[int] | None,
              where: str) -> np.ndarray:
    """Cells chosen by material id and/or Voronoi label (all cells when both are None)."""
    sel = np.ones(net.n_cells, bool)
    for name, ids in ((MATERIAL_FIELD, materials), (LABEL_FIELD, labels)):
        if ids is None:
            continue
        if name not in net:
            raise InputError(f"{where}: selecting by {name} but the network has no such field")
        sel &= np.isin(np.asarray(net[name]), ids)
    return sel


def gates(net, materials: list[int] | None = None, labels: list[int] | None = None,
          where: str = "cellnet") -> tuple[np.ndarray, np.ndarray]:
    """(send, update) masks: neighbours that count, and selected cells that receive."""
    gs = states(net)
    return sends(gs), receives(gs) & selection(net, materials, labels, where)


def put_states(net, gs: np.ndarray) -> None:
    """Write ``cell__state`` and ``cell__alive`` (False for TRANSPARENT: holes for every CA)."""
    gs = np.asarray(gs, np.int8)
    net.add_field(STATE_FIELD, gs, at="cell",
                  doc="general state: 0 sleeping, 1 receiving, 2 influencing, 3 active, 4 transparent")
    net.add_field(PRESENT_FIELD, gs != TRANSPARENT, at="cell", doc="cell exists (not transparent)")
