"""Objects and materials from the connected parts of any mesh (Figure 1: one material per glyph).

``cellnet.polygons`` gives every polygon its object and material by hand.  A solid built another
way (an SVG logo extruded by ``mesh.extrude``, a loaded OBJ of several pieces) carries no such
ids, yet section 3.3 seeds "several objects at once" and Figure 1 runs a different effect on
each part of one logo.  This converter finds the parts (faces joined through shared vertices),
numbers them in reading order - rows from the top down, left to right in a row - and writes
``face__object`` and ``face__material``, which ``cellnet.seed`` hands on to its cells.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from procgen import FieldSpec, InputError, RuleBase, State, TriMesh, param

ORDERS = ("reading", "x", "y", "z")

#: view colours of parts 0, 1, ... (cycled): a qualitative palette, neighbours well apart
PART_COLORS = np.array([[0.12, 0.47, 0.71], [1.0, 0.5, 0.05], [0.17, 0.63, 0.17], [0.84, 0.15, 0.16],
                        [0.58, 0.4, 0.74], [0.55, 0.34, 0.29], [0.89, 0.47, 0.76], [0.74, 0.74, 0.13],
                        [0.09, 0.75, 0.81], [0.5, 0.5, 0.5]])


def face_parts(faces: np.ndarray, n_vertices: int) -> tuple[np.ndarray, int]:
    """Part index of every face (faces sharing a vertex are one part) and the number of parts."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components

    f = np.asarray(faces, np.int64)
    rows = np.concatenate([f[:, 0], f[:, 1]])
    cols = np.concatenate([f[:, 1], f[:, 2]])
    graph = coo_matrix((np.ones(len(rows), np.int8), (rows, cols)), shape=(n_vertices, n_vertices))
    _, comp = connected_components(graph, directed=False)
    used, part = np.unique(comp[f[:, 0]], return_inverse=True)
    return part.astype(np.int64), len(used)


def reading_order(lo: np.ndarray, hi: np.ndarray, centre: np.ndarray) -> np.ndarray:
    """Ranks of parts read as text: rows from the top (largest y) down, left to right in a row.

    ``lo``/``hi``/``centre`` are the parts' (k, 3) bounding boxes and centroids.  A part joins
    the current row when its y extent overlaps the row's by at least half of the shorter of the
    two, so letters of one line (an A lower than a G's overshoot) stay together.  The loop runs
    over parts (a handful), never over cells.
    """
    by_top = np.argsort(-hi[:, 1], kind="stable")
    rows: list[list[int]] = []
    row_lo = row_hi = 0.0
    for p in by_top:
        overlap = min(row_hi, hi[p, 1]) - max(row_lo, lo[p, 1])
        shorter = min(row_hi - row_lo, hi[p, 1] - lo[p, 1])
        if rows and overlap >= 0.5 * shorter:
            rows[-1].append(int(p))
            row_lo, row_hi = min(row_lo, lo[p, 1]), max(row_hi, hi[p, 1])
        else:
            rows.append([int(p)])
            row_lo, row_hi = lo[p, 1], hi[p, 1]
    ordered = [p for row in rows for p in sorted(row, key=lambda q: centre[q, 0])]
    rank = np.empty(len(ordered), np.int64)
    rank[ordered] = np.arange(len(ordered))
    return rank


@dataclass(kw_only=True)
class MeshParts(RuleBase):
    """Converter: every connected part of a TriMesh becomes an object with its own material.

    Parts are numbered 0, 1, ... in ``order`` (``reading``: rows from the top down, left to
    right, as the glyphs of a logo are read; or by centroid along x, y or z).  Part k gets
    ``materials[k]`` (default k + 1).  Writes ``face__object``, ``face__material`` and
    ``vertex__color`` (one colour per part, for a picture of them); ``cellnet.seed`` passes the first two on to
    its cells, so ``materials`` selections and ``cellnet.parallel`` behaviours act per part.
    """

    name: ClassVar[str] = "cellnet.parts"
    uses: ClassVar[dict[str, str]] = {"{mesh}": "TriMesh"}
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("face__object", domain="{mesh}", at="face", intent="out", doc="part (object) index"),
        FieldSpec("face__material", domain="{mesh}", at="face", intent="out", doc="material id"),
        FieldSpec("vertex__color", domain="{mesh}", at="vertex", intent="out", doc="one colour per part"),
    )
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "cube"}},
        {"rule": "cellnet.parts"},
    )

    mesh: str = param("mesh", doc="TriMesh whose parts become objects")
    order: str = param("reading", choices=ORDERS, doc="how parts are numbered: text reading order "
                       "(rows top down, left to right) or by centroid along an axis")
    materials: list[int] | None = param(None, doc="material id of each part in that order "
                                        "(default: part k gets k + 1); one per part")

    def validate(self) -> None:
        bad = [m for m in (self.materials or ()) if not 0 <= m <= 32767]
        if bad:     # face__material is int16
            raise ValueError(f"materials: {bad[0]} is outside 0..32767, the ids a face material takes")

    def step(self, state: State) -> bool:
        mesh = state.get(self.mesh, TriMesh)
        if mesh.vertices.shape[1] != 3:
            raise InputError(f"{self.name}: mesh {self.mesh!r} is 2-D; give a 3-D mesh")
        part, k = face_parts(mesh.faces, mesh.n_vertices)
        v = np.asarray(mesh.vertices, np.float64)
        corners = v[mesh.faces].reshape(-1, 3)
        owner = np.repeat(part, 3)
        lo = np.full((k, 3), np.inf)
        hi = np.full((k, 3), -np.inf)
        np.minimum.at(lo, owner, corners)
        np.maximum.at(hi, owner, corners)
        area = mesh.face_areas
        weight = np.bincount(part, weights=area, minlength=k)
        centre = np.stack([np.bincount(part, weights=area * v[mesh.faces].mean(axis=1)[:, a], minlength=k)
                           for a in range(3)], axis=1) / np.maximum(weight, 1e-300)[:, None]
        if self.order == "reading":
            rank = reading_order(lo, hi, centre)
        else:
            axis = "xyz".index(self.order)
            rank = np.empty(k, np.int64)
            rank[np.argsort(centre[:, axis], kind="stable")] = np.arange(k)
        if self.materials is not None and len(self.materials) != k:
            raise InputError(f"{self.name}: mesh {self.mesh!r} has {k} parts but {len(self.materials)} "
                             "materials were given (one per part, in "
                             f"{'reading' if self.order == 'reading' else self.order} order)")
        mats = np.asarray(self.materials if self.materials is not None else np.arange(1, k + 1), np.int64)
        obj = rank[part]
        mesh.add_field("face__object", obj.astype(np.int32), at="face", doc="part (object) index")
        mesh.add_field("face__material", mats[obj].astype(np.int16), at="face", doc="material id")
        rgb = np.full((mesh.n_vertices, 3), 0.8)
        rgb[mesh.faces.reshape(-1)] = PART_COLORS[np.repeat(obj, 3) % len(PART_COLORS)]
        mesh.add_field("vertex__color", rgb, at="vertex", doc="one colour per part")
        state.report(f"{self.mesh}.n_parts", k)
        state.report(f"{self.mesh}.n_faces", mesh.n_faces)
        return True
