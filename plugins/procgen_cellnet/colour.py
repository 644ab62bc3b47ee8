"""Colour on a network: general-state setting, random colour seeds, colour spreading (Table 1).

Table 1's basic rows set the general state of (selected) cells ("Sleeping all", "Active all")
and give random cells random colours ("seed values").  "Spreading col." averages a cell's
colour with its coloured sending neighbours: vc <- (vc + sum vc_n) / (kc + 1).  Read literally,
an uncoloured cell would average in its own null (black) colour and darken every front, so by
default an uncoloured cell with kc > 0 takes the plain mean of its coloured neighbours and
becomes coloured (``literal`` keeps the paper's formula).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, InputError, State, param

from .cellrule import EXAMPLE_NET, CellRule, Next, changed
from .network import CellNetwork
from .states import LABEL_FIELD, STATE_NAMES, put_states, selection, states

COLOR, COLORED = "surface__color", "cell__colored"


def colours(net) -> tuple[np.ndarray, np.ndarray]:
    """(surface__color, cell__colored), uncoloured black when absent."""
    if COLOR not in net:
        return np.zeros((net.n_cells, 3), np.float32), np.zeros(net.n_cells, bool)
    return np.asarray(net[COLOR], np.float32), np.asarray(net[COLORED], bool)


def put_colours(net, color: np.ndarray, colored: np.ndarray) -> None:
    net.add_field(COLOR, np.asarray(color, np.float32), at="cell", doc="RGB colour in [0, 1]")
    net.add_field(COLORED, np.asarray(colored, bool), at="cell", doc="colour is not null")


@dataclass(kw_only=True)
class StateSetting(CellRule):
    """Set the general state of the selected cells (Table 1 "Sleeping all" / "Active all")."""

    name: ClassVar[str] = "cellnet.state"
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("cell__state", domain="{cells}", at="cell", intent="out", doc="general state"),)
    example: ClassVar[tuple[dict, ...]] = EXAMPLE_NET + (
        {"rule": "cellnet.state", "params": {"state": "sleeping", "materials": [0]}},)

    state: str = param("active", choices=STATE_NAMES, doc="general state to give")

    def step(self, state: State) -> bool:
        net = state.get(self.cells, CellNetwork)
        gs = states(net)
        sel = selection(net, self.materials, self.labels, self.name)
        new = gs.copy()
        new[sel] = STATE_NAMES.index(self.state)
        put_states(net, new)
        return changed(gs, new)


@dataclass(kw_only=True)
class RandomColorSeeds(CellRule):
    """Random colour seeds: n selected receiving cells get a random or palette colour (Table 1).

    The seeds of colour spreading (Figure 8(e)); Voronoi regions get their seeds from the
    generic ``ca.voronoi`` and their colours from ``cellnet.label_colors``.
    """

    name: ClassVar[str] = "cellnet.seed_colors"
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(COLOR, domain="{cells}", at="cell", intent="out", units="rgb", doc="RGB colour"),
        FieldSpec(COLORED, domain="{cells}", at="cell", intent="out", doc="colour is not null"),
    )
    example: ClassVar[tuple[dict, ...]] = EXAMPLE_NET + (
        {"rule": "cellnet.seed_colors", "params": {"n_seeds": 5}},)

    n_seeds: int = param(12, ge=1, le=10_000_000, doc="number of seed cells")
    palette: list[list[float]] | None = param(None, doc="RGB colours in [0, 1] (cycled); random if none")

    def validate(self) -> None:
        check_palette(self.palette)

    def step(self, state: State) -> bool:
        net = state.get(self.cells, CellNetwork)
        _, update = self.gates(net)
        cand = np.nonzero(update)[0]
        if len(cand) < self.n_seeds:
            raise InputError(f"{self.name}: {self.n_seeds} seeds but only {len(cand)} selected "
                             "receiving cells")
        rng = state.rng()
        pick = np.sort(rng.choice(cand, self.n_seeds, replace=False))
        color, colored = (a.copy() for a in colours(net))
        color[pick] = palette_colours(self.palette, self.n_seeds, rng)
        colored[pick] = True
        put_colours(net, color, colored)
        return True


@dataclass(kw_only=True)
class LabelColors(CellRule):
    """Colour every labelled selected cell by its region label (label k: palette colour k).

    Turns ``ca.voronoi`` regions into the coloured regions of Figures 9(b) and 10(d);
    unlabelled cells (label 0) stay uncoloured.  ``jitter`` varies each region's colour.
    """

    name: ClassVar[str] = "cellnet.label_colors"
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(LABEL_FIELD, domain="{cells}", at="cell", intent="in", doc="region label"),
        FieldSpec(COLOR, domain="{cells}", at="cell", intent="out", units="rgb", doc="RGB colour"),
        FieldSpec(COLORED, domain="{cells}", at="cell", intent="out", doc="colour is not null"),
    )
    example: ClassVar[tuple[dict, ...]] = EXAMPLE_NET + (
        {"rule": "ca.voronoi", "params": {"seeds": 3}, "iterations": 30},
        {"rule": "cellnet.label_colors"},)

    palette: list[list[float]] | None = param(None, doc="RGB colours in [0, 1] (cycled); random if none")
    jitter: float = param(0.0, ge=0.0, le=1.0, doc="random brightness change per region (fraction)")

    def validate(self) -> None:
        check_palette(self.palette)

    def step(self, state: State) -> bool:
        net = state.get(self.cells, CellNetwork)
        _, update = self.gates(net)
        label = np.asarray(net[LABEL_FIELD], np.int64)
        rng = state.rng()
        n = int(label.max(initial=0))
        table = palette_colours(self.palette, n, rng)
        table *= (1 + self.jitter * (rng.random(n) * 2 - 1))[:, None].astype(np.float32)
        color, colored = (a.copy() for a in colours(net))
        ok = update & (label > 0)
        color[ok] = np.clip(table[label[ok] - 1], 0, 1)
        colored[ok] = True
        put_colours(net, color, colored)
        return True


@dataclass(kw_only=True)
class ColorFromField(CellRule):
    """Colour the selected cells from a bool or integer cell field (alive/dead, labels).

    Maps a CA state to a material's colours: mud from the maze rule, lichen from the
    activator/inhibitor, Life in two tones (Figures 1(j, l), 14).  True / value k takes
    ``palette[1]`` / ``palette[k % len]``; False / 0 takes ``palette[0]``.
    """

    name: ClassVar[str] = "cellnet.color_by"
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("{field}", domain="{cells}", at="cell", intent="in", doc="bool or integer state"),
        FieldSpec(COLOR, domain="{cells}", at="cell", intent="out", units="rgb", doc="RGB colour"),
        FieldSpec(COLORED, domain="{cells}", at="cell", intent="out", doc="colour is not null"),
    )
    example: ClassVar[tuple[dict, ...]] = EXAMPLE_NET + (
        {"rule": "ca.life", "iterations": 2},
        {"rule": "cellnet.color_by"},)

    field: str = param("ca__alive", doc="bool or integer cell field")
    palette: list[list[float]] = param([[0.93, 0.91, 0.86], [0.15, 0.15, 0.15]],
                                       doc="RGB colours in [0, 1]: index 0 for False / 0")

    def validate(self) -> None:
        check_palette(self.palette)

    def step(self, state: State) -> bool:
        net = state.get(self.cells, CellNetwork)
        _, update = self.gates(net)
        a = np.asarray(net[self.field])
        if a.ndim != 1 or not (a.dtype == bool or np.issubdtype(a.dtype, np.integer)):
            raise InputError(f"{self.name}: field {self.field!r} must be one bool or integer per cell")
        pal = np.asarray(self.palette, np.float32)
        color, colored = (x.copy() for x in colours(net))
        color[update] = pal[np.mod(a.astype(np.int64), len(pal))][update]
        colored[update] = True
        put_colours(net, color, colored)
        return True


def check_palette(palette: list[list[float]] | None) -> None:
    if palette is not None and (not palette or any(len(c) != 3 or min(c) < 0 or max(c) > 1
                                                   for c in palette)):
        raise ValueError("palette must be a non-empty list of [r, g, b] values in 0..1")


def palette_colours(palette: list[list[float]] | None, n: int, rng: np.random.Generator) -> np.ndarray:
    """n colours: cycled from the palette, or uniformly random when there is none."""
    if palette is None:
        return rng.random((n, 3)).astype(np.float32)
    pal = np.asarray(palette, np.float32)
    return pal[np.arange(n) % len(pal)]


def spread(net, color: np.ndarray, colored: np.ndarray, send: np.ndarray, update: np.ndarray,
           literal: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """One synchronous spreading step (Table 1 "Spreading col."): the t + 1 colours.

    vc <- (vc + sum vc_n) / (kc + 1) over the coloured sending neighbours; an uncoloured cell
    (own term 0) divides by kc only unless ``literal``.  Computed in the colours' precision
    with the network's precomputed sending / averaging matrices: one (n, 3) product per step.
    """
    dtype = np.float32 if np.asarray(color).dtype == np.float32 else np.float64
    colored = np.asarray(colored, bool)
    if colored.all():                  # the usual steady state: one averaging product
        out_c = (net.averaging(send, dtype) @ np.asarray(color, dtype)).astype(np.float32, copy=False)
        if not update.all():
            np.copyto(out_c, color, where=~update[:, None])
        return out_c, colored.copy()
    g, _ = net.sending(send, dtype)
    own = np.where(colored[:, None], color, 0).astype(dtype)
    kc = g @ colored.astype(dtype)
    new = g @ own
    new += own
    new *= (1 / np.maximum(kc + (colored | literal), 1)).astype(dtype)[:, None]
    ok = update & (colored | (kc > 0))
    out_c = new.astype(np.float32, copy=False)
    if not ok.all():
        np.copyto(out_c, color, where=~ok[:, None])
    return out_c, colored | (update & (kc > 0))


@dataclass(kw_only=True)
class ColorSpreading(CellRule):
    """Colour spreading / diffusion: own colour averaged with coloured sending neighbours.

    Table 1 "Spreading col.", Figures 8(e), 10(f), 1(h).  Stable when no colour moves by more
    than ``tol``.  Sleeping crack cells neither change nor count, so colour never crosses a crack.
    """

    name: ClassVar[str] = "cellnet.diffuse"
    default_iterations: ClassVar[int] = 20
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(COLOR, domain="{cells}", at="cell", intent="inout", units="rgb", doc="RGB colour"),
        FieldSpec(COLORED, domain="{cells}", at="cell", intent="inout", doc="colour is not null"),
    )
    example: ClassVar[tuple[dict, ...]] = EXAMPLE_NET + (
        {"rule": "cellnet.seed_colors", "params": {"n_seeds": 4}},
        {"rule": "cellnet.diffuse"},)

    literal: bool = param(False, doc="the paper's formula for uncoloured cells too (darkens fronts)")
    tol: float = param(1e-6, ge=0.0, doc="stable when no channel changes by more than this")

    def advance(self, net, send: np.ndarray, update: np.ndarray) -> Next:
        new_c, new_k = spread(net, *colours(net), send, update, self.literal)
        return Next(update, {COLOR: new_c, COLORED: new_k})

    def step(self, state: State) -> bool:
        net = self.network(state)
        color, colored = colours(net)
        nxt = self.advance(net, *self.gates(net))
        self.commit(state, net, nxt)
        new_c, new_k = nxt.fields[COLOR], nxt.fields[COLORED]
        return bool(np.any(new_k != colored)) or float(np.abs(new_c - color).max(initial=0)) > self.tol
