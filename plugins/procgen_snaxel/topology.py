"""The tessellation as the snake sees it: CCW neighbour rings, edge lengths, blocked vertices.

Snaxels live on Delaunay edges (thesis section 3.1). Every topological question the snake asks
("which edges leave this vertex, in angular order?", "which triangle lies left of this edge?")
is answered from one ring per vertex sorted counter-clockwise by angle.

Why not the core's ``CellGraph`` or ``TriMesh.vertex_neighbors`` as they are: the snake needs
each ring in *angular* order (births fan the children around the vertex, thesis Figure 3.2),
and a tiled tessellation (:mod:`.tiles`) adds vertices and finishes rings while the cloud grows,
so the rings live in append-only storage addressed per vertex (``ring_lo``/``ring_hi``) rather
than in a frozen CSR. The neighbour *sets* do come from the core: ``TriMesh.vertex_neighbors``
for a mesh made by a recipe step, ``edge_table`` for the tiles' triangles.
"""
from __future__ import annotations

import numpy as np

from procgen import TriMesh, portable
from procgen.errors import InputError


def angular_rings(points: np.ndarray, src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Directed edges (src -> dst) sorted by source, then counter-clockwise by angle."""
    d = points[dst] - points[src]
    a = portable.pseudo_angle(d[:, 0], d[:, 1])
    a = np.where(a > 2.0, a - 2.0, a + 2.0)    # each ring starts just past -x and ends on it
    order = np.argsort(src * 8.0 + a)          # by vertex, then CCW (keys < 8)
    return src[order], dst[order]


class Topology:
    """Tessellation topology for snaxel growth: flat arrays, rings addressed per vertex.

    A vertex is *ready* once its ring is final; the snake only enters ready vertices. A whole
    mesh is ready from the start; :class:`.tiles.TiledTopology` makes vertices ready on demand
    through :meth:`ensure`.
    """

    def __init__(self, points: np.ndarray, faces: np.ndarray, ring_lo: np.ndarray, ring_hi: np.ndarray,
                 ring: np.ndarray, hull: np.ndarray, mean_edge: float, min_edge: float) -> None:
        self.points = points          # (n, 2) vertex positions
        self.faces = faces            # (m, 3) triangles known so far
        self.ring_lo = ring_lo        # (n,) start of each vertex's ring in ``ring`` (-1: not ready)
        self.ring_hi = ring_hi        # (n,) end of each vertex's ring
        self.ring = ring              # neighbours, CCW by angle per vertex
        self.hull = hull              # (n,) bool: vertex on the mesh boundary (never entered)
        self.mean_edge = mean_edge    # mean undirected edge length
        self.min_edge = min_edge      # shortest edge length (a lower bound for tiles)

    unbounded = False     # a whole mesh has a boundary; tiles extend without end

    @property
    def n_vertices(self) -> int:
        return len(self.points)

    @property
    def ready(self) -> np.ndarray:
        return self.ring_lo >= 0

    def neighbours(self, w: int) -> np.ndarray:
        return self.ring[self.ring_lo[w]:self.ring_hi[w]]

    def ensure(self, vertices: np.ndarray) -> bool:
        """Make the rings of ``vertices`` final; True when vertices were added (a whole mesh: never)."""
        return False

    def ensure_box(self, x0: float, y0: float, x1: float, y1: float) -> bool:
        """Make every vertex in the box ready (sketches, sources); True when vertices were added."""
        return False

    def rings_of(self, vertices: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(source, neighbour) pairs of the given ready vertices' rings, flat and vectorised."""
        v = np.asarray(vertices, np.int64)
        lo = self.ring_lo[v]
        n = self.ring_hi[v] - lo
        at = np.repeat(lo - np.concatenate([[0], np.cumsum(n)[:-1]]), n) + np.arange(int(n.sum()))
        return np.repeat(v, n), self.ring[at]

    def edges(self) -> np.ndarray:
        """(E, 2) undirected edges between ready vertices, each once (lower index first)."""
        src, dst = self.rings_of(np.flatnonzero(self.ring_lo >= 0))
        keep = src < dst
        return np.column_stack([src[keep], dst[keep]])

    def left_vertex(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """Third vertex of the triangle left of each directed edge u->v (-1 if none).

        (u, v, y) is CCW exactly when y follows v in u's CCW ring (and the wedge is a triangle).
        """
        u = np.asarray(u, np.int64)
        v = np.asarray(v, np.int64)
        out = np.full(u.shape, -1, np.int64)
        for i in range(u.size):     # test/diagnostic helper only, never on the per-step path
            nb = self.neighbours(int(u.flat[i]))
            k = int(np.flatnonzero(nb == v.flat[i])[0])
            y = int(nb[(k + 1) % len(nb)])
            a, b, c = self.points[u.flat[i]], self.points[v.flat[i]], self.points[y]
            cross = (b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])
            out.flat[i] = y if cross > 0 else -1
        return out


def mesh_topology(mesh: TriMesh) -> Topology:
    """Rings of a whole 2-D mesh from the core's cached edge table; InputError on a broken mesh."""
    pts = np.asarray(mesh.vertices[:, :2], np.float64)
    if np.any(mesh.face_areas == 0):
        raise InputError("snaxel tessellation: degenerate (zero-area) triangle")
    if np.any(mesh.edge_valence > 2):
        raise InputError("snaxel tessellation: an edge is shared by more than two triangles (non-manifold)")
    graph = mesh.vertex_neighbors
    indptr = graph.indptr
    src, dst = angular_rings(pts, graph.rows, graph.indices)
    hull = np.zeros(len(pts), bool)
    hull[mesh.edges[mesh.is_boundary_edge].ravel()] = True
    e = mesh.edges
    elen = np.hypot(*(pts[e[:, 1]] - pts[e[:, 0]]).T)
    return Topology(pts, np.asarray(mesh.faces), indptr[:-1].copy(), indptr[1:].copy(), dst, hull,
                    float(elen.mean()), float(elen.min()))
