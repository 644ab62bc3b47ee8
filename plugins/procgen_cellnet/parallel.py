"""Several behaviours in one synchronous step, and Table 1's one-sided regrouping.

Figure 1 shows eight effects "synchronised" on one object: every cell runs the behaviour of its
material, and all of them read the same time-t buffer and write one t + 1 buffer (Table 1's
double buffer, section 3.1).  ``cellnet.parallel`` does exactly that: each behaviour's step
function computes its t + 1 arrays from the t arrays with its own cells as the receiving ones,
and the results are merged by material, so a cell's new value never depends on a neighbour's
new value - even where two behaviours write the same field (Life next to regrouping on
``ca__alive``), unlike running the rules one after another.

Table 1's "Regrouping" row, read literally, is one-sided: "(p)? ((kp < k/2)? dead : alive)" -
a live cell dies when fewer than half of its sending neighbours live, and nothing is ever born,
so the live set only shrinks to a fixed point.  ``cellnet.regroup`` runs that reading
(``mode = "one_sided"``); ``"majority"`` is the two-sided vote (ties keep the state) that the
generic ``ca.majority`` also gives, here gated by the general states.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, InputError, State, param
from procgen.ca.lifelike import parse_rule

from .cellrule import EXAMPLE_NET, CellRule
from .colour import COLOR, COLORED, colours, put_colours, spread
from .melting import melt_step
from .network import CellNetwork
from .states import MATERIAL_FIELD

REGROUP_MODES = ("one_sided", "majority")
#: behaviour -> the fields it writes (all on ``cell``)
BEHAVIOURS = {"diffuse": (COLOR, COLORED), "melt": ("cell__normal",), "life": ("{field}",),
              "regroup": ("{field}",), "majority": ("{field}",)}


def regroup_step(net: CellNetwork, alive: np.ndarray, send: np.ndarray, update: np.ndarray,
                 mode: str = "one_sided") -> np.ndarray:
    """Table 1 "Regrouping" at t + 1: kp live sending neighbours out of k sending ones.

    one_sided: a live cell with kp < k/2 dies, nothing is born; majority: kp > k/2 lives,
    kp < k/2 dies, a tie keeps the state.  Only ``update`` cells change.
    """
    g, k = net.sending(send)
    kp = g @ alive.astype(float)
    if mode == "one_sided":
        new = alive & ~(2 * kp < k)
    else:
        new = np.where(2 * kp > k, True, np.where(2 * kp < k, False, alive))
    return np.where(update, new, alive)


def life_step_gated(net: CellNetwork, alive: np.ndarray, send: np.ndarray, update: np.ndarray,
                    rule: str) -> np.ndarray:
    """Outer-totalistic step counting live *sending* neighbours (Table 1 "Life game" / "Maze")."""
    g, k = net.sending(send)
    lut = parse_rule(rule).lut(int(k.max(initial=0)))
    kp = (g @ alive.astype(float)).astype(np.intp)
    return np.where(update, lut[kp, alive.astype(np.intp)], alive)


def bool_state(net: CellNetwork, field: str, where: str) -> np.ndarray:
    if field not in net:
        raise InputError(f"{where}: network has no cell field {field!r} (start one with ca.life, "
                         "ca.majority or cellnet.color_by)")
    a = np.asarray(net[field])
    if a.ndim != 1:
        raise InputError(f"{where}: field {field!r} must be one bool per cell")
    return a.astype(bool)


@dataclass(kw_only=True)
class Regrouping(CellRule):
    """Regrouping (Table 1, Figure 14(c)): live cells with fewer than half live senders die."""

    name: ClassVar[str] = "cellnet.regroup"
    default_iterations: ClassVar[int] = 50
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("{field}", domain="{cells}", at="cell", intent="inout", dtype="bool",
                  doc="live cells"),)
    example: ClassVar[tuple[dict, ...]] = EXAMPLE_NET + (
        {"rule": "ca.life", "iterations": 1},
        {"rule": "cellnet.regroup", "iterations": 3},)

    field: str = param("ca__alive", doc="bool cell field holding the live state")
    mode: str = param("one_sided", choices=REGROUP_MODES,
                      doc="one_sided: Table 1 read literally (only deaths); majority: two-sided vote")

    def step(self, state: State) -> bool:
        net = self.network(state)
        send, update = self.gates(net)
        alive = bool_state(net, self.field, self.name)
        new = regroup_step(net, alive, send, update, self.mode)
        net.add_field(self.field, new, at="cell", doc=f"live cells ({self.mode} regrouping)")
        return bool(np.any(new != alive))


@dataclass(kw_only=True)
class ParallelBehaviours(CellRule):
    """Several behaviours in one synchronous step, each on its materials (Figure 1).

    ``behaviours`` maps a behaviour (diffuse, melt, life, regroup, majority) to the
    ``cell__material`` ids that run it; every behaviour reads the same time-t state and the
    t + 1 results are merged by material.  Behaviours writing the same field (life, regroup,
    majority on ``field``) must have disjoint materials.  ``materials`` / ``labels`` narrow
    every behaviour further.
    """

    name: ClassVar[str] = "cellnet.parallel"
    default_iterations: ClassVar[int] = 20
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(MATERIAL_FIELD, domain="{cells}", at="cell", intent="in", doc="material id"),
        FieldSpec(COLOR, domain="{cells}", at="cell", intent="inout", units="rgb", doc="RGB colour"),
        FieldSpec(COLORED, domain="{cells}", at="cell", intent="inout", doc="colour is not null"),
        FieldSpec("cell__normal", domain="{cells}", at="cell", intent="out", doc="unit normal"),
        FieldSpec("{field}", domain="{cells}", at="cell", intent="inout", dtype="bool",
                  doc="live cells (life / regroup / majority)"),
    )
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "plane", "size": 12.0, "subdivisions": 1}},
        {"rule": "cellnet.seed", "params": {"cs": 1.0, "grid": "square8"}},
        {"rule": "cellnet.link"},
        {"rule": "cellnet.seed_colors", "params": {"n_seeds": 5}},
        {"rule": "ca.life", "iterations": 1},
        {"rule": "cellnet.parallel", "iterations": 3,
         "params": {"behaviours": {"diffuse": [0], "life": [0]}}},)

    behaviours: dict[str, list[int]] = param({"diffuse": [0]},
                                             doc="behaviour -> material ids: diffuse, melt, life, regroup, majority")
    field: str = param("ca__alive", doc="bool cell field of life / regroup / majority")
    rule: str = param("B3/S23", doc="B/S string of the life behaviour (B3/S234: maze)")
    regroup_mode: str = param("one_sided", choices=REGROUP_MODES, doc="regroup behaviour's reading")

    def validate(self) -> None:
        unknown = sorted(set(self.behaviours) - set(BEHAVIOURS))
        if unknown:
            raise ValueError(f"behaviours: unknown {unknown}; choose from {sorted(BEHAVIOURS)}")
        if not self.behaviours:
            raise ValueError("behaviours: name at least one behaviour")
        owner: dict[int, str] = {}
        for b in ("life", "regroup", "majority"):
            for m in self.behaviours.get(b, []):
                if m in owner:
                    raise ValueError(f"behaviours: material {m} runs both {owner[m]} and {b}, "
                                     f"which both write {self.field!r}")
                owner[m] = b
        try:
            parse_rule(self.rule)
        except InputError as exc:
            raise ValueError(str(exc)) from None

    def field_specs(self) -> list[FieldSpec]:
        """Only the fields of the behaviours named (a melt-only run needs no colours)."""
        wanted = {MATERIAL_FIELD}
        for b in self.behaviours:
            wanted |= {f.format(field=self.field) for f in BEHAVIOURS[b]}
        return [s for s in super().field_specs() if s.name in wanted]

    def step(self, state: State) -> bool:
        net = self.network(state)
        out, changed = parallel_step(net, self.behaviours, *self.gates(net), field=self.field,
                                     rule=self.rule, regroup_mode=self.regroup_mode)
        state.add_domain(self.cells, out)
        return changed


def parallel_step(net: CellNetwork, behaviours: dict[str, list[int]], send: np.ndarray,
                  update: np.ndarray, *, field: str = "ca__alive", rule: str = "B3/S23",
                  regroup_mode: str = "one_sided") -> tuple[CellNetwork, bool]:
    """The network at t + 1: every behaviour from the same time-t arrays, merged by material."""
    if MATERIAL_FIELD not in net:
        raise InputError("cellnet.parallel: the network has no cell__material")
    material = np.asarray(net[MATERIAL_FIELD])
    own = {b: update & np.isin(material, m) for b, m in behaviours.items()}
    changed = False
    new_state = None
    if any(b in own for b in ("life", "regroup", "majority")):
        alive = bool_state(net, field, "cellnet.parallel")
        new_state = alive.copy()
        for b in ("life", "regroup", "majority"):
            if b in own:
                nxt = (life_step_gated(net, alive, send, own[b], rule) if b == "life" else
                       regroup_step(net, alive, send, own[b],
                                    regroup_mode if b == "regroup" else "majority"))
                new_state[own[b]] = nxt[own[b]]
        changed |= bool(np.any(new_state != alive))
    new_colour = None
    if "diffuse" in own:
        color, colored = colours(net)
        new_colour = spread(net, color, colored, send, own["diffuse"])
        changed |= bool(np.any(new_colour[1] != colored)) or bool(np.any(new_colour[0] != color))
    out = net
    if "melt" in own:
        pos, nrm = melt_step(net, send, own["melt"])
        changed |= bool(np.any(pos != net.positions))
        out = net.with_positions(pos)
        out.add_field("cell__normal", nrm, at="cell", doc="unit normal")
    if new_state is not None:
        out.add_field(field, new_state, at="cell", doc="live cells")
    if new_colour is not None:
        put_colours(out, *new_colour)
    return out, changed
