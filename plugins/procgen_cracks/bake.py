"""Bake the look of cracked cells per micro-cell, once, as fields the exporters serialise.

Why: the crack family's meshes used to be coloured inside each exporter (OBJ, GLB and preview
each computed the texels and packed their own atlas).  ``cracks.bake`` writes, per micro-cell of
``crack__coverage`` (thesis 5.2.5.a), the base colour (the stack, with the lower layers showing
through the crack and the crack-mirror bands of 5.2.5.b), the glTF metallic and roughness (the
stack's and the lower layers' mixed by the coverage: a crack in a glaze shows the dull body, a
crack in a patina the bare metal) and the relief (a groove of ``groove_depth`` cells at full
coverage, plus the partial-peeling lift of Figure 5.30): ``bake__texels``, ``bake__texel_*``
and ``bake__relief`` (docs/fields.md).  ``surface.bake`` then packs them into one atlas.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from procgen import FieldSpec, InputError, RuleBase, State, param
from procgen_layers.bake import stack_terms
from procgen_layers.light import layer_weights, through_layers
from procgen_layers.stack import load_table
from procgen_surface.relief import relief_shading

THICKNESS = "layers__thickness"
#: the partial-peeling elevation of cracks.peel (thesis 5.3.3, Figure 5.30), drawn as relief
LIFT = "peel__lift"
#: default direction towards the light for the baked lift shading (above, front left)
LIGHT = (-0.4, -0.5, 0.77)
CELLS = "{cells}"


def _check(sc: Any, fmt: str) -> Any:
    from procgen_surface.domain import SurfaceCells
    if not isinstance(sc, SurfaceCells):
        raise InputError(f"{fmt}: expected a SurfaceCells domain, got {sc.kind}")
    if "crack__coverage" not in sc:
        raise InputError(f"{fmt}: the cells have no crack__coverage (run cracks.render first)")
    return sc


def texel_colors(sc: Any, *, layer: int = -1, shadow: float = 0.7, highlight: float = 0.6,
                 light: tuple[float, ...] = LIGHT, lift_relief: float = 1.0,
                 lift_rim: float = 0.5) -> np.ndarray:
    """(n, k, k, 3) albedo of every micro-cell: stack colour, cracks opening on the layers below.

    ``shadow`` / ``highlight``: how much a full crack-mirror band darkens / lightens the layer
    under the cracked one (before the glaze above it filters the change).  Cells lifted by partial
    peeling (``peel__lift``, thesis Figure 5.30) are shaded as a relief (procgen_surface.relief:
    ``light`` towards the light, ``lift_relief`` slope exaggeration, ``lift_rim`` darkest rim),
    since the texture is baked once for every view.
    """
    lv = np.asarray(light, float)
    if lv.shape != (3,) or not np.linalg.norm(lv) > 0 or lift_relief < 0 or not 0.0 <= lift_rim <= 1.0:
        raise InputError(f"crack export: need a non-zero 3-vector light (towards the light), "
                         f"lift_relief >= 0 and lift_rim in [0, 1]; got {light}, {lift_relief}, {lift_rim}")
    lift = np.asarray(sc[LIFT], float) if LIFT in sc else None
    lit = relief_shading(sc, lift, light=lv, slope=lift_relief, rim=lift_rim)
    table = load_table(sc, "crack export")
    t = np.asarray(sc[THICKNESS], float)
    n_layers = t.shape[1]
    if not -n_layers <= layer < n_layers:
        raise InputError(f"crack export: layer {layer} is not a layer of the {n_layers}-layer stack")
    layer %= n_layers
    col = table.array("color")                                   # (L, 3) bottom first
    opac = table.array("opacity")
    lc = np.broadcast_to(col[::-1], t.shape + (3,))              # top first
    full = through_layers(lc, t[:, ::-1], opac[::-1])
    t_under = t.copy()
    t_under[:, layer:] = 0.0
    under = through_layers(lc, t_under[:, ::-1], opac[::-1], empty=col[0] * 0.15)
    cov = np.asarray(sc["crack__coverage"], np.float32)
    k = cov.shape[1]
    rgb = np.broadcast_to(full[:, None, None, :], cov.shape + (3,)).copy()
    if layer > 0 and "crack__shadow" in sc:
        sh = np.asarray(sc["crack__shadow"], np.float32)
        hl = np.asarray(sc["crack__highlight"], np.float32)
        if sh.shape != cov.shape or hl.shape != cov.shape:
            raise InputError(f"crack export: crack__shadow/highlight have {sh.shape[1]} micro-cells "
                             f"per side, crack__coverage {k}: render both with the same k")
        w_low = layer_weights(t[:, ::-1], opac[::-1])[:, n_layers - layer]      # the layer below
        low = col[layer - 1]
        delta = -shadow * sh[..., None] * low + highlight * hl[..., None] * (1.0 - low)
        rgb += w_low[:, None, None, None] * delta
    c = cov[..., None]
    rgb = (1.0 - c) * rgb + c * under[:, None, None, :]
    if lit is not None:
        rgb *= lit[:, None, None, None]
    return np.clip(rgb, 0.0, 1.0)


def crack_maps(sc: Any, *, layer: int = -1, groove_depth: float = 0.5, **texels: Any) -> dict[str, np.ndarray]:
    """The ``bake__*`` arrays of cracked cells (see the module docstring); ``texels`` go to
    :func:`texel_colors`."""
    if not np.isfinite(groove_depth) or groove_depth < 0:
        raise InputError(f"crack bake: groove_depth must be >= 0 (cell sizes), got {groove_depth}")
    rgb = texel_colors(sc, layer=layer, **texels)
    table = load_table(sc, "crack bake")
    t = np.asarray(sc[THICKNESS], float)
    layer %= t.shape[1]
    t_under = t.copy()
    t_under[:, layer:] = 0.0
    full, under = stack_terms(t, table), stack_terms(t_under, table)
    cov = np.asarray(sc["crack__coverage"], np.float32)

    def mix(key: str) -> np.ndarray:
        a, b = full[key].astype(np.float32), under[key].astype(np.float32)
        return (1.0 - cov) * a[:, None, None] + cov * b[:, None, None]

    lift = np.asarray(sc[LIFT], np.float32) if LIFT in sc else np.zeros(sc.n_cells, np.float32)
    relief = lift[:, None, None] - cov * np.float32(groove_depth * float(sc.size))
    return {"bake__texels": rgb.astype(np.float32), "bake__texel_metallic": mix("bake__metallic"),
            "bake__texel_roughness": mix("bake__roughness"), "bake__texel_relief": relief,
            "bake__relief": lift.astype(np.float64)}


BAKED_UNITS = {"bake__texels": "rgb", "bake__texel_metallic": "1", "bake__texel_roughness": "1",
               "bake__texel_relief": "length", "bake__relief": "length"}


@dataclass(kw_only=True)
class CrackBake(RuleBase):
    """Bake cracked cells per micro-cell: colour, metallic, roughness and relief as fields.

    The lower layers show through each micro-cell by its crack coverage; the crack-mirror bands
    change the layer under the cracked one (``shadow`` / ``highlight``); the partial-peeling
    lift is shaded towards ``light`` (``lift_relief`` slope exaggeration, ``lift_rim`` darkest
    rim) and kept as relief; a full crack is a groove ``groove_depth`` cells deep in the height
    and normal maps.  Run ``surface.bake`` after it to pack the maps once for every output.
    """

    name: ClassVar[str] = "cracks.bake"
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "plane", "subdivisions": 2}},
        {"rule": "surface.cells", "params": {"target_cells": 400}},
        {"rule": "layers.stack", "params": {"layers": [
            {"preset": "copper", "thickness": 1.0, "noise": 0.0},
            {"preset": "glaze", "thickness": 0.5, "noise": 0.2}]}},
        {"rule": "cracks.draw", "params": {"lines": [[-0.4, -0.3, 0.01, 0.0, 0.1, 0.03, 0.4, 0.2, 0.01]]}},
        {"rule": "cracks.render", "params": {"k": 4}},
        {"rule": "cracks.bake"})
    uses: ClassVar[dict[str, str]] = {CELLS: "SurfaceCells"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec(THICKNESS, CELLS, "cell", "in", units="length"),
        FieldSpec("crack__coverage", CELLS, "cell", "in", units="1"),
        *(FieldSpec(n, CELLS, "cell", "out", units=u, doc="baked micro-cell appearance")
          for n, u in BAKED_UNITS.items()))
    cells: str = param("cells", doc="SurfaceCells with a layer stack and crack__coverage")
    layer: int = param(-1, ge=-64, le=63, doc="cracked stack layer (negative: from the top)")
    shadow: float = param(0.7, ge=0.0, le=1.0, doc="darkening of a full crack-mirror shadow band")
    highlight: float = param(0.6, ge=0.0, le=1.0, doc="lightening of a full crack-mirror highlight band")
    light: list[float] = param(list(LIGHT), doc="direction towards the light of the baked lift shading")
    lift_relief: float = param(1.0, ge=0.0, doc="slope exaggeration of the lift shading")
    lift_rim: float = param(0.5, ge=0.0, le=1.0, doc="darkest rim beside lifted paint")
    groove_depth: float = param(0.5, ge=0.0, doc="depth of a full crack in the height map, in cell sizes")

    def step(self, state: State) -> bool:
        sc = _check(state.get(self.cells), self.name)
        maps = crack_maps(sc, layer=self.layer, groove_depth=self.groove_depth, shadow=self.shadow,
                          highlight=self.highlight, light=tuple(self.light), lift_relief=self.lift_relief,
                          lift_rim=self.lift_rim)
        for name, arr in maps.items():
            sc.add_field(name, arr, at="cell", units=BAKED_UNITS[name], doc="baked micro-cell appearance")
        return True
