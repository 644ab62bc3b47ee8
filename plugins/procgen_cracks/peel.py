"""Peeling of a cracked layer by groups, in depth order (3DSCA thesis, ch. 5.3, "hybrid CA").

The thesis (Gobron, §5.3.2) peels the first layer of an object in two tasks:

1. *Peeling groups* (Figure-plates 5.13-5.16): the cells bounded by cracks, and by facet edges
   whose dihedral angle exceeds the user's rupture angle gamma (Figure 5.23), flooded with the
   smallest group id (SCA-Functions 5.1-5.4) across facets, so that coplanar or smoothly joined
   facets never split a group (Figure 5.22).  Each pass also raises the *peeling level* of every
   cell already reached and spreads the ids one ring inward (SCA-Functions 5.5, 5.6), a
   distance transform whose passes the thesis counts (28 passes for 1.8 M cells, Figure 5.28).
2. *Order* (§5.3.2(d), SCA-Function 5.7): a group's minimum level tells how deep it is; groups
   peel shallow first, so a group with inner cracks peels before a smaller one without
   (Figure 5.24: "A should peel after B").  Each group is removed at once, with its cracked
   border (Appendix C of §5.3, steps 5.3.1-5.3.2).

Here the floods are :func:`procgen.ca.components.connected_components` and
:func:`~procgen.ca.components.hop_distance` on the CSR cell graph (no recursion).  The rule's
iterations replay the thesis's passes: with ``grow`` the first D iterations reveal one more
ring of levels each (the frames of plates 5.16 and 5.17(b)-(d)), then each iteration removes
the groups of the next depth (plate 5.17(e)-(j)).  Partial peeling as elevation (§5.3.3,
Figure 5.30): t = T pc / (1 + pc), or T pc / sqrt(1 + pc^2), where pc is the thesis's level.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from procgen import FieldSpec, InputError, State, param
from procgen import geometry as geo
from procgen.ca.automaton import CellAutomaton
from procgen.ca.cells import NEIGHBOURHOODS, cell_values, put_cell_values
from procgen.ca.components import connected_components, hop_distance
from procgen.ca.graph import CellGraph
from procgen_layers.stack import THICKNESS, cell_areas, load_table, put_thickness

CELLS = "{cells}"
#: data views: cells whose layer has peeled
PEELED_COLOR = (0.45, 0.62, 0.85)


def layer_index(domain: Any, layer: str, where: str) -> int:
    """Index of the named layer of the stack ('' = the top layer)."""
    names = load_table(domain, where).names
    if layer == "":
        return len(names) - 1
    if layer not in names:
        raise InputError(f"{where}: no layer {layer!r} in the stack (layers: {', '.join(names)})")
    return names.index(layer)


def sharp_links(domain: Any, graph: CellGraph, gamma: float) -> np.ndarray:
    """Graph entries that cross a mesh edge bent by more than ``gamma`` degrees (thesis Fig. 5.23).

    The bend is the angle between the two facets' normals (0 for coplanar facets), so an
    outward-oriented mesh is assumed.  Domains without facets (a Grid) have no sharp links.
    """
    face = getattr(domain, "face", None)
    if face is None or not hasattr(domain, "vertices") or gamma >= 180.0:
        return np.zeros(len(graph.indices), bool)
    fn = geo.face_normals(np.asarray(domain.vertices, float), np.asarray(domain.faces))
    a, b = face[graph.rows], face[graph.indices]
    out = a != b                                       # only links between two facets can bend
    e = np.nonzero(out)[0]
    out[e] = np.einsum("ij,ij->i", fn[a[e]], fn[b[e]]) < np.cos(np.radians(gamma)) - 1e-12
    return out


@dataclass(frozen=True)
class PeelPlan:
    """Groups, levels and schedule of one peeling (flat per-cell arrays, -1 = none)."""

    group: np.ndarray      # (n,) group id 0..G-1; -1 cracked or not peelable
    level: np.ndarray      # (n,) cells from the crack border: 0 cracked, 1 beside it; -1 none
    time: np.ndarray       # (n,) peeling step 0..n_steps-1 of the cell (cracked border too)
    depth: np.ndarray      # (G,) deepest level of each group; 0 = no border (never peels)
    n_steps: int           # number of peeling steps (distinct depths)

    @property
    def passes(self) -> int:
        """Propagation passes of the thesis's task 1: the deepest level."""
        return int(self.depth.max(initial=0))


def plan_peeling(graph: CellGraph, cracked: np.ndarray, peelable: np.ndarray,
                 keep: np.ndarray) -> PeelPlan:
    """Peeling groups, levels and order (thesis §5.3.2(c)-(d)).

    ``cracked``: cells under a crack; ``peelable``: cells holding the peeling layer; ``keep``:
    graph entries that do not cross a sharp edge.  A group is a connected region of peelable,
    uncracked cells along kept links.  Its border cells (level 1) touch a crack, a cell without
    the layer, or a sharp edge; levels grow by one per link inward.  Group depth = its deepest
    level; steps are the distinct depths, shallowest first.  A cracked cell peels with the
    earliest group beside it (reached through cracked cells if the crack is wider than a cell).
    """
    n = graph.n_cells
    cracked = np.asarray(cracked, bool) & peelable
    inside = peelable & ~cracked
    group, n_groups = connected_components(graph, inside, keep)
    r, c = graph.rows, graph.indices
    border = np.zeros(n, bool)
    border[r[inside[r] & (~inside[c] | ~keep)]] = True
    dist = hop_distance(graph, border, inside, keep)
    level = np.where(inside & (dist >= 0), dist + 1, -1)
    level[cracked] = 0
    depth = np.zeros(n_groups, np.int64)
    np.maximum.at(depth, group[inside], np.maximum(level[inside], 0))
    steps, rank = np.unique(depth, return_inverse=True)
    first = 1 if len(steps) and steps[0] == 0 else 0           # depth 0: intact, never peels
    gtime = np.where(depth > 0, rank - first, -1)
    time = np.full(n, -1, np.int64)
    time[inside] = gtime[group[inside]]
    _crack_times(graph, cracked, time, int(len(steps) - first))
    return PeelPlan(group, level, time, depth, int(len(steps) - first))


def _crack_times(graph: CellGraph, cracked: np.ndarray, time: np.ndarray, n_steps: int) -> None:
    """Cracked cells peel at the earliest step of a neighbour, ring by ring into wide cracks;
    crack cells that no group reaches go with the last step (the layer ends empty)."""
    r, c = graph.rows, graph.indices
    todo = cracked & (time < 0)
    while todo.any():
        e = todo[r] & (time[c] >= 0)
        if not e.any():
            break
        best = np.full(len(time), np.iinfo(np.int64).max)
        np.minimum.at(best, r[e], time[c[e]])
        hit = best < np.iinfo(np.int64).max
        time[hit] = best[hit]
        todo &= ~hit
    if n_steps > 0:
        time[todo] = n_steps - 1


def _areas(dom: Any, n: int) -> np.ndarray:
    """Cell areas where the domain gives them (Grid, surface cells), else one per cell."""
    try:
        return cell_areas(dom)
    except InputError:
        return np.ones(n)


def deaden(pc: np.ndarray, height: float, kind: str) -> np.ndarray:
    """Thesis Figure 5.30: elevation t(pc), 0 at pc = 0, increasing, saturating below T."""
    pc = np.maximum(np.asarray(pc, float), 0.0)
    return height * (pc / (1.0 + pc) if kind == "rational" else pc / np.sqrt(1.0 + pc * pc))


def level_colors(age: np.ndarray, reached: np.ndarray, cracked: np.ndarray) -> np.ndarray:
    """Thesis plate 5.16 palette: cracked black, not reached white, older (higher) darker."""
    top = max(int(age.max(initial=0)), 1)
    grey = np.where(reached, 0.92 - 0.72 * (age - 1) / top, 1.0)
    grey = np.where(cracked, 0.0, grey)
    return np.repeat(grey[:, None], 3, axis=1)


def group_colors(group: np.ndarray, cracked: np.ndarray) -> np.ndarray:
    """One pastel colour per group id (golden-ratio hues), cracked black, no group white."""
    import colorsys
    k = int(group.max(initial=-1)) + 1
    hues = (np.arange(k) * 0.618033988749895) % 1.0
    sat = 0.35 + 0.4 * ((np.arange(k) * 7) % 3) / 2
    pal = np.array([colorsys.hsv_to_rgb(h, s, 0.95) for h, s in zip(hues, sat)]).reshape(-1, 3)
    out = np.ones((len(group), 3))
    has = group >= 0
    out[has] = pal[group[has]]
    out[cracked] = 0.0
    return out


@dataclass(kw_only=True)
class Peel(CellAutomaton):
    """Peeling of a cracked layer: groups between cracks and sharp edges, removed shallow first.

    Gobron's 3DSCA thesis ch. 5.3.  Cracked cells are ``crack__width[:, layer] > 0``; edges bent
    more than the rupture angle ``gamma`` also split groups, coplanar facets never do.  With
    ``grow`` the first iterations spread the peeling levels one ring per pass (plate 5.16), then
    every iteration removes the next groups in depth order with their cracked borders: the
    layer's thickness drops to ``residue`` (cracked cells) or 0, so ``layers.shade`` shows the
    layer beneath.  Run with ``until = "stable"``: it stops once the last group has peeled.
    """

    name: ClassVar[str] = "cracks.peel"
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "cube", "subdivisions": 0}},
        {"rule": "surface.cells", "params": {"target_cells": 1500}},
        {"rule": "layers.stack", "params": {"layers": ["copper", {"preset": "patina", "thickness": 0.5}]}},
        {"rule": "cracks.imposed", "params": {"seeds": 8}},
        {"rule": "cracks.peel", "until": "stable", "max_iterations": 60,
         "params": {"lift_height": 0.1, "view": "levels"}},
    )
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("crack__width", CELLS, "cell", "in", units="length",
                  doc="width of the widest crack crossing the cell, per layer (0 = not cracked)"),
        FieldSpec(THICKNESS, CELLS, "cell", "inout", units="length",
                  doc="thickness per layer; the peeling layer drops to 0 where it peeled"),
        FieldSpec("peel__group", CELLS, "cell", "out", units="",
                  doc="peeling-group id, -1 cracked, not reached or not peelable"),
        FieldSpec("peel__level", CELLS, "cell", "out", units="",
                  doc="cells from the crack border (0 cracked, 1 beside a crack), -1 none"),
        FieldSpec("peel__time", CELLS, "cell", "out", units="steps",
                  doc="iteration at which the cell's layer peeled, -1 not (yet)"),
        FieldSpec("peel__lift", CELLS, "cell", "out", units="length",
                  doc="partial-peeling elevation t = T pc / (1 + pc) of the unpeeled layer"),
        FieldSpec("peel__color", CELLS, "cell", "out", units="rgb",
                  doc="data view of the peeling (groups or levels), when view is set"),
    )
    neighbourhood: str = param("von_neumann", choices=NEIGHBOURHOODS,
                               doc="flooding links: the 4 side neighbours (with 8-connected "
                                   "cracks, so no group leaks through a diagonal) or all 8")
    layer: str = param("", doc="material name of the peeling layer ('' = the top layer)")
    gamma: float = param(30.0, ge=0.0, le=180.0, units="deg",
                         doc="rupture angle: facet edges bent more than this split groups")
    grow: bool = param(True, doc="spend one iteration per level ring before peeling (plate 5.16)")
    lift_height: float = param(0.0, ge=0.0, units="length", doc="T, saturation of the elevation")
    deaden: str = param("rational", choices=("rational", "root"),
                        doc="elevation T pc/(1+pc) or T pc/sqrt(1+pc^2) (thesis Figure 5.30)")
    residue: float = param(0.0, ge=0.0, le=1.0,
                           doc="share of the layer left on cracked cells after peeling (plate 5.18)")
    peel_share: float = param(1.0, ge=0.0, le=1.0,
                              doc="stop after this share of the peeling steps (0: groups and levels "
                                  "only, plates 5.13-5.16; 0.5: mid-peel, plate 5.20(d))")
    view: str = param("", choices=("", "groups", "levels"),
                      doc="write peel__color each iteration: group colours or the level greys")

    def setup(self, state: State) -> None:
        dom, graph, present = self.cell_domain(state)
        where = f"{self.name}: domain {self.cells!r}"
        self._li = layer_index(dom, self.layer, where)
        thick = np.array(cell_values(dom, THICKNESS), float)
        if "crack__width" not in dom:
            raise InputError(f"{where} has no crack__width (run a crack rule first)")
        width = cell_values(dom, "crack__width")
        if width.shape != thick.shape:
            raise InputError(f"{where}: crack__width has shape {width.shape}, layers__thickness "
                             f"{thick.shape}")
        peelable = present & (thick[:, self._li] > 0)
        keep = ~sharp_links(dom, graph, self.gamma)
        self._plan = plan_peeling(graph, width[:, self._li] > 0, peelable, keep)
        self._pass = 0
        p = self._plan
        peeling = p.depth > 0
        state.report("peel.steps", p.passes)
        state.report("peel.groups", int(peeling.sum()))
        state.report("peel.peel_steps", p.n_steps)
        state.report("peel.cracked_cells", int((p.level == 0).sum()))
        state.report("peel.group_cells", int((p.group >= 0).sum()))
        state.report("peel.intact_cells", int(((p.group >= 0) & ~peeling[np.maximum(p.group, 0)]).sum()))
        state.report("peel.sharp_links", int((~keep).sum()))
        state.report("peel.deepest_level", p.passes)
        self._area = np.where(peelable, _areas(dom, graph.n_cells), 0.0)
        sizes = np.bincount(p.group[p.group >= 0], self._area[p.group >= 0], minlength=len(p.depth))
        state.report("peel.largest_group_share", float(sizes.max(initial=0.0) / max(sizes.sum(), 1e-300)))
        state.report("peel.exposed_share", 0.0)
        put_cell_values(dom, "peel__time", np.full(graph.n_cells, -1, np.int64), units="steps")
        self._rgb: np.ndarray | None = None
        self._grown(dom, 0 if self.grow else p.passes)

    def _grown(self, dom: Any, passes: int) -> None:
        """Fields after ``passes`` passes of task 1: the cells within that many rings are reached."""
        p = self._plan
        cracked = p.level == 0
        reached = (p.level > 0) & (p.level <= passes)
        # the thesis's level pc: passes since the front reached the cell (older = higher)
        age = np.where(reached, passes - p.level + 1, 0)
        group = np.where(reached, p.group, -1)
        put_cell_values(dom, "peel__group", group, units="")
        put_cell_values(dom, "peel__level", np.where(reached | cracked, p.level, -1), units="")
        self._lift = deaden(age, self.lift_height, self.deaden)
        put_cell_values(dom, "peel__lift", self._lift, units="length")
        if self.view == "groups":
            self._rgb = group_colors(group, cracked)
        elif self.view == "levels":
            self._rgb = level_colors(age, reached, cracked)
        if self._rgb is not None:
            put_cell_values(dom, "peel__color", self._rgb, units="rgb")

    def _peeled(self, dom: Any, now: np.ndarray) -> None:
        """Fields after a peeling step: the peeled cells lie flat and show as peeled."""
        self._lift = np.where(now, 0.0, self._lift)
        put_cell_values(dom, "peel__lift", self._lift, units="length")
        if self._rgb is not None:
            self._rgb = np.where(now[:, None], np.asarray(PEELED_COLOR), self._rgb)
            put_cell_values(dom, "peel__color", self._rgb, units="rgb")

    def step(self, state: State) -> bool:
        dom = state.get(self.cells)
        p = self._plan
        self._pass += 1
        if self.grow and self._pass <= p.passes:           # task 1: one more ring of levels
            self._grown(dom, self._pass)
            return True
        k = self._pass - 1 - (p.passes if self.grow else 0)  # task 2: peeling step k
        if k >= int(np.ceil(self.peel_share * p.n_steps - 1e-9)):
            return False
        now = p.time == k
        thick = np.array(cell_values(dom, THICKNESS), float)
        thick[now, self._li] *= np.where(p.level[now] == 0, self.residue, 0.0)
        put_thickness(dom, thick, load_table(dom))
        t = np.where(now, state.iteration, cell_values(dom, "peel__time"))
        put_cell_values(dom, "peel__time", t, units="steps")
        # area share of the layer gone so far (the layer beneath shows; residue on cracks counts)
        gone = (t >= 0) & (thick[:, self._li] <= 0)
        state.report("peel.exposed_share", float(self._area[gone].sum() / max(self._area.sum(), 1e-300)))
        self._peeled(dom, now)
        return True
