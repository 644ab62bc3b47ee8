"""Rules that render crack paths on the surface cells (3DSCA thesis 5.2.5, plates 5.4, 5.11).

``cracks.render`` subdivides the cracked cells into k x k micro-cells and stores their anti-aliased
crack coverage; ``cracks.mirror`` stores the crack-mirror shadow and highlight bands on the lower
layer for one light per iteration; ``cracks.draw`` lays given linked segments with widths on a
flat mesh as crack paths (plate 5.4 renders such a hand-made linked segment, and the tests use
it); ``cracks.sheet`` unfolds the paths into a 2-D sheet for the SVG exporter.  The textured
mesh with the lower layer showing through is the exporters' work (:mod:`.exporters`).

Crack paths follow the family's contract: a Polylines domain of 3-D points, each segment i->i+1
inside facet ``crack__face[i]``, widths ``crack__width`` per point, ``crack__layer`` per line.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from procgen import FieldSpec, InputError, Polylines, RuleBase, State, param
from procgen import geometry as geo
from procgen.lighting import light_direction

from .mirror import MODELS, front_lit_faces, mirror_bands
from .render import PROFILES, Segments, facet_segments, micro_coverage

THICKNESS = "layers__thickness"
_EXAMPLE_FLAT = (
    {"rule": "mesh.primitive", "params": {"shape": "plane", "subdivisions": 2}},
    {"rule": "surface.cells", "params": {"target_cells": 400}},
    {"rule": "layers.stack", "params": {"layers": [
        {"preset": "stone", "thickness": 1.0, "noise": 0.0},
        {"preset": "glaze", "thickness": 0.5, "noise": 0.2}]}},
    {"rule": "cracks.draw", "params": {"lines": [[-0.4, -0.3, 0.01, 0.0, 0.1, 0.03, 0.4, 0.2, 0.01]]}},
)


def crack_segments(cells, paths: Polylines, layer: int) -> Segments:
    """The segments of the cracks in stack layer ``layer`` (all lines if the paths carry none)."""
    for name in ("crack__width", "crack__face"):
        if name not in paths:
            raise InputError(f"crack paths: the Polylines has no point field {name!r}")
    lines = None
    if "crack__layer" in paths:
        lines = np.nonzero(np.asarray(paths["crack__layer"]) == layer)[0]
    return facet_segments(cells, np.asarray(paths.points, float), np.asarray(paths.offsets),
                          paths["crack__face"], paths["crack__width"], lines)


def stack_layer(cells, layer: int) -> int:
    """Layer index (negative counts from the top) checked against the stack on ``cells``."""
    n = np.asarray(cells[THICKNESS]).shape[1]
    if not -n <= layer < n:
        raise InputError(f"crack layer {layer} is not a layer of the {n}-layer stack")
    return layer % n


@dataclass(kw_only=True)
class RenderCracks(RuleBase):
    """Anti-aliased crack coverage of k x k micro-cells in every cracked cell (thesis 5.2.5.a).

    Width profiles across the crack: constant (area fraction) or the V / U linear, parabolic A
    and parabolic B types of App. B 2 (U: saturated centre of ``saturation`` of the half-width).
    The subdivided cells are those the crack band overlaps.  Exported meshes (crack_obj,
    crack_glb, crack_png) show the layers below through the coverage.
    """

    name: ClassVar[str] = "cracks.render"
    cells: str = param("cells", doc="SurfaceCells domain carrying the layer stack")
    paths: str = param("cracks", doc="Polylines domain of crack paths (the family's contract)")
    layer: int = param(-1, ge=-64, le=63, doc="cracked stack layer (negative: from the top)")
    k: int = param(6, ge=1, le=32, doc="micro-cells per cell side (thesis: 3, 6, 11, 16)")
    profile: str = param("v_linear", choices=PROFILES, doc="width profile across the crack (App. B 2)")
    saturation: float = param(0.5, ge=0.0, lt=1.0, doc="U types: saturated share C% of the half-width")
    uses: ClassVar[dict[str, str]] = {"{cells}": "SurfaceCells", "{paths}": "Polylines"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(THICKNESS, domain="{cells}", at="cell", intent="in", units="length",
                  doc="layer stack, bottom first"),
        FieldSpec("crack__coverage", domain="{cells}", at="cell", intent="out", units="1",
                  doc="(n, k, k) crack coverage of each micro-cell [cell, x, y]"),
    )
    example: ClassVar[tuple[dict, ...]] = _EXAMPLE_FLAT + (
        {"rule": "cracks.render", "params": {"k": 4}},)

    def step(self, state: State) -> bool:
        cells = state.get(self.cells)
        paths = state.get(self.paths, Polylines)
        layer = stack_layer(cells, self.layer)
        seg = crack_segments(cells, paths, layer)
        cov = micro_coverage(cells, seg, self.k, profile=self.profile, saturation=self.saturation)
        cracked = cov.reshape(len(cov), -1).max(axis=1) > 0
        cells.add_field("crack__coverage", cov, at="cell", units="1",
                        doc=f"crack coverage of {self.k}x{self.k} micro-cells, layer {layer}")
        state.report(f"{self.cells}.cracks.cracked_cells", int(cracked.sum()))
        state.report(f"{self.cells}.cracks.covered_micro_cells", int((cov > 0).sum()))
        return True


def parse_light(entry: list[float]) -> np.ndarray:
    """(azimuth, elevation) degrees -> sun direction (3,); (x, y, z) -> spot position (1, 3)."""
    if len(entry) == 2:
        return light_direction(float(entry[0]), float(entry[1]))
    return np.asarray(entry, dtype=float).reshape(1, 3)


@dataclass(kw_only=True)
class CrackMirror(RuleBase):
    """Crack-mirror shadow and highlight bands on the layer under a cracked glaze (thesis 5.2.5.b).

    One light per iteration (``lights[i % len]``): [azimuth, elevation] in degrees is a sun,
    [x, y, z] a spot light.  Only front-lit facets get bands; the band offset is the glaze
    thickness (times ``depth`` cells per unit of layer thickness) through Snell refraction, or
    the thesis's cheap deadened offset T sin(alpha) (``model = damped``).
    """

    name: ClassVar[str] = "cracks.mirror"
    cells: str = param("cells", doc="SurfaceCells domain carrying the layer stack")
    paths: str = param("cracks", doc="Polylines domain of crack paths (the family's contract)")
    layer: int = param(-1, ge=-64, le=63, doc="cracked glaze layer (negative: from the top)")
    k: int = param(6, ge=1, le=32, doc="micro-cells per cell side")
    profile: str = param("v_linear", choices=PROFILES, doc="width profile across each band")
    lights: list[list[float]] = param([[30.0, 45.0]], doc="one light per iteration: [azimuth, "
                                      "elevation] degrees (sun) or [x, y, z] (spot)")
    refraction: float = param(1.5, ge=1.0, le=4.0, doc="glaze refraction index (Snell)")
    model: str = param("snell", choices=MODELS, doc="snell (Eq. 2) or damped T sin(alpha) (Eqs. 3-4)")
    depth: float = param(1.0, gt=0.0, doc="cells of surface length per unit of layer thickness")
    uses: ClassVar[dict[str, str]] = {"{cells}": "SurfaceCells", "{paths}": "Polylines"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(THICKNESS, domain="{cells}", at="cell", intent="in", units="length",
                  doc="layer stack, bottom first"),
        FieldSpec("crack__shadow", domain="{cells}", at="cell", intent="out", units="1",
                  doc="(n, k, k) crack-mirror shadow coverage of each micro-cell"),
        FieldSpec("crack__highlight", domain="{cells}", at="cell", intent="out", units="1",
                  doc="(n, k, k) crack-mirror highlight coverage of each micro-cell"),
    )
    example: ClassVar[tuple[dict, ...]] = _EXAMPLE_FLAT + (
        {"rule": "cracks.mirror", "params": {"k": 4, "lights": [[0.0, 40.0], [180.0, 40.0]]}},)

    def validate(self) -> None:
        if not self.lights or any(len(e) not in (2, 3) for e in self.lights):
            raise ValueError("lights must be a non-empty list of [azimuth, elevation] or [x, y, z]")
        for e in self.lights:
            if len(e) == 2 and (not -90.0 <= e[1] <= 90.0):
                raise ValueError(f"light elevation {e[1]} must be in [-90, 90] degrees")

    def step(self, state: State) -> bool:
        cells = state.get(self.cells)
        paths = state.get(self.paths, Polylines)
        layer = stack_layer(cells, self.layer)
        light = parse_light(self.lights[max(state.iteration, 0) % len(self.lights)])
        seg = crack_segments(cells, paths, layer)
        t = np.asarray(cells[THICKNESS], float)[:, layer]
        ij = np.floor(0.5 * (seg.a + seg.b) / cells.size).astype(np.int64)
        under = cells.layout.cell_at(seg.face, ij[:, 0], ij[:, 1])
        glaze = np.where(under >= 0, t[np.maximum(under, 0)], 0.0) * self.depth * cells.size
        shadow, highlight, front = mirror_bands(cells, seg, glaze, light,
                                                refraction=self.refraction, model=self.model)
        lit = front_lit_faces(cells, light)
        for name, band in (("crack__shadow", shadow), ("crack__highlight", highlight)):
            cov = micro_coverage(cells, band, self.k, profile=self.profile, faces=lit)
            cells.add_field(name, cov, at="cell", units="1",
                            doc=f"crack-mirror {name[7:]} of {self.k}x{self.k} micro-cells")
        state.report(f"{self.cells}.cracks.mirror_front_lit_segments", int(front.sum()))
        return True


@dataclass(kw_only=True)
class DrawCracks(RuleBase):
    """Crack paths from given linked segments with widths on a flat mesh (plate 5.4's test line).

    Each line is [x0, y0, w0, x1, y1, w1, ...] in the mesh's plane (z = const): points and the
    crack width there.  The paths are split at facet edges (a point on the edge) so that every
    segment lies in one facet, as the crack model stores them.
    """

    name: ClassVar[str] = "cracks.draw"
    cells: str = param("cells", doc="SurfaceCells domain of a flat mesh (normal along z)")
    paths: str = param("cracks", doc="name of the Polylines domain to create")
    lines: list[list[float]] = param([[0.0, 0.0, 0.01, 0.1, 0.0, 0.01]],
                                     doc="linked segments: [x0, y0, w0, x1, y1, w1, ...] each")
    layer: int = param(-1, ge=-64, le=63, doc="stack layer the cracks are in (negative: from the top)")
    uses: ClassVar[dict[str, str]] = {"{cells}": "SurfaceCells"}
    creates: ClassVar[dict[str, str]] = {"{paths}": "Polylines"}
    default_iterations: ClassVar[int] = 1
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("crack__width", domain="{paths}", at="point", intent="out", units="length",
                  doc="crack width at each path point"),
        FieldSpec("crack__face", domain="{paths}", at="point", intent="out", units="",
                  doc="facet of the segment starting at each point"),
        FieldSpec("crack__layer", domain="{paths}", at="line", intent="out", units="",
                  doc="stack layer of each crack"),
        FieldSpec("crack__type", domain="{paths}", at="line", intent="out", units="",
                  doc="crack type (0 I, 1 T, 2 Y, 3 X; Table 5.3)"),
    )
    example: ClassVar[tuple[dict, ...]] = _EXAMPLE_FLAT[:3] + (
        {"rule": "cracks.draw", "params": {"lines": [[-0.4, -0.3, 0.01, 0.4, 0.2, 0.02]]}},)

    def validate(self) -> None:
        for i, ln in enumerate(self.lines):
            if len(ln) < 6 or len(ln) % 3:
                raise ValueError(f"lines[{i}] must be x, y, width triples (at least two points)")
            if min(ln[2::3]) < 0:
                raise ValueError(f"lines[{i}] has a negative width")

    def step(self, state: State) -> bool:
        cells = state.get(self.cells)
        layer = stack_layer(cells, self.layer) if THICKNESS in cells else max(self.layer, 0)
        v = cells.vertices
        nrm = np.cross(v[cells.faces[:, 1]] - v[cells.faces[:, 0]], v[cells.faces[:, 2]] - v[cells.faces[:, 0]])
        flat = np.abs(nrm[:, :2]).max() <= 1e-9 * np.abs(nrm[:, 2]).max() and np.ptp(v[:, 2]) <= 1e-9
        if not flat:
            raise InputError(f"cracks.draw: the mesh of {self.cells!r} is not flat in a z = const plane")
        pts, width, face, offsets = [], [], [], [0]
        for ln in self.lines:                        # a handful of user lines: setup, not per step
            p, w, f = split_at_facets(cells, np.asarray(ln, float).reshape(-1, 3))
            pts.append(p)
            width.append(w)
            face.append(f)
            offsets.append(offsets[-1] + len(p))
        z = float(v[0, 2])
        xyz = np.column_stack([np.concatenate(pts), np.full(offsets[-1], z)])
        out = Polylines(xyz, np.asarray(offsets))
        out.add_field("crack__width", np.concatenate(width), at="point", units="length")
        out.add_field("crack__face", np.concatenate(face), at="point", units="")
        out.add_field("crack__layer", np.full(len(self.lines), layer, np.int64), at="line", units="")
        out.add_field("crack__type", np.zeros(len(self.lines), np.int64), at="line", units="")
        state.add_domain(self.paths, out)
        return True


def split_at_facets(cells, line: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points (xy), widths and facets of one line [x, y, w] split where it crosses facet edges."""
    tri = cells.vertices[cells.faces][:, :, :2]                     # (m, 3, 2)
    sgn = np.sign(geo.orient2d(tri[:, 0], tri[:, 1], tri[:, 2]))
    p0, p1 = line[:-1, :2], line[1:, :2]
    w0, w1 = line[:-1, 2], line[1:, 2]
    d = p1 - p0
    # parametric clip of every segment against every triangle's three half-planes
    e0 = tri
    e1 = np.roll(tri, -1, axis=1)
    en = np.stack([-(e1 - e0)[..., 1], (e1 - e0)[..., 0]], -1) * sgn[:, None, None]   # inward
    num = np.einsum("mkc,smkc->smk", en, e0[None] - p0[:, None, None])             # n.(e0 - p0)
    den = np.einsum("mkc,sc->smk", en, d)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = num / den
    enter = np.where(den > 0, t, -np.inf).max(axis=2)        # n.(p0 + t d - e0) >= 0
    leave = np.where(den < 0, t, np.inf).min(axis=2)
    inside = np.all((den != 0) | (num <= 1e-12), axis=2)
    lo, hi = np.clip(enter, 0, 1), np.clip(leave, 0, 1)
    ok = inside & (hi - lo > 1e-9) & cells.valid[None, :]
    s_idx, f_idx = np.nonzero(ok)
    if len(s_idx) == 0:
        raise InputError("cracks.draw: a line lies outside the mesh")
    t0 = lo[s_idx, f_idx]
    order = np.lexsort((t0, s_idx))
    s_idx, f_idx, t0 = s_idx[order], f_idx[order], t0[order]
    pts = p0[s_idx] + t0[:, None] * d[s_idx]
    wid = w0[s_idx] + t0 * (w1 - w0)[s_idx]
    last = len(p0) - 1
    pts = np.vstack([pts, p1[last]])
    wid = np.append(wid, w1[last])
    face = np.append(f_idx, f_idx[-1])
    return pts, wid, face


@dataclass(kw_only=True)
class CrackSheet(RuleBase):
    """Crack paths unfolded onto one flat sheet (planar patches side by side) for the SVG exporter.

    A flat mesh is one patch (its 2-D grid); a cube gives its six sides; curved surfaces give
    one panel per facet.  Lines keep their widths; patch outlines are lines of layer -1.
    """

    name: ClassVar[str] = "cracks.sheet"
    cells: str = param("cells", doc="SurfaceCells domain the paths lie on")
    paths: str = param("cracks", doc="Polylines domain of crack paths (the family's contract)")
    sheet: str = param("crack_sheet", doc="name of the 2-D Polylines domain to create")
    gap: float = param(0.08, ge=0.0, le=1.0, doc="space between panels, share of the largest panel")
    uses: ClassVar[dict[str, str]] = {"{cells}": "SurfaceCells", "{paths}": "Polylines"}
    creates: ClassVar[dict[str, str]] = {"{sheet}": "Polylines"}
    default_iterations: ClassVar[int] = 1
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("crack__width", domain="{sheet}", at="point", intent="out", units="length",
                  doc="crack width at each sheet point (0 on outlines)"),
        FieldSpec("crack__layer", domain="{sheet}", at="line", intent="out", units="",
                  doc="stack layer of each crack piece; -1 = a patch outline edge"),
        FieldSpec("crack__type", domain="{sheet}", at="line", intent="out", units="",
                  doc="crack type of each piece (Table 5.3); -1 = outline"),
    )
    example: ClassVar[tuple[dict, ...]] = _EXAMPLE_FLAT + ({"rule": "cracks.sheet", "params": {}},)

    def step(self, state: State) -> bool:
        from .sheet import crack_sheet

        cells = state.get(self.cells)
        paths = state.get(self.paths, Polylines)
        if paths.n_lines == 0 or len(paths.points) < 2:
            raise InputError(f"cracks.sheet: {self.paths!r} has no crack segment to lay out")
        state.add_domain(self.sheet, crack_sheet(cells, paths, gap=self.gap))
        return True


@dataclass(kw_only=True)
class StressFlowers(RuleBase):
    """"Stress flowers" (plate D-19): the stress spectrum as 8-petal glyphs on a flat sheet.

    One star per cell on a lattice of ``every`` cells, a petal each way along the four axes of
    the cell's facet frame, log-compressed with one scale for the object (App. C step 4); the
    planar patches laid side by side as for the crack sheet (closed lines: the core ``svg``
    exporter fills them).
    """

    name: ClassVar[str] = "cracks.flowers"
    cells: str = param("cells", doc="SurfaceCells domain with stress__spectrum")
    layer: int = param(-1, ge=-64, le=63, doc="stack layer shown (negative: from the top)")
    flowers: str = param("stress_flowers", doc="name of the 2-D Polylines domain to create")
    every: int = param(4, ge=1, le=1000, doc="one flower every this many cells of a facet grid")
    size: float = param(0.45, gt=0.0, le=2.0, doc="longest petal, share of the flower spacing")
    gap: float = param(0.08, ge=0.0, le=1.0, doc="space between panels, share of the largest panel")
    uses: ClassVar[dict[str, str]] = {"{cells}": "SurfaceCells"}
    creates: ClassVar[dict[str, str]] = {"{flowers}": "Polylines"}
    default_iterations: ClassVar[int] = 1
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("stress__spectrum", domain="{cells}", at="cell", intent="in", units="1",
                  doc="tension per layer along 0, pi/4, pi/2, 3pi/4 of the facet frame"),
    )
    example: ClassVar[tuple[dict, ...]] = _EXAMPLE_FLAT[:3] + (
        {"rule": "cracks.stress", "params": {"mode": "uniform", "jitter": 0.3}},
        {"rule": "cracks.flowers", "params": {"every": 3}},)

    def step(self, state: State) -> bool:
        from .sheet import stress_flowers

        cells = state.get(self.cells)
        spec = np.asarray(cells["stress__spectrum"], float)
        if spec.ndim != 3 or spec.shape[2] != 4:
            raise InputError(f"cracks.flowers: stress__spectrum must be (n, L, 4), got {spec.shape}")
        layer = stack_layer(cells, self.layer)
        state.add_domain(self.flowers, stress_flowers(cells, spec[:, layer], every=self.every,
                                                      size=self.size, gap=self.gap))
        return True


RULES: list[Any] = [RenderCracks, CrackMirror, DrawCracks, CrackSheet, StressFlowers]
