"""Pack the baked appearance of surface cells into texture maps once, for every output format.

Why: a recipe that writes OBJ, GLB and a textured preview of the same cells used to pack (and
round) the same atlas once per format; with 60,000 cells of 11 x 11 micro-cells that was most
of the run (plate 5.10).  ``surface.bake`` packs the base colour (``surface__color`` or the
baked ``bake__color`` / ``bake__texels``), the ORM map (occlusion from the relief's cavities,
``bake__roughness``, ``bake__metallic``) and the height map (``bake__relief`` /
``bake__texel_relief``) into ``atlas__*`` fields; the exporters then only serialise them.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, InputError, RuleBase, State, param
from procgen.exchange.image import to_rgb8

from .domain import SurfaceCells

CELLS = "{cells}"


@dataclass(kw_only=True)
class BakeAtlas(RuleBase):
    """Texture atlas of the cells' baked look (base colour, ORM, height), packed once.

    The mesh exporters (surface_obj / surface_glb, crack_obj / crack_glb / crack_png) use these
    maps whenever they show the default colours; run it after the last rule that changes how
    the cells look (e.g. after ``cracks.bake``).
    """

    name: ClassVar[str] = "surface.bake"
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "icosphere", "subdivisions": 1}},
        {"rule": "surface.cells", "params": {"target_cells": 1500}},
        {"rule": "surface.bake"})
    uses: ClassVar[dict[str, str]] = {CELLS: "SurfaceCells"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("atlas__color", CELLS, "domain", "out", doc="base colour atlas, RGBA uint8"),
        FieldSpec("atlas__orm", CELLS, "domain", "out", doc="occlusion, roughness, metallic atlas"),
        FieldSpec("atlas__height", CELLS, "domain", "out", units="length", doc="height atlas"),
        FieldSpec("atlas__normal", CELLS, "domain", "out", doc="tangent-space normal atlas"),
        FieldSpec("atlas__origin", CELLS, "face", "out", doc="texel of each face's first cell"),
        FieldSpec("atlas__texels", CELLS, "domain", "out", doc="texels per cell side"),)
    cells: str = param("cells", doc="SurfaceCells to pack")
    texels: int = param(2, ge=1, le=16, doc="texels per cell side (cells without micro-cell texels)")

    def step(self, state: State) -> bool:
        from .exporters import DEFAULT, _colors, bake_atlas

        sc = state.get(self.cells, SurfaceCells)
        if sc.n_cells == 0:
            raise InputError(f"{self.name}: the cells {self.cells!r} are empty")
        atlas = bake_atlas(sc, _colors(sc, DEFAULT), texels=self.texels, pbr=True)
        height = atlas.height if atlas.height is not None else np.zeros(atlas.image.shape[:2], np.float32)
        normal = atlas.normal_map() if atlas.height is not None else np.broadcast_to(
            np.array([0.0, 0.0, 1.0], np.float32), height.shape + (3,))
        sc.add_field("atlas__color", to_rgb8(atlas.image), at="domain", doc="base colour atlas (RGBA)")
        sc.add_field("atlas__orm", to_rgb8(atlas.orm), at="domain", doc="occlusion, roughness, metallic")
        sc.add_field("atlas__height", height.astype(np.float32), at="domain", units="length",
                     doc="relief height atlas (all 0: no relief)")
        sc.add_field("atlas__normal", to_rgb8(0.5 * (normal + 1.0)), at="domain",
                     doc="tangent-space normal map (OpenGL), uint8")
        sc.add_field("atlas__origin", atlas.origin, at="face", doc="atlas texel of each face's cell (0, 0)")
        sc.add_field("atlas__texels", np.int64(atlas.texels), at="domain", doc="texels per cell side")
        return True
