"""procgen rules of the wood-weathering family (thesis: Chidtavong 2007, KMITL).

wood.grain (texture image), wood.map (texture onto surface cells), wood.age_colour (cell value
-> palette colour, composed with the grain), wood.exposure (sun and rain, not in the thesis),
wood.table (the table stand-in mesh).  The Life-like automaton itself is the core's generic CA.
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, Grid, InputError, MissingExtra, RuleBase, State, TriMesh, param
from procgen.ca.cells import CELL_DOMAIN, cell_values, put_cell_values
from procgen_surface.domain import SurfaceCells

from . import exposure as ex
from .compose import BLENDS, compose
from .grain import HASH_VARIANTS, INTERPOLATIONS, PATTERNS, RINGS, wood_texture
from .palette import FIRST_GREY, THRESHOLDS, check_palette, default_colors, palette_colors, palette_index
from .table import table
from .texgen import MODES, texture_coordinates, sample_bilinear

_ICO = {"rule": "mesh.primitive", "params": {"shape": "icosphere", "subdivisions": 1}}
_CELLS = {"rule": "surface.cells", "params": {"target_cells": 1500}}


@dataclass(kw_only=True)
class WoodGrain(RuleBase):
    """Generator: the procedural wood texture of thesis Fig. 3.10 as a Grid image (wood__color).

    Value noise (Fig. 3.1, corrected hash), 3x3 smoothing (Fig. 3.3), turbulence (Fig. 3.9) and
    the ring function |sin(2 pi xyPeriod (f(x, y) + turbPower T / 256))| with the f of Figs
    3.4-3.8; colour (190, 120, 70) + (15, 15, 10) |sin|, bytes truncated as printed.  The printed
    turbPower (1-2) dissolves the rings into figured grain; 0.2 gives clean wavy rings.
    """

    example: ClassVar[tuple[dict, ...]] = ({"rule": "wood.grain", "params": {"width": 48, "height": 32, "turb_size": 16}},)
    name: ClassVar[str] = "wood.grain"
    creates: ClassVar[dict[str, str]] = {"{texture}": "Grid"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("wood__color", domain="{texture}", at="cell", intent="out", units="rgb",
                  doc="wood grain colour in [0, 1] (sRGB bytes / 255)"),)
    texture: str = param("wood_texture", doc="name of the Grid image to create")
    width: int = param(256, ge=8, le=8192, units="texels", doc="texture width (thesis: not given)")
    height: int = param(256, ge=8, le=8192, units="texels", doc="texture height")
    ring: str = param("half_ellipse", choices=tuple(RINGS), doc="base function f(x, y) (Figs 3.4-3.8, 4.12-4.14)")
    xy_period: float = param(20.0, gt=0.0, le=1000.0, doc="xyPeriod: rings per unit of f")
    turb_power: float = param(0.2, ge=0.0, le=100.0, doc="turbPower (thesis code: 2; Fig. 3.11: 1 and 2)")
    turb_size: int = param(128, ge=1, le=4096, units="texels", doc="turbSize: largest noise octave")
    interp: str = param("bilinear", choices=INTERPOLATIONS,
                        doc="noise between lattice points: truncate (as printed: block seams), bilinear, cosine")
    hash: str = param("elias", choices=HASH_VARIANTS, doc="noise hash: corrected constants, or as printed")
    pattern: str = param("rings", choices=PATTERNS,
                         doc="rings (the wood), or a building block through the same colours (Fig. 3.2: noise)")
    base_rgb: list[float] = param([190.0, 120.0, 70.0], doc="colour bytes where |sin| = 0")
    amp_rgb: list[float] = param([15.0, 15.0, 10.0], doc="colour bytes added at |sin| = 1")

    def validate(self) -> None:
        for key in ("base_rgb", "amp_rgb"):
            c = getattr(self, key)
            if len(c) != 3 or min(c) < 0 or max(c) > 255:
                raise ValueError(f"{key} must be three bytes in 0..255")

    def memory_estimate(self) -> int:
        return 200 * self.width * self.height

    def step(self, state: State) -> bool:
        img = wood_texture(self.width, self.height, ring=self.ring, xy_period=self.xy_period,
                           turb_power=self.turb_power, turb_size=self.turb_size, interp=self.interp,
                           variant=self.hash, pattern=self.pattern, base_rgb=tuple(self.base_rgb),
                           amp_rgb=tuple(self.amp_rgb))
        g = Grid((self.height, self.width), spacing=1.0 / self.width)
        g.add_field("wood__color", img / 255.0, at="cell", doc="wood grain colour (bytes / 255)")
        state.add_domain(self.texture, g)
        return True


@dataclass(kw_only=True)
class WoodMap(RuleBase):
    """The wood texture onto surface cells by OpenGL-style texgen (thesis 4.3.4, Figs 4.12-4.14).

    object_linear: s = plane_s . (x, y, z, 1) x scale, t from plane_t (default: the next axis);
    sphere_map: s, t = n_x / 2 + 1/2, n_y / 2 + 1/2 (fixed view along -z).  Repeat wrapping,
    bilinear filtering; writes the grain colour per cell.
    """

    example: ClassVar[tuple[dict, ...]] = (_ICO, _CELLS, {"rule": "wood.grain", "params": {"width": 32, "height": 32, "turb_size": 16}},
                                           {"rule": "wood.map"})
    name: ClassVar[str] = "wood.map"
    uses: ClassVar[dict[str, str]] = {"{cells}": "SurfaceCells", "{texture}": "Grid"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("wood__color", domain="{texture}", at="cell", intent="in", units="rgb", doc="texture image"),
        FieldSpec("wood__color", domain="{cells}", at="cell", intent="out", units="rgb",
                  doc="wood grain colour in [0, 1] per cell"),)
    cells: str = param("cells", doc="SurfaceCells domain")
    texture: str = param("wood_texture", doc="Grid image made by wood.grain")
    mode: str = param("object_linear", choices=MODES, doc="GL_OBJECT_LINEAR planes or GL_SPHERE_MAP")
    plane_s: list[float] = param([1.0, 0.0, 0.0, 0.0], doc="s plane (p1, p2, p3, p4) (object_linear)")
    plane_t: list[float] | None = param(None, doc="t plane (default: plane_s's axis moved x -> y -> z -> x)")
    scale: float = param(1.0, gt=0.0, units="1/length", doc="texture repeats per unit length (object_linear)")

    def validate(self) -> None:
        for key in ("plane_s", "plane_t"):
            p = getattr(self, key)
            if p is not None and len(p) != 4:
                raise ValueError(f"{key} must be four numbers (p1, p2, p3, p4)")

    def step(self, state: State) -> bool:
        sc = state.get(self.cells, SurfaceCells)
        img = np.asarray(state.get(self.texture, Grid)["wood__color"], float)
        st = texture_coordinates(sc.center3d, sc.normal, mode=self.mode, plane_s=self.plane_s,
                                 plane_t=self.plane_t, scale=self.scale)
        sc.add_field("wood__color", np.clip(sample_bilinear(img, st), 0, 1), at="cell",
                     doc=f"wood grain ({self.mode})")
        return True


@dataclass(kw_only=True)
class AgeColour(RuleBase):
    """Cell value -> colour by range (thesis 4.3.3), composed with the wood grain (Fig. 4.15).

    Reads the CA's per-cell step counter (``age_field``), optionally weighted by exposure
    (a + b E_sun + c E_rain: the value grows by that much per step alive, exactly the count
    times the rate since exposure is constant), picks the palette colour of its range
    (weathering__color; the palette is ours, see palette.py) and writes surface__color by
    ``blend``: modulate (the thesis), lerp (reaches grey), ca_only or texture_only.
    With ``rain_gate`` > 0, cells whose rain exposure is below it never pass the last brown
    range: greying needs wetting, so sheltered sunny wood stays brown.
    """

    example: ClassVar[tuple[dict, ...]] = (
        _ICO, _CELLS, {"rule": "ca.life", "iterations": 20,
                       "params": {"rule": "25/2356", "semantics": "table", "density": 0.05}},
        {"rule": "wood.age_colour", "params": {"blend": "ca_only"}})
    name: ClassVar[str] = "wood.age_colour"
    uses: ClassVar[dict[str, str]] = {"{cells}": CELL_DOMAIN}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("{age_field}", domain="{cells}", at="cell", intent="in", units="steps",
                  doc="the CA's step counter per cell"),
        FieldSpec("weathering__age", domain="{cells}", at="cell", intent="out", units="steps",
                  doc="weathering value: steps alive x exposure rate (= the count without exposure)"),
        FieldSpec("weathering__color", domain="{cells}", at="cell", intent="out", units="rgb",
                  doc="palette colour of the value's range, in [0, 1]"),
        FieldSpec("surface__color", domain="{cells}", at="cell", intent="out", units="rgb",
                  doc="final colour in [0, 1]"),)
    cells: str = param("cells", doc="cell domain (surface cells or a Grid)")
    age_field: str = param("ca__age", doc="integer cell field counting steps (ca.life's age)")
    thresholds: list[float] = param(list(THRESHOLDS), units="steps", doc="first value of each range (rising from 0)")
    colors: list[list[float]] = param(default_colors(), doc="sRGB bytes of each range (default: our L*a*b* palette)")
    interpolate: bool = param(False, doc="blend linearly between range starts instead of steps")
    blend: str = param("modulate", choices=BLENDS,
                       doc="grain x CA colour: modulate (thesis GL_MODULATE), lerp, ca_only, texture_only")
    v_full: float = param(200.0, gt=0.0, units="steps", doc="lerp: value at which the palette colour fully replaces the grain")
    exposure: bool = param(False, doc="weight ageing by exposure__sun / exposure__rain (not in the thesis)")
    age_base: float = param(0.25, ge=0.0, doc="ageing rate with no exposure")
    age_sun: float = param(1.5, ge=0.0, doc="extra ageing rate per unit of sun exposure")
    age_rain: float = param(1.0, ge=0.0, doc="extra ageing rate per unit of rain exposure")
    rain_gate: float = param(0.0, ge=0.0, le=1.0,
                             doc="cells with rain exposure below this never grey (0: off)")
    first_grey: int = param(FIRST_GREY, ge=1, doc="index of the first range that needs wetting (rain_gate)")

    def validate(self) -> None:
        try:
            check_palette(self.thresholds, self.colors, f"{self.name}")
        except InputError as exc:
            raise ValueError(str(exc)) from None
        if self.first_grey >= len(self.thresholds):
            raise ValueError(f"first_grey must be below the number of ranges ({len(self.thresholds)})")

    def field_specs(self) -> list[FieldSpec]:
        specs = super().field_specs()
        extra = []
        if self.blend not in ("ca_only",):
            extra.append(FieldSpec("wood__color", domain=self.cells, at="cell", intent="in", units="rgb",
                                   doc="wood grain per cell (wood.map)"))
        if self.exposure or self.rain_gate > 0:
            extra += [FieldSpec(f"exposure__{k}", domain=self.cells, at="cell", intent="in",
                                doc=f"{k} exposure (wood.exposure)") for k in ("sun", "rain")]
        return specs + extra

    def step(self, state: State) -> bool:
        dom = state.get(self.cells, CELL_DOMAIN)
        for spec in self.field_specs():
            if spec.intent == "in" and spec.name not in dom:
                raise InputError(f"{self.name}: {self.cells!r} has no field {spec.name!r} ({spec.doc})")
        age = np.asarray(cell_values(dom, self.age_field), float)
        cap = None
        if self.exposure:
            rate = (self.age_base + self.age_sun * cell_values(dom, "exposure__sun")
                    + self.age_rain * cell_values(dom, "exposure__rain"))
            age = age * rate
        if self.rain_gate > 0:
            dry = np.asarray(cell_values(dom, "exposure__rain")) < self.rain_gate
            cap = np.where(dry, self.first_grey - 1, len(self.thresholds) - 1)
        ca = palette_colors(age, self.thresholds, self.colors, interpolate=self.interpolate, cap=cap)
        wood = None if self.blend == "ca_only" else np.asarray(cell_values(dom, "wood__color"), float)
        fresh = np.asarray(self.colors[0], float) / 255.0
        out = compose(wood, ca, age, blend=self.blend, fresh=fresh, v_full=self.v_full)
        put_cell_values(dom, "weathering__age", age, units="steps", doc="steps alive x exposure rate")
        put_cell_values(dom, "weathering__color", ca, doc="palette colour of the value's range")
        put_cell_values(dom, "surface__color", out, units="rgb", doc=f"wood weathering colour ({self.blend})")
        k = palette_index(age, self.thresholds) if cap is None else \
            np.minimum(palette_index(age, self.thresholds), cap)
        share = np.bincount(k, minlength=len(self.thresholds)) / max(len(k), 1)
        state.report(f"{self.cells}.weathering.range_share", [round(float(x), 6) for x in share])
        state.report(f"{self.cells}.weathering.mean_value", float(age.mean()) if len(age) else 0.0)
        return True


@dataclass(kw_only=True)
class Exposure(RuleBase):
    """Sun and rain exposure per surface cell (not in the thesis: it models no weather).

    E = mean over directions d of max(0, n . d) x visibility along d, visibility by ray casts
    against the mesh (trimesh; Embree via the ``embree`` extra).  Sun: an equinox day's path at
    ``latitude``; rain: a cone of half-angle ``rain_spread`` about ``up``.  Feeds
    wood.age_colour's ``exposure`` and ``rain_gate``, and ca.life's ``birth_field`` through
    ``exposure__birth`` (see :func:`procgen_wood.exposure.birth_probability`).
    """

    example: ClassVar[tuple[dict, ...]] = (_ICO, _CELLS, {"rule": "wood.exposure", "params": {"sun_count": 4, "rain_count": 4}})
    name: ClassVar[str] = "wood.exposure"
    uses: ClassVar[dict[str, str]] = {"{cells}": "SurfaceCells"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("exposure__sun", domain="{cells}", at="cell", intent="out",
                  doc="mean max(0, n.d) x visibility over the sun's path, in [0, 1]"),
        FieldSpec("exposure__rain", domain="{cells}", at="cell", intent="out",
                  doc="mean max(0, n.d) x visibility over the rain cone, in [0, 1]"),
        FieldSpec("exposure__birth", domain="{cells}", at="cell", intent="out", units="1",
                  doc="birth probability from sun and rain exposure, in [birth_floor, 1]"),)
    cells: str = param("cells", doc="SurfaceCells domain")
    up: list[float] = param([0.0, 0.0, 1.0], doc="the sky direction")
    south: list[float] = param([0.0, -1.0, 0.0], doc="the equator direction (the sun's noon side)")
    latitude: float = param(45.0, ge=-89.0, le=89.0, units="deg", doc="latitude of the sun path (equinox day)")
    sun_count: int = param(12, ge=1, le=1000, doc="sun directions over the day")
    rain_spread: float = param(25.0, ge=0.0, le=90.0, units="deg", doc="half-angle of the rain cone about up")
    rain_count: int = param(16, ge=1, le=1000, doc="rain directions")
    occlusion: str = param("rays", choices=("rays", "none"), doc="ray-cast visibility, or none (n.d only)")
    offset: float = param(1e-4, gt=0.0, units="length", doc="ray start offset along the normal")
    birth_floor: float = param(0.2, ge=0.0, le=1.0,
                               doc="exposure__birth of a cell no sun or rain reaches (the most exposed get 1)")

    def validate(self) -> None:
        try:
            ex.sun_directions(1, self.latitude, np.asarray(self.up), np.asarray(self.south))
        except InputError as exc:
            raise ValueError(str(exc)) from None
        if self.occlusion == "rays" and ex.ray_engine() is None:
            raise MissingExtra(ex.NO_ENGINE, "embree")

    def step(self, state: State) -> bool:
        sc = state.get(self.cells, SurfaceCells)
        rays = ex.intersector(sc.vertices, sc.faces) if self.occlusion == "rays" else None
        up, south = np.asarray(self.up, float), np.asarray(self.south, float)
        sun = ex.exposure(sc.center3d, sc.normal, ex.sun_directions(self.sun_count, self.latitude, up, south),
                          rays=rays, offset=self.offset)
        rain = ex.exposure(sc.center3d, sc.normal, ex.cone_directions(self.rain_count, self.rain_spread, up),
                           rays=rays, offset=self.offset)
        sc.add_field("exposure__sun", sun, at="cell", doc="sun exposure")
        sc.add_field("exposure__rain", rain, at="cell", doc="rain exposure")
        birth = ex.birth_probability(sun, rain, self.birth_floor)
        sc.add_field("exposure__birth", birth, at="cell", units="1", doc="birth probability from exposure")
        state.report(f"{self.cells}.exposure.birth_mean", float(birth.mean()))
        state.report(f"{self.cells}.exposure.sun_mean", float(sun.mean()))
        state.report(f"{self.cells}.exposure.rain_mean", float(rain.mean()))
        state.report(f"{self.cells}.exposure.rain_sheltered_fraction", float(np.mean(rain == 0)))
        return True


@dataclass(kw_only=True)
class WoodTable(RuleBase):
    """Generator: a table of boxes and cylinders (top, four legs, four aprons; z up).

    Stand-in for the thesis's 3ds Max table (Figs 3.14-3.17): separate closed primitives whose
    triangles all have about the same edge length, as the thesis's Fig. 3.17 asks.
    """

    name: ClassVar[str] = "wood.table"
    creates: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    mesh: str = param("mesh", doc="name of the TriMesh to create")
    length: float = param(1.2, gt=0.0, units="length", doc="top length (x)")
    width: float = param(0.8, gt=0.0, units="length", doc="top width (y)")
    height: float = param(0.75, gt=0.0, units="length", doc="height to the top surface (z)")
    top: float = param(0.05, gt=0.0, units="length", doc="top thickness")
    leg_radius: float = param(0.035, gt=0.0, units="length", doc="leg radius")
    apron: float = param(0.1, gt=0.0, units="length", doc="apron height under the top")
    edge: float = param(0.04, gt=0.0, units="length", doc="target triangle edge length")

    def validate(self) -> None:
        if self.top + self.apron >= self.height:
            raise ValueError("top + apron must be less than height")
        if 5 * self.leg_radius >= min(self.length, self.width):
            raise ValueError("leg_radius too large for the top")
        if max(self.length, self.width, self.height) / self.edge > 2000:
            raise ValueError("edge too small for the table (over 2000 segments per side)")

    def step(self, state: State) -> bool:
        v, f = table(self.length, self.width, self.height, self.top, self.leg_radius, self.apron, self.edge)
        state.add_domain(self.mesh, TriMesh(v, f))
        state.report(f"{self.mesh}.n_faces", len(f))
        return True

