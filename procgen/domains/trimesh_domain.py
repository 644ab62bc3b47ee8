"""TriMesh: triangle meshes, both 2-D tessellations (Delaunay) and 3-D surfaces."""
from __future__ import annotations

from functools import cached_property
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from ..errors import InputError
from .base import Domain, frozen

if TYPE_CHECKING:
    from ..ca.graph import CellGraph


def edge_table(faces: np.ndarray, use: np.ndarray | None = None
               ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(edges, face_edges, edge_faces, valence) of a triangle list, vectorised.

    ``use`` masks faces (e.g. degenerate ones) that keep their edge ids but link nothing:
    they count in neither ``edge_faces`` nor ``valence``.
    """
    faces = np.asarray(faces, dtype=np.int64)
    m = len(faces)
    half = np.stack([faces, np.roll(faces, -1, axis=1)], axis=2).reshape(-1, 2)
    edges, inverse = np.unique(np.sort(half, axis=1), axis=0, return_inverse=True)
    fe = inverse.reshape(m, 3)
    keep = np.ones(m, bool) if use is None else np.asarray(use, bool)
    flat = fe[keep].ravel()
    fid = np.repeat(np.arange(m)[keep], 3)
    order = np.argsort(flat, kind="stable")
    flat, fid = flat[order], fid[order]
    first = np.ones(len(flat), bool)
    first[1:] = flat[1:] != flat[:-1]
    ef = np.full((len(edges), 2), -1, np.int64)
    ef[flat[first], 0] = fid[first]
    second = np.zeros(len(flat), bool)
    second[1:] = (~first[1:]) & first[:-1]
    ef[flat[second], 1] = fid[second]
    return edges, fe, ef, np.bincount(flat, minlength=len(edges))


class TriMesh(Domain):
    """Vertices (n, 2 or 3) and triangles (m, 3); fields on ``vertex``, ``face`` or ``edge``.

    Derived topology (edges, adjacency, CSR neighbour lists, normals) is computed on first use
    and cached; it can be cached safely because topology arrays are read-only.
    """

    kind: ClassVar[str] = "TriMesh"
    locations: ClassVar[tuple[str, ...]] = ("vertex", "face", "edge")

    def __init__(self, vertices: Any, faces: Any) -> None:
        super().__init__()
        v = np.asarray(vertices, dtype=np.float64)
        f = np.asarray(faces)
        if v.ndim != 2 or v.shape[1] not in (2, 3) or len(v) < 3:
            raise InputError(f"TriMesh: vertices must be (n>=3, 2 or 3), got shape {v.shape}")
        if not np.all(np.isfinite(v)):
            raise InputError("TriMesh: vertices contain NaN or inf")
        if f.ndim != 2 or f.shape[1] != 3 or len(f) < 1:
            raise InputError(f"TriMesh: faces must be (m>=1, 3), got shape {f.shape}")
        if not np.issubdtype(f.dtype, np.integer):
            raise InputError("TriMesh: faces must hold integer vertex indices")
        if f.min() < 0 or f.max() >= len(v):
            raise InputError(f"TriMesh: face indices must lie in [0, {len(v) - 1}]")
        self.vertices = frozen(v)
        self.faces = frozen(f, np.int64)

    # -- sizes ----------------------------------------------------------------------------
    @property
    def dim(self) -> int:
        return int(self.vertices.shape[1])

    @property
    def n_vertices(self) -> int:
        return len(self.vertices)

    @property
    def n_faces(self) -> int:
        return len(self.faces)

    def location_shape(self, at: str) -> tuple[int, ...]:
        if at == "vertex":
            return (self.n_vertices,)
        if at == "face":
            return (self.n_faces,)
        return (len(self.edges),)

    # -- derived topology (cached) ----------------------------------------------------------
    @cached_property
    def _edge_table(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        return tuple(frozen(x) for x in edge_table(self.faces))  # type: ignore[return-value]

    @property
    def edges(self) -> np.ndarray:
        """Unique undirected edges (E, 2), each row sorted."""
        return self._edge_table[0]

    @property
    def face_edges(self) -> np.ndarray:
        """(m, 3) edge ids; edge k of face f joins faces[f, k] and faces[f, (k+1) % 3]."""
        return self._edge_table[1]

    @property
    def edge_faces(self) -> np.ndarray:
        """(E, 2) the faces on each side of an edge, -1 on a boundary; non-manifold extras dropped."""
        return self._edge_table[2]

    @property
    def edge_valence(self) -> np.ndarray:
        """Number of faces using each edge (1 boundary, 2 manifold, >2 non-manifold)."""
        return self._edge_table[3]

    @property
    def is_boundary_edge(self) -> np.ndarray:
        return self.edge_valence == 1

    @cached_property
    def face_adjacency(self) -> np.ndarray:
        """(K, 2) pairs of faces sharing an edge."""
        ef = self.edge_faces
        return frozen(ef[ef[:, 1] >= 0])

    @cached_property
    def vertex_neighbors(self) -> "CellGraph":
        """Vertices joined by an edge as the core's neighbour graph (no lattice directions);
        ``indptr``/``indices`` CSR, neighbours sorted per vertex."""
        from ..ca.graph import CellGraph
        e = self.edges
        src = np.concatenate([e[:, 0], e[:, 1]])
        dst = np.concatenate([e[:, 1], e[:, 0]])
        order = np.lexsort((dst, src))
        src, dst = src[order], dst[order]
        indptr = np.concatenate([[0], np.cumsum(np.bincount(src, minlength=self.n_vertices))])
        return CellGraph(frozen(indptr, np.int64), frozen(dst, np.int64))

    @cached_property
    def vertex_faces(self) -> tuple[np.ndarray, np.ndarray]:
        """CSR (indptr, indices) of faces around each vertex."""
        vid = self.faces.ravel()
        fid = np.repeat(np.arange(self.n_faces), 3)
        order = np.argsort(vid, kind="stable")
        indptr = np.concatenate([[0], np.cumsum(np.bincount(vid, minlength=self.n_vertices))])
        return frozen(indptr, np.int64), frozen(fid[order], np.int64)

    @cached_property
    def _cross(self) -> np.ndarray:
        v = self.vertices if self.dim == 3 else np.column_stack([self.vertices, np.zeros(self.n_vertices)])
        a, b, c = v[self.faces[:, 0]], v[self.faces[:, 1]], v[self.faces[:, 2]]
        return np.cross(b - a, c - a)

    @cached_property
    def face_areas(self) -> np.ndarray:
        return frozen(0.5 * np.linalg.norm(self._cross, axis=1))

    @cached_property
    def face_normals(self) -> np.ndarray:
        """Unit normals (m, 3); zero for degenerate faces."""
        n = self._cross
        ln = np.linalg.norm(n, axis=1, keepdims=True)
        return frozen(np.divide(n, ln, out=np.zeros_like(n), where=ln > 0))

    @cached_property
    def vertex_normals(self) -> np.ndarray:
        """Area-weighted unit vertex normals (n, 3)."""
        acc = np.zeros((self.n_vertices, 3))
        for k in range(3):
            np.add.at(acc, self.faces[:, k], self._cross)
        ln = np.linalg.norm(acc, axis=1, keepdims=True)
        return frozen(np.divide(acc, ln, out=np.zeros_like(acc), where=ln > 0))

    @cached_property
    def face_centroids(self) -> np.ndarray:
        return frozen(self.vertices[self.faces].mean(axis=1))

    @property
    def bounds(self) -> np.ndarray:
        return np.stack([self.vertices.min(axis=0), self.vertices.max(axis=0)])

    # -- interop --------------------------------------------------------------------------
    def to_trimesh(self) -> Any:
        """A ``trimesh.Trimesh`` view (3-D; 2-D meshes get z = 0), unprocessed."""
        import trimesh

        v = self.vertices if self.dim == 3 else np.column_stack([self.vertices, np.zeros(self.n_vertices)])
        return trimesh.Trimesh(vertices=np.array(v), faces=np.array(self.faces), process=False)

    @classmethod
    def from_trimesh(cls, mesh: Any) -> "TriMesh":
        return cls(np.asarray(mesh.vertices), np.asarray(mesh.faces))

    def topology_arrays(self) -> dict[str, np.ndarray]:
        return {"vertices": self.vertices, "faces": self.faces}

    @classmethod
    def from_topology(cls, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> "TriMesh":
        return cls(arrays["vertices"], arrays["faces"])
