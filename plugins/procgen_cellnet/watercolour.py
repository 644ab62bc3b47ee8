"""Watercolour: water that spreads and evaporates, carrying pigment (Table 1, Figure 13).

Table 1 "Watercolor": p <- (p + sum p_n)/(k + 1) - Dp, i.e. the water amount p diffuses by
neighbour averaging and evaporates (clamped at 0).  The pigment formula is garbled in the
source ("Vc <- Vc + V_kc % p"); the reading kept here: with humidity h = min(p / p_sat, 1) and
m the mean pigment of the wet, pigmented sending neighbours, Vc <- Vc + mix h (m - Vc).  A dry
cell (p = 0) never changes colour: the pigment has settled.  A layer (section 5.2: three in
Figure 13) is a brush that wets a disc or a set of regions with water and pigment, then flows
until dry; the layer's settled pigment glazes the cell colour multiplicatively (``surface__color``,
white paper where a cell had none).
Figure 13(a)'s humidity map: blue where p >= p_sat, green shading for p / p_sat.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, InputError, State, param

from .cellrule import EXAMPLE_NET, CellRule, Next
from .colour import COLOR, colours, put_colours
from .network import CellNetwork

WATER, PIGMENT, LAYER = "water__volume", "pigment__color", "paint__layer"


def flow_step(net, p: np.ndarray, pig: np.ndarray, has: np.ndarray, send: np.ndarray,
              update: np.ndarray, dp: float, p_sat: float, mix: float):
    """One synchronous watercolour step: (p, pigment, has-pigment) at t + 1."""
    g, k = net.sending(send)
    new_p = np.maximum((p + g @ p) / (k + 1) - dp, 0.0)
    h = np.clip(p / p_sat, 0.0, 1.0)
    wet = (p > 0) & has
    ks = g @ wet.astype(float)
    m = (g @ (pig * wet[:, None])) / np.maximum(ks, 1)[:, None]
    move = update & (ks > 0) & (p > 0)
    new_pig = np.where(move[:, None], pig + (mix * h)[:, None] * (m - pig), pig)
    return (np.where(update, new_p, p), new_pig.astype(np.float32), has | move)


@dataclass(kw_only=True)
class WatercolorBrush(CellRule):
    """A watercolour brush stroke: wet a disc (or the selected regions) with water and pigment.

    Starts a painting layer: the cells reached get ``water``, the pigment ``color`` and
    ``paint__layer`` = ``layer``.  Unpigmented water is clear (white pigment): a cell the flow
    reaches takes a tint in proportion to its humidity.
    """

    name: ClassVar[str] = "cellnet.paint"
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(WATER, domain="{cells}", at="cell", intent="out", doc="water amount p"),
        FieldSpec(PIGMENT, domain="{cells}", at="cell", intent="out", doc="pigment in the water"),
        FieldSpec(LAYER, domain="{cells}", at="cell", intent="out", doc="last layer that wetted"),
        FieldSpec(COLOR, domain="{cells}", at="cell", intent="out", units="rgb", doc="RGB colour (the paper)"),
        FieldSpec("cell__colored", domain="{cells}", at="cell", intent="out", doc="colour is not null"),
    )
    example: ClassVar[tuple[dict, ...]] = EXAMPLE_NET + (
        {"rule": "cellnet.paint", "params": {"center": [6.0, 6.0, 0.0], "radius": 3.0}},)

    center: list[float] | None = param(None, doc="brush centre [x, y, z] (none: every selected cell)")
    radius: float = param(1.0, gt=0.0, units="length", doc="brush radius")
    water: float = param(1.0, gt=0.0, doc="water amount given (p_0)")
    color: list[float] = param([0.2, 0.35, 0.8], doc="pigment colour (RGB in 0..1)")
    layer: int = param(1, ge=1, le=127, doc="painting layer number")

    def validate(self) -> None:
        if len(self.color) != 3 or min(self.color) < 0 or max(self.color) > 1:
            raise ValueError("color must be [r, g, b] in 0..1")
        if self.center is not None and len(self.center) != 3:
            raise ValueError("center must be [x, y, z]")

    def step(self, state: State) -> bool:
        net = state.get(self.cells, CellNetwork)
        _, update = self.gates(net)
        hit = update.copy()
        if self.center is not None:
            hit &= np.linalg.norm(net.positions - np.asarray(self.center), axis=1) <= self.radius
        if not hit.any():
            raise InputError(f"{self.name}: the brush reaches no cell of {self.cells!r}")
        p = _field(net, WATER, np.zeros(net.n_cells))
        pig = _field(net, PIGMENT, np.ones((net.n_cells, 3), np.float32))
        layer = _field(net, LAYER, np.zeros(net.n_cells, np.int8))
        color, colored = (a.copy() for a in colours(net))
        blank = update & ~colored
        color[blank] = 1.0                          # blank selected cells are white paper
        p[hit] = np.maximum(p[hit], self.water)
        pig[hit] = self.color
        layer[hit] = self.layer
        net.add_field(WATER, p, at="cell", doc="water amount p")
        net.add_field(PIGMENT, pig.astype(np.float32), at="cell", doc="pigment carried (RGB)")
        net.add_field(LAYER, layer.astype(np.int8), at="cell", doc="last layer that wetted the cell")
        put_colours(net, color, colored | blank)
        return True


def _field(net, name: str, default: np.ndarray) -> np.ndarray:
    return np.array(net[name], dtype=default.dtype) if name in net else default


@dataclass(kw_only=True)
class WatercolorFlow(CellRule):
    """Watercolour flow: water diffuses and evaporates; pigment moves with it and settles when dry.

    Run ``until = "stable"``: when every cell of the layer is dry, the layer's pigment glazes
    ``surface__color`` (multiplied in) and the pigment map is cleared for the next layer.
    """

    name: ClassVar[str] = "cellnet.watercolor"
    default_iterations: ClassVar[int] = 400
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(WATER, domain="{cells}", at="cell", intent="inout", doc="water amount p"),
        FieldSpec(PIGMENT, domain="{cells}", at="cell", intent="inout", doc="pigment carried"),
        FieldSpec(LAYER, domain="{cells}", at="cell", intent="inout", doc="last layer that wetted"),
        FieldSpec(COLOR, domain="{cells}", at="cell", intent="inout", units="rgb", doc="RGB colour (the paper)"),
    )
    example: ClassVar[tuple[dict, ...]] = EXAMPLE_NET + (
        {"rule": "cellnet.paint", "params": {"center": [6.0, 6.0, 0.0], "radius": 3.0}},
        {"rule": "cellnet.watercolor", "params": {"dp": 0.1}, "until": "stable",
         "max_iterations": 50},)

    dp: float = param(0.005, gt=0.0, doc="evaporation per step (in units of p_0)")
    p_sat: float = param(0.5, gt=0.0, doc="saturation water level (Figure 13(a) blue)")
    mix: float = param(0.5, ge=0.0, le=1.0, doc="pigment mobility")

    def advance(self, net, send: np.ndarray, update: np.ndarray) -> Next:
        """One flow step; the step that dries the last wet cell also settles the layer: its
        pigment glazes ``surface__color`` (multiplied in) and the pigment map is cleared."""
        p = np.asarray(net[WATER], float)
        pig = np.asarray(net[PIGMENT], np.float32)
        layer = np.asarray(net[LAYER])
        has = layer > 0
        new_p, new_pig, new_has = flow_step(net, p, pig, has, send, update, self.dp, self.p_sat,
                                            self.mix)
        new_layer = np.where(new_has & ~has, layer.max(initial=1), layer).astype(np.int8)
        if np.any(new_p > 0) or not np.any(p > 0):
            return Next(update, {WATER: new_p, PIGMENT: new_pig, LAYER: new_layer})
        wetted = new_layer > 0
        color, _ = colours(net)
        glazed = np.where(wetted[:, None], color * new_pig, color)
        return Next(update | wetted, {WATER: new_p, COLOR: glazed,
                                      PIGMENT: np.ones((net.n_cells, 3), np.float32),
                                      LAYER: np.zeros(net.n_cells, np.int8)})

    def step(self, state: State) -> bool:
        net = self.network(state)
        was_wet = bool(np.any(np.asarray(net[WATER]) > 0))
        self.commit(state, net, self.advance(net, *self.gates(net)))
        return was_wet


def humidity_rgb(p: np.ndarray, p_sat: float) -> np.ndarray:
    """Figure 13(a): blue where p >= p_sat, green shading by p / p_sat elsewhere, white when dry."""
    h = np.clip(p / p_sat, 0, 1)
    rgb = np.column_stack([1 - h, 1 - 0.4 * h, 1 - h])
    rgb[p >= p_sat] = (0.1, 0.2, 0.9)
    return rgb.astype(np.float32)
