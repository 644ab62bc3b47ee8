"""SurfaceCells: the 3DSCA cells of a triangle mesh as a procgen domain.

The core's four domain kinds have no place for per-triangle grids and a cross-edge neighbour
graph, so this plugin registers a fifth kind.  Fields live on ``cell`` (n,) or on the source
mesh's ``face`` (m,).  Topology (read-only) keeps everything a later CA family needs: the source
mesh, each triangle's 2-D frame and grid, each cell's face/column/row/flag/area/centre/normal,
and the CSR neighbour graph with Moore direction codes (see :mod:`.stepping`).
"""
from __future__ import annotations

from functools import cached_property
from typing import Any, ClassVar

import numpy as np

from procgen import geometry as geo
from procgen.domains import Domain, frozen, register_domain_kind
from procgen.errors import InputError

from .geometry import CellLayout, FaceFrames, build_cells, choose_cell_size
from .neighbours import build_neighbours, orientation_errors
from procgen.ca.graph import CellGraph

_TOPOLOGY = ("vertices", "faces", "origin", "ex", "ey", "corners2d", "valid", "nx", "ny",
             "grid_offset", "lookup", "face", "ij", "comp_in", "area", "center2d", "center3d",
             "normal", "indptr", "indices", "direction", "cross")


@register_domain_kind
class SurfaceCells(Domain):
    """Square cells of one size on every triangle of a mesh, with a cross-edge neighbour graph."""

    kind: ClassVar[str] = "SurfaceCells"
    locations: ClassVar[tuple[str, ...]] = ("cell", "face")

    def __init__(self, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> None:
        super().__init__()
        missing = [k for k in _TOPOLOGY if k not in arrays]
        if missing:
            raise InputError(f"SurfaceCells: missing topology arrays {missing}")
        for k in _TOPOLOGY:
            setattr(self, k, frozen(arrays[k]))
        self.size = float(meta["size"])
        self.frame = str(meta.get("frame", "thesis"))
        self.neighbours = str(meta.get("neighbours", "unfold"))
        self.n_degenerate = int(meta.get("n_degenerate", 0))

    # -- construction ---------------------------------------------------------------------
    @classmethod
    def from_mesh(cls, vertices: np.ndarray, faces: np.ndarray, *, cell_size: float | None = None,
                  target_cells: int | None = None, k: float | None = None, frame: str = "thesis",
                  neighbours: str = "unfold", max_cells: int = 20_000_000,
                  vertex_normals: np.ndarray | None = None) -> "SurfaceCells":
        v = np.asarray(vertices, dtype=float)
        f = np.asarray(faces, dtype=np.int64)
        if v.ndim != 2 or v.shape[1] != 3:
            raise InputError(f"SurfaceCells: need 3-D vertices (n, 3), got {v.shape}")
        if f.ndim != 2 or f.shape[1] != 3 or len(f) == 0:
            raise InputError(f"SurfaceCells: mesh has no faces (shape {f.shape})")
        if not np.all(np.isfinite(v)):
            raise InputError("SurfaceCells: mesh vertices contain NaN or inf")
        s = choose_cell_size(v, f, cell_size=cell_size, target_cells=target_cells, k=k)
        layout = build_cells(v, f, s, frame=frame, max_cells=max_cells)
        if layout.n_cells == 0:
            raise InputError("SurfaceCells: no cell overlaps any triangle")
        graph, _ = build_neighbours(layout, v, f, neighbours)
        vn = geo.vertex_normals(v, f) if vertex_normals is None else vertex_normals
        normal = _interpolated_normals(layout, v, f, vn)
        arrays = {"vertices": v, "faces": f, "origin": layout.frames.origin, "ex": layout.frames.ex,
                  "ey": layout.frames.ey, "corners2d": layout.frames.corners2d,
                  "valid": layout.frames.valid, "nx": layout.nx, "ny": layout.ny,
                  "grid_offset": layout.grid_offset, "lookup": layout.lookup, "face": layout.face,
                  "ij": layout.ij, "comp_in": layout.comp_in, "area": layout.area,
                  "center2d": layout.center2d, "center3d": layout.center3d, "normal": normal,
                  "indptr": graph.indptr, "indices": graph.indices, "direction": graph.direction,
                  "cross": graph.cross}
        meta = {"size": s, "frame": frame, "neighbours": neighbours,
                "n_degenerate": int((~layout.frames.valid).sum())}
        return cls(arrays, meta)

    # -- sizes and views ------------------------------------------------------------------
    @property
    def n_cells(self) -> int:
        return len(self.face)

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    def location_shape(self, at: str) -> tuple[int, ...]:
        return (self.n_cells,) if at == "cell" else (self.n_faces,)

    @cached_property
    def graph(self) -> CellGraph:
        return CellGraph(self.indptr, self.indices, self.direction, self.cross)

    def cell_graph(self, neighbourhood: str = "moore") -> CellGraph:
        """The cross-edge cell graph (the cell-domain protocol of :mod:`procgen.ca.cells`)."""
        return self.graph.neighbourhood(neighbourhood)

    def cell_centres(self) -> np.ndarray:
        """(n, 3) cell centres, for the cell-domain protocol (seed points, nearest cells)."""
        return self.center3d

    @cached_property
    def layout(self) -> CellLayout:
        frames = FaceFrames(self.origin, self.ex, self.ey, self.corners2d, self.valid)
        return CellLayout(self.size, frames, self.nx, self.ny, self.grid_offset, self.lookup,
                          self.face, self.ij, self.comp_in, self.area, self.center2d, self.center3d)

    def edge_errors(self) -> np.ndarray:
        """Thesis 3.3.3 orientation error 1 - cos(alpha) of every shared edge."""
        from .neighbours import edge_topology
        topo = edge_topology(self.faces, self.valid)
        return orientation_errors(self.layout, self.faces, topo)

    def surface_distances(self, cell: int) -> np.ndarray:
        """(n,) distance over the surface from cell ``cell`` to every cell (NaN beyond the
        seed triangle's edge neighbours; see :func:`.neighbours.unfolded_distances`)."""
        from .neighbours import edge_topology, unfolded_distances
        return unfolded_distances(self.layout, self.faces, edge_topology(self.faces, self.valid), cell)

    def alive(self) -> np.ndarray:
        """Cells that still exist (``cell__alive`` if a rule cut holes, else all)."""
        return np.asarray(self["cell__alive"], bool) if "cell__alive" in self else \
            np.ones(self.n_cells, bool)

    # -- persistence ----------------------------------------------------------------------
    def topology_arrays(self) -> dict[str, np.ndarray]:
        return {k: getattr(self, k) for k in _TOPOLOGY}

    def topology_meta(self) -> dict[str, Any]:
        return {"size": self.size, "frame": self.frame, "neighbours": self.neighbours,
                "n_degenerate": self.n_degenerate}

    @classmethod
    def from_topology(cls, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> "SurfaceCells":
        return cls(arrays, meta)


def _interpolated_normals(layout: CellLayout, v: np.ndarray, f: np.ndarray,
                          vn: np.ndarray) -> np.ndarray:
    """Cell normal: vertex normals interpolated at the (clamped) centre; face normal fallback.

    Vertex normals are flipped to the face's side when they disagree (sharp edges, open sheets).
    """
    fc = layout.face
    fn = geo.face_normals(v, f)[fc]
    bc = np.clip(geo.barycentric(layout.frames.corners2d[fc], layout.center2d), 0, None)
    bc /= np.maximum(bc.sum(1, keepdims=True), 1e-300)
    vv = vn[f[fc]]                                                     # (n, 3, 3)
    vv = np.where((np.sum(vv * fn[:, None], 2) < 0)[..., None], -vv, vv)
    n = np.einsum("nk,nkd->nd", bc, vv)
    ln = np.linalg.norm(n, axis=1, keepdims=True)
    ok = (ln[:, 0] > 1e-9) & (np.sum(n * fn, 1) > 0.2 * ln[:, 0])
    return np.where(ok[:, None], n / np.maximum(ln, 1e-300), fn)
