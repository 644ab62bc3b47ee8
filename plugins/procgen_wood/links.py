"""The link points of a whole model (thesis 4.3.2, Fig. 4.7(b)-(e)): which cells talk across a
facet edge, as a colour per cell that the surface exporters draw.

The thesis's Programming2 projects each edge cell's centre onto the joint edge and pairs it with
the nearest projected centre of the opposite triangle (section 3.4.3, Figs 3.26-3.29); Fig. 4.7
then draws those links over each model.  ``cells_svg`` draws them for a flat patch (Fig.
4.7(a)); on a closed 3-D model the links are too many and too short to draw as strokes, so this
rule marks their ends instead: a cell with no cross-edge partner keeps the light cell colour, a
linked cell turns red, and a cell paired with two or more cells of the same neighbouring
triangle - the "received twice" error the thesis describes at the ends of an edge (Fig. 3.26) -
turns dark blue.  The counts are reported, so a test can check them against the graph.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, RuleBase, State, param
from procgen.ca.graph import CellGraph

#: colours of the three kinds: no cross-edge link, one partner per neighbouring face, several
KIND_COLORS = np.array([[233, 211, 176], [192, 57, 43], [31, 78, 156]], float) / 255.0


def link_kinds(graph: CellGraph, face: np.ndarray) -> tuple[np.ndarray, np.ndarray, int]:
    """Per cell: (cross-edge partner count, kind 0/1/2, number of distinct undirected links).

    Kind 2: some neighbouring triangle holds two or more of the cell's partners (it receives
    from, and sends to, that triangle twice); kind 1: every partner in a different triangle.
    """
    n = graph.n_cells
    if graph.cross is None:
        return np.zeros(n, np.int64), np.zeros(n, np.int8), 0
    rows, cols = graph.rows[graph.cross], graph.indices[graph.cross]
    count = np.bincount(rows, minlength=n)
    n_faces = int(face.max()) + 1 if len(face) else 1
    key, per = np.unique(rows * n_faces + face[cols], return_counts=True)
    twice = np.zeros(n, bool)
    twice[key[per >= 2] // n_faces] = True
    kind = np.where(twice, 2, np.where(count > 0, 1, 0)).astype(np.int8)
    pairs = np.unique(np.sort(np.column_stack([rows, cols]), axis=1), axis=0)
    return count, kind, len(pairs)


@dataclass(kw_only=True)
class LinkPoints(RuleBase):
    """The cells linked across facet edges, coloured (thesis 4.3.2, Fig. 4.7(b)-(e)).

    Light: no cross-edge partner; red: linked; dark blue: two or more partners in one
    neighbouring triangle (the thesis's "received twice", Fig. 3.26).  Build the cells with
    ``neighbours = "pairs"`` for the thesis's links; with unfolded slots most edge cells take
    several cells of the next triangle and so show dark blue.
    """

    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "icosphere", "subdivisions": 1}},
        {"rule": "surface.cells", "params": {"target_cells": 1500, "neighbours": "pairs"}},
        {"rule": "wood.link_points"})
    name: ClassVar[str] = "wood.link_points"
    uses: ClassVar[dict[str, str]] = {"{cells}": "SurfaceCells"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("links__count", domain="{cells}", at="cell", intent="out", units="1",
                  doc="number of cross-edge partners of the cell"),
        FieldSpec("links__color", domain="{cells}", at="cell", intent="out", units="rgb",
                  doc="light: not linked; red: linked; dark blue: two partners in one triangle"),)
    cells: str = param("cells", doc="SurfaceCells domain")

    def step(self, state: State) -> bool:
        from procgen_surface.domain import SurfaceCells

        sc = state.get(self.cells, SurfaceCells)
        count, kind, n_links = link_kinds(sc.graph, np.asarray(sc.face))
        sc.add_field("links__count", count, at="cell", units="1", doc="cross-edge partners")
        sc.add_field("links__color", KIND_COLORS[kind], at="cell", units="rgb", doc="link kind colour")
        n = max(sc.n_cells, 1)
        c = self.cells
        state.report(f"{c}.links.n_links", n_links)
        state.report(f"{c}.links.linked_fraction", float(np.count_nonzero(kind) / n))
        state.report(f"{c}.links.twice_fraction", float(np.count_nonzero(kind == 2) / n))
        return True
