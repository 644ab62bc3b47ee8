"""An imposed crack network: cracks drawn on the borders of random cells, for peeling studies.

The thesis peels along "precomputed" cracks loaded from a file (Gobron, §5.3.2(c) step 1, Table
5.3); plate 5.13(b) shows such a crack network on a lattice.  This rule draws one without a
stress model: cells take the nearest of random seed points (a 3-D Voronoi partition of the
cell centres, its borders made irregular by fBm displacement), and every cell with a side
neighbour of a smaller region id becomes cracked (links read both ways).  The crack line is one cell wide and closed
for 4-neighbour flooding (no two uncracked cells of different regions are side neighbours).
``gaps`` opens stretches of the borders, so that regions merge and keep dangling inner cracks
(the shallow group B of Figure 5.24).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np
from scipy.spatial import cKDTree

from procgen import FieldSpec, State, param
from procgen.ca.automaton import CellAutomaton
from procgen.ca.cells import put_cell_values
from procgen.noise import value_noise_3d
from procgen.ca.cells import cell_size
from procgen_layers.stack import THICKNESS, cell_areas, cell_centres

from .peel import layer_index


def region_borders(graph, labels: np.ndarray) -> np.ndarray:
    """Cells on one side of every border: of each link between two labels, the larger one.

    Both ends of a link are looked at, so a one-way cross-edge link cannot let a flood through.
    """
    r, c = graph.rows, graph.indices
    e = labels[r] != labels[c]
    out = np.zeros(graph.n_cells, bool)
    out[np.where(labels[r[e]] > labels[c[e]], r[e], c[e])] = True
    return out


@dataclass(kw_only=True)
class ImposedCracks(CellAutomaton):
    """Imposed crack network on one layer: borders of wiggly random regions (no stress model).

    For peeling without the crack model (thesis §5.3.2(c): cracks are an input).  Writes
    ``crack__width`` (n, L): ``width`` on the border cells of ``layer``, 0 elsewhere.
    """

    name: ClassVar[str] = "cracks.imposed"
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "cube", "subdivisions": 0}},
        {"rule": "surface.cells", "params": {"target_cells": 1500}},
        {"rule": "layers.stack", "params": {"layers": ["copper", {"preset": "patina", "thickness": 0.5}]}},
        {"rule": "cracks.imposed", "params": {"seeds": 8, "gaps": 0.2}},
    )
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(THICKNESS, "{cells}", "cell", "in", units="length", doc="the layer stack"),
        FieldSpec("crack__width", "{cells}", "cell", "out", units="length",
                  doc="width of the widest crack crossing the cell, per layer (0 = not cracked)"),
    )
    neighbourhood: str = param("von_neumann", choices=("von_neumann",),
                               doc="borders between side neighbours (closed for 4-flooding)")
    layer: str = param("", doc="material name of the cracked layer ('' = the top layer)")
    seeds: int = param(40, ge=1, doc="number of random regions")
    wiggle: float = param(0.35, ge=0.0, doc="border displacement, as a share of the region spacing")
    gaps: float = param(0.0, ge=0.0, lt=1.0, doc="share of the border cells left uncracked (in stretches)")
    width: float | None = param(None, gt=0.0, units="length", doc="crack width (default: the cell size)")

    def step(self, state: State) -> bool:
        dom, graph, present = self.cell_domain(state)
        li = layer_index(dom, self.layer, f"{self.name}: domain {self.cells!r}")
        centres = cell_centres(dom)
        area = cell_areas(dom) * present
        spacing = float(np.sqrt(area.sum() / self.seeds))
        rng = state.rng()
        seeds = rng.choice(len(centres), size=min(self.seeds, int(present.sum())), replace=False,
                           p=area / area.sum())
        moved = centres.copy()
        if self.wiggle > 0:
            for axis in range(3):
                moved[:, axis] += self.wiggle * spacing * value_noise_3d(centres, rng, scale=spacing, octaves=2)
        _, labels = cKDTree(centres[seeds]).query(moved)
        cracked = region_borders(graph, labels) & present
        if self.gaps > 0 and cracked.any():
            g = value_noise_3d(centres, rng, scale=0.5 * spacing)
            cracked &= g >= np.quantile(g[cracked], self.gaps)
        width = np.zeros((len(centres), len(dom["material__name"])))
        width[cracked, li] = self.width or cell_size(dom)
        put_cell_values(dom, "crack__width", width, units="length")
        state.report("cracks.imposed.cracked_cells", int(cracked.sum()))
        return True
