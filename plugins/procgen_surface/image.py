"""Images onto surface cells through the mesh's own UVs: a texture as a field on every cell.

Why: a user's textured model (an OBJ with ``vt`` lines) carries a painted map in its UV space
(dirt, a weak zone, a rain mask); the cell automata need it per cell. Each cell's centre is
located in its triangle by barycentric weights (a PART-IN cell's centre may lie just outside:
the weights are clamped to the triangle), the triangle's corner UVs are interpolated with them,
and the image is read there bilinearly (the core's ``sample_bilinear``, the same lookup as
``mesh.image_field``). Corner UVs come per face from ``mesh.load`` (``mesh__uv``) and reach the
cells through ``surface.cells``, which carries face fields; a seam therefore never mixes the
UVs of its two sides.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, InputError, State, param
from procgen.builtin.loaders import ImageFieldParams, sample_bilinear
from procgen.geometry import barycentric

from .domain import SurfaceCells


def cell_uv(sc: SurfaceCells, uv: np.ndarray) -> np.ndarray:
    """(n_cells, 2) UV at each cell centre from corner UVs (m, 3, 2) or cell UVs (n, 2).

    Barycentric weights of the centre in its triangle's 2-D frame, clamped to the triangle and
    renormalised, so an edge cell takes the UV of the nearest point of its own face.
    """
    uv = np.asarray(uv, dtype=np.float64)
    if uv.shape == (sc.n_cells, 2):
        return uv
    if uv.shape != (sc.n_faces, 3, 2):
        raise InputError(f"UV field of shape {uv.shape}: need face corners ({sc.n_faces}, 3, 2) "
                         f"or cells ({sc.n_cells}, 2)")
    fc = sc.face
    w = np.clip(barycentric(sc.corners2d[fc], sc.center2d), 0.0, None)
    w /= np.maximum(w.sum(axis=1, keepdims=True), 1e-300)
    return np.einsum("nk,nkd->nd", w, uv[fc])


@dataclass(kw_only=True)
class SurfaceImageField(ImageFieldParams):
    """An image as a cell field of SurfaceCells, sampled through the mesh's UVs at each cell centre.

    The UVs are the face corners ``mesh__uv`` that ``mesh.load`` reads from an OBJ (carried to
    the cells by ``surface.cells``), or any (cells, 2) UV field; v = 1 is the image's top row,
    UVs repeat. Black maps to ``vmin``, white to ``vmax`` (luma for ``channels = 'grey'``).
    """

    name: ClassVar[str] = "surface.image_field"
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.load", "params": {"path": "spot.obj"}},
        {"rule": "surface.cells", "params": {"target_cells": 3000}},
        {"rule": "surface.image_field", "params": {"file": "data/weak-map.png"}})
    uses: ClassVar[dict[str, str]] = {"{cells}": "SurfaceCells"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("{field}", "{cells}", "cell", "out", doc="image values"),)

    cells: str = param("cells", doc="SurfaceCells to paint")
    uv_field: str = param("mesh__uv", doc="face-corner UVs (mesh.load's mesh__uv) or a (cells, 2) UV field")

    def step(self, state: State) -> bool:
        sc = state.get(self.cells, SurfaceCells)
        if self.uv_field not in sc:
            raise InputError(f"surface.image_field: cells {self.cells!r} have no UV field {self.uv_field!r} "
                             "(the mesh file has no texture coordinates?)")
        uv = cell_uv(sc, sc[self.uv_field])
        v, _, name = self.image(state)
        sc.add_field(self.field, sample_bilinear(v, uv), at="cell", units=self.units, doc=f"from {name}")
        return True
