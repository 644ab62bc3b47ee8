"""Stress flowers drawn on the surface itself (3DSCA thesis Plate D-19, "a spherical field of
stress flowers").

``cracks.flowers`` lays the flowers out on a flat sheet for SVG; the plate shows them on the
sphere.  ``cracks.flower_paint`` colours the cells that fall inside each flower: the same
eight-petal star as :func:`.sheet.stress_flowers` (a petal each way along the four axes of the
facet frame, log-compressed with one scale for the object, the gaps between petals at a fifth
of the longest), centred on every ``every``-th cell of each facet's grid.  Each cell finds its
flower centre by rounding its grid position to the lattice (no search), then tests its offset
against the star's radius at its angle: one vectorised pass over the cells.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from procgen import FieldSpec, InputError, RuleBase, State, param
from procgen.fields import check_field_name

SPECTRUM = "stress__spectrum"


def star_radius(theta: np.ndarray, tips: np.ndarray) -> np.ndarray:
    """Radius of the eight-petal star at angles ``theta`` (m,) for petal lengths ``tips`` (m, 4).

    Petal k points along k pi/4 and its opposite; between two petals the outline dips to 0.22
    of the longest petal at the half angle, linearly in angle on each side (as the sheet's
    polygons, which join the tip and gap points by straight lines, nearly do).
    """
    r8 = np.concatenate([tips, tips], axis=1)                      # (m, 8) tips at k pi/4
    r_in = 0.22 * tips.max(axis=1)
    a = np.mod(theta, 2 * np.pi) / (np.pi / 4)                     # in petal units
    k = np.floor(a).astype(np.int64) % 8
    f = a - np.floor(a)                                            # 0 at tip k, 1 at tip k + 1
    rows = np.arange(len(theta))
    near = np.where(f < 0.5, r8[rows, k], r8[rows, (k + 1) % 8])
    w = np.abs(f - 0.5) * 2.0                                      # 1 at a tip, 0 at the gap
    return r_in + w * (near - r_in)


def flower_cells(cells: Any, spectrum: np.ndarray, every: int, size: float) -> np.ndarray:
    """(n,) bool: cells inside the stress flower of their facet-grid lattice point."""
    ij = np.asarray(cells.ij, np.int64)
    face = np.asarray(cells.face, np.int64)
    comp_in = np.asarray(cells.comp_in, bool)
    s = np.asarray(spectrum, float)
    pick = np.all(ij % every == 0, axis=1) & comp_in
    if not pick.any():
        return np.zeros(len(ij), bool)
    mean = max(float(np.mean(s[pick])), 1e-300)
    top = max(float(s[pick].max()), 1e-300)
    radius = size * every * np.log1p(s / mean) / np.log1p(top / mean)     # in cells
    centre_ij = np.rint(ij / every).astype(np.int64) * every
    centre = cells.layout.cell_at(face, centre_ij[:, 0], centre_ij[:, 1])
    ok = (centre >= 0)
    ok[ok] &= pick[centre[ok]]
    inside = np.zeros(len(ij), bool)
    c = centre[ok]
    d = (ij[ok] - ij[c]).astype(float)                              # cells, facet frame (ex, ey)
    r = np.hypot(d[:, 0], d[:, 1])
    inside[ok] = r <= star_radius(np.arctan2(d[:, 1], d[:, 0]), radius[c]) + 0.5
    return inside


@dataclass(kw_only=True)
class FlowerPaint(RuleBase):
    """Stress flowers painted on the surface cells (Plate D-19): a cell colour field.

    The cells inside each eight-petal flower take ``color``, the others ``background``; with
    ``blend`` the flower colour is mixed towards the field's own strength (darker = weaker).
    """

    name: ClassVar[str] = "cracks.flower_paint"
    uses: ClassVar[dict[str, str]] = {"{cells}": "SurfaceCells"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(SPECTRUM, "{cells}", "cell", "in", units="1",
                  doc="tension per layer along 0, pi/4, pi/2, 3pi/4 of the facet frame"),
        FieldSpec("{field}", "{cells}", "cell", "out", units="rgb", doc="colour in [0, 1]"),)
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "icosphere", "subdivisions": 1}},
        {"rule": "surface.cells", "params": {"target_cells": 3000}},
        {"rule": "layers.stack", "params": {"layers": [
            {"preset": "stone", "thickness": 1.0}, {"preset": "glaze", "thickness": 0.5, "noise": 0.4}]}},
        {"rule": "cracks.stress", "params": {"share": 25.0, "loops": 5}},
        {"rule": "cracks.flower_paint", "params": {"every": 6}},)
    cells: str = param("cells", doc="SurfaceCells domain with stress__spectrum")
    layer: int = param(-1, ge=-64, le=63, doc="stack layer shown (negative: from the top)")
    every: int = param(8, ge=2, le=1000, doc="one flower every this many cells of a facet grid")
    size: float = param(0.45, gt=0.0, le=1.0, doc="longest petal, share of the flower spacing")
    color: list[float] = param([0.69, 0.29, 0.48], ge=0.0, le=1.0, doc="flower colour (RGB)")
    background: list[float] = param([0.97, 0.96, 0.93], ge=0.0, le=1.0, doc="colour elsewhere (RGB)")
    field: str = param("surface__color", doc="cell colour field to write")

    def validate(self) -> None:
        if len(self.color) != 3 or len(self.background) != 3:
            raise ValueError("color and background must be RGB triples")
        check_field_name(self.field)

    def step(self, state: State) -> bool:
        cells = state.get(self.cells)
        if SPECTRUM not in cells:
            raise InputError(f"{self.name}: no {SPECTRUM} on {self.cells!r} (run cracks.stress first)")
        spec = np.asarray(cells[SPECTRUM], float)
        n_layers = spec.shape[1]
        if not -n_layers <= self.layer < n_layers:
            raise InputError(f"{self.name}: layer {self.layer} is not a layer of the {n_layers}-layer stack")
        inside = flower_cells(cells, spec[:, self.layer % n_layers], self.every, self.size)
        rgb = np.where(inside[:, None], np.asarray(self.color, float), np.asarray(self.background, float))
        cells.add_field(self.field, rgb, at="cell", units="rgb", doc="colour in [0, 1]")
        state.report(f"{self.cells}.flowers.cells", int(inside.sum()))
        state.report(f"{self.cells}.flowers.flowers",
                     int((np.all(np.asarray(cells.ij) % self.every == 0, axis=1)
                          & np.asarray(cells.comp_in, bool)).sum()))
        return True


RULES = [FlowerPaint]
