"""Several behaviours in one synchronous step, and Table 1's one-sided regrouping.

Figure 1 shows eight effects "synchronised" on one object: every cell runs the behaviour of its
material, and all of them read the same time-t buffer and write one t + 1 buffer (Table 1's
double buffer, section 3.1).  ``cellnet.parallel`` does exactly that: each behaviour (the
``advance`` of its rule: colour spreading, melting, cracks, corrosion, watercolour, Young's
activator/inhibitor, regrouping, majority, plus the gated Life / maze rule) computes its t + 1
arrays from the t arrays with its own cells as the receiving ones, and the results are merged
by material, so a cell's new value never depends on a neighbour's new value - even where two
behaviours write the same field (Life next to regrouping on ``ca__alive``), unlike running the
rules one after another.  The crack derivative writes only the cells it marks and wins there
(a marble cell that becomes a vein takes the vein colour, not its diffused colour).

Table 1's "Regrouping" row, read literally, is one-sided: "(p)? ((kp < k/2)? dead : alive)" -
a live cell dies when fewer than half of its sending neighbours live, and nothing is ever born,
so the live set only shrinks to a fixed point.  ``cellnet.regroup`` runs that reading
(``mode = "one_sided"``); ``"majority"`` is the two-sided vote (ties keep the state) that the
generic ``ca.majority`` also gives, here gated by the general states.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from typing import Any

from procgen import FieldSpec, InputError, RecipeError, State, param
from procgen.ca.lifelike import parse_rule

from .activation import ActivatorInhibitor
from .cellrule import EXAMPLE_NET, CellRule, Next, changed_next, put_next
from .colour import ColorSpreading
from .corrosion import CorrosionCountdown
from .cracks import CrackDerivative
from .melting import MeltingAverage
from .network import CellNetwork
from .states import MATERIAL_FIELD
from .watercolour import WatercolorFlow

REGROUP_MODES = ("one_sided", "majority")


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

    def advance(self, net: CellNetwork, send: np.ndarray, update: np.ndarray) -> Next:
        alive = bool_state(net, self.field, self.name)
        return Next(update, {self.field: regroup_step(net, alive, send, update, self.mode)})


@dataclass(kw_only=True)
class GatedLife(CellRule):
    """Table 1 "Life game" / "Maze" as a behaviour of ``cellnet.parallel`` (live *sending*
    neighbours counted; the stand-alone generic rule is ``ca.life``)."""

    name: ClassVar[str] = "cellnet.parallel.life"
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("{field}", domain="{cells}", at="cell", intent="out", dtype="bool",
                  doc="live cells"),)
    field: str = param("ca__alive", doc="bool cell field of live cells")
    rule: str = param("B3/S23", doc="B/S string (B3/S234: maze)")
    density: float = param(0.5, ge=0.0, le=1.0, doc="initial share of live cells (if the field is absent)")

    def setup(self, state: State) -> None:
        net = self.network(state)
        if self.field not in net:
            net.add_field(self.field, state.rng().random(net.n_cells) < self.density, at="cell",
                          doc="live cells")

    def validate(self) -> None:
        try:
            parse_rule(self.rule)
        except InputError as exc:
            raise ValueError(str(exc)) from None

    def advance(self, net: CellNetwork, send: np.ndarray, update: np.ndarray) -> Next:
        alive = bool_state(net, self.field, "cellnet.parallel")
        return Next(update, {self.field: life_step_gated(net, alive, send, update, self.rule)})


#: behaviour -> (rule whose parameters and ``advance`` it uses, default parameters)
BEHAVIOURS: dict[str, tuple[type[CellRule], dict[str, Any]]] = {
    "diffuse": (ColorSpreading, {}), "melt": (MeltingAverage, {}), "life": (GatedLife, {}),
    "regroup": (Regrouping, {}), "majority": (Regrouping, {"mode": "majority"}),
    "young": (ActivatorInhibitor, {}), "corrode": (CorrosionCountdown, {}),
    "watercolor": (WatercolorFlow, {}), "crack": (CrackDerivative, {}),
}
#: merge order: later behaviours win on the cells both write (only the crack may share cells)
ORDER = tuple(BEHAVIOURS)


def kind(b: str) -> str:
    """The behaviour of a key: ``crack/marble`` is a second ``crack`` with its own settings."""
    return b.split("/", 1)[0]


@dataclass(kw_only=True)
class ParallelBehaviours(CellRule):
    """Several behaviours in one synchronous step, each on its materials (Figure 1).

    ``behaviours`` maps a behaviour (diffuse, melt, life, regroup, majority, young, corrode,
    watercolor, crack) to the ``cell__material`` ids that run it; ``settings`` gives a
    behaviour the parameters of its rule (``cellnet.diffuse``, ``cellnet.melt``,
    ``cellnet.regroup``, ``cellnet.young``, ``cellnet.corrode``, ``cellnet.watercolor``,
    ``cellnet.crack``; life takes ``rule`` and ``field``), and ``steps`` how many steps it runs
    (then its cells keep their state).  Every behaviour reads the same time-t state and the
    t + 1 results are merged by material.  Behaviours writing the same field must have disjoint
    materials, except the crack, which writes only the cells it marks and wins there.
    ``materials`` / ``labels`` narrow every behaviour further.  A key ``kind/name``
    (``crack/marble``) runs one more instance of a behaviour with its own settings and steps.
    """

    name: ClassVar[str] = "cellnet.parallel"
    default_iterations: ClassVar[int] = 20
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "plane", "size": 12.0, "subdivisions": 1}},
        {"rule": "cellnet.seed", "params": {"cs": 1.0, "grid": "square8"}},
        {"rule": "cellnet.link"},
        {"rule": "ca.voronoi", "params": {"seeds": 4}, "iterations": 30},
        {"rule": "cellnet.seed_colors", "params": {"n_seeds": 5}},
        {"rule": "ca.life", "iterations": 1},
        {"rule": "cellnet.parallel", "iterations": 3,
         "params": {"behaviours": {"diffuse": [0], "life": [0], "crack": [0]},
                    "settings": {"crack": {"crack_state": "influencing"}}}},)

    behaviours: dict[str, list[int]] = param({"diffuse": [0]},
                                             doc="behaviour -> material ids: " + ", ".join(BEHAVIOURS))
    settings: dict[str, dict[str, Any]] = param({}, doc="behaviour -> parameters of its rule")
    steps: dict[str, int] = param({}, doc="behaviour -> number of steps it runs (absent: every step)")

    def validate(self) -> None:
        unknown = sorted(b for b in {*self.behaviours, *self.settings, *self.steps}
                         if kind(b) not in BEHAVIOURS)
        if unknown:
            raise ValueError(f"behaviours: unknown {unknown}; choose from {sorted(BEHAVIOURS)}")
        if not self.behaviours:
            raise ValueError("behaviours: name at least one behaviour")
        extra = sorted((set(self.settings) | set(self.steps)) - set(self.behaviours))
        if extra:
            raise ValueError(f"settings / steps for {extra}, which no material runs")
        for b, n in self.steps.items():
            if n < 1:
                raise ValueError(f"steps.{b}: {n} must be at least 1")
        self._rules = {b: self.behaviour_rule(b)
                       for b in sorted(self.behaviours, key=lambda b: (ORDER.index(kind(b)), b))}
        owner: dict[tuple[str, int], str] = {}
        for b, rule in self._rules.items():
            if kind(b) == "crack":
                continue
            for name in written_fields(rule):
                for m in self.behaviours[b]:
                    if (name, m) in owner:
                        raise ValueError(f"behaviours: material {m} runs both {owner[name, m]} and "
                                         f"{b}, which both write {name!r}")
                    owner[name, m] = b

    def behaviour_rule(self, b: str) -> CellRule:
        cls, defaults = BEHAVIOURS[kind(b)]
        given = self.settings.get(b, {})
        fixed = {k for k in ("cells", "materials", "labels") if k in given}
        if fixed:
            raise ValueError(f"settings.{b}: {sorted(fixed)} are set by cellnet.parallel itself")
        params = {**defaults, **given, "cells": self.cells, "materials": self.behaviours[b]}
        try:
            return cls.from_params(params, f"settings.{b}")
        except RecipeError as exc:
            raise ValueError(str(exc)) from None

    def field_specs(self) -> list[FieldSpec]:
        """Every behaviour's fields (written ones as inout: a cell a behaviour does not own keeps
        its time-t value), and the material."""
        specs = {MATERIAL_FIELD: FieldSpec(MATERIAL_FIELD, domain=self.cells, at="cell",
                                           intent="in", doc="material id")}
        for rule in self._rules.values():
            for s in rule.field_specs():
                if s.name in specs and specs[s.name].intent != s.intent:
                    s = dataclasses.replace(s, intent="inout")
                specs[s.name] = s
        return list(specs.values())

    def setup(self, state: State) -> None:
        self._t = 0
        saved = state.rule_name
        for rule in self._rules.values():
            state.rule_name = rule.name          # each behaviour draws from its own stream
            try:
                rule.setup(state)
            finally:
                state.rule_name = saved

    def step(self, state: State) -> bool:
        net = self.network(state)
        running = {b: r for b, r in self._rules.items() if self._t < self.steps.get(b, self._t + 1)}
        self._t += 1
        if not running:
            return False
        out, moved = parallel_step(net, running, *self.gates(net))
        if out is not net:
            state.add_domain(self.cells, out)
        for rule in running.values():
            for key, value in rule.reports(out).items():
                state.report(f"{self.cells}.{key}", value)
        return moved


def written_fields(rule: CellRule) -> set[str]:
    return {s.name for s in rule.field_specs() if s.intent in ("out", "inout")}


def parallel_step(net: CellNetwork, rules: dict[str, CellRule], send: np.ndarray,
                  update: np.ndarray) -> tuple[CellNetwork, bool]:
    """The network at t + 1: every behaviour from the same time-t network, merged by material.

    ``rules`` maps a behaviour to its rule (``materials`` = the behaviour's materials), in merge
    order; each ``advance`` sees its own selected receiving cells as the updating ones.
    """
    if MATERIAL_FIELD not in net:
        raise InputError("cellnet.parallel: the network has no cell__material")
    material = np.asarray(net[MATERIAL_FIELD])
    merged = Next(np.zeros(net.n_cells, bool))
    docs: dict[str, str] = {}
    for rule in rules.values():
        own = update & np.isin(material, rule.materials)
        nxt = rule.advance(net, send, own)
        w = nxt.written
        merged.written |= w
        docs.update({s.name: s.doc for s in rule.field_specs()})
        for name, a in nxt.fields.items():
            if name not in merged.fields:
                merged.fields[name] = np.array(net[name]) if name in net else a.copy()
            merged.fields[name][w] = a[w]
        if nxt.positions is not None:
            merged.positions = net.positions.copy() if merged.positions is None else merged.positions
            merged.positions[w] = nxt.positions[w]
    moved = changed_next(net, merged)
    return put_next(net, merged, docs), moved
