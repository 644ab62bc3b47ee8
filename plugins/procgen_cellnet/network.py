"""CellNetwork: free cells in 3-D joined by distance links, as a procgen cell domain.

The paper's cells are not tied to any polygon once seeded (section 3.3): each is a point with
an orientation, and its neighbours are whatever cells lie within the link radius r_i (section
4.3).  Positions and links are the domain's immutable topology; everything else (normal,
colour, general state, potentials) is a field on the ``cell`` location.  A rule that moves
cells (harmonization, melting) or changes links (release, pruning) makes a new network through
:meth:`with_positions` / :meth:`with_links`; the box index follows moves incrementally.

It is a cell domain (:mod:`procgen.ca.cells`): :meth:`cell_graph` hands out its links as a
:class:`~procgen.ca.graph.CellGraph`, so every generic CA rule runs on it.  The network has
no orientation of its own (the paper's section 4.4 point); the Moore ``direction`` of a link is
read in the tangent frame of its first cell (u = world +x projected onto the cell's tangent
plane, or +y when +x is nearly normal; w = n x u): a link longer than (1 + sqrt 2)/2 cs is a
*diagonal* and takes the nearest corner slot, a shorter one the nearest side slot.  On a
square-8 lattice these are exactly the Moore slots (so ``von_neumann`` is the square-4
network); on other lattices ``von_neumann`` keeps the links near cs and drops the long ones,
and several links can share a slot (``window`` then shows only one of them).
"""
from __future__ import annotations

import math
from functools import cached_property
from typing import Any, ClassVar

import numpy as np
import scipy.sparse as sp

from procgen import Domain, InputError, register_domain_kind
from procgen.ca.graph import CellGraph
from procgen.domains import frozen

from .boxes import BoxIndex

#: links longer than this many cs are diagonals (midway between cs and sqrt(2) cs)
DIAGONAL_CS = (1 + math.sqrt(2)) / 2

#: Moore slot of each (di, dj) window position ((dj + 1) * 3 + di + 1), -1 for the centre
_WINDOW_TO_SLOT = np.array([0, 1, 2, 3, -1, 4, 5, 6, 7])


@register_domain_kind
class CellNetwork(Domain):
    """n free cells (positions, bond length cs) and their symmetric links (m, 2), i < j."""

    kind: ClassVar[str] = "CellNetwork"
    locations: ClassVar[tuple[str, ...]] = ("cell",)

    def __init__(self, positions: Any, links: Any = None, *, cs: float, grid: str,
                 radius: float = 0.0, normals: str = "face") -> None:
        super().__init__()
        p = np.asarray(positions, np.float64)
        if p.ndim != 2 or p.shape[1] != 3:
            raise InputError(f"CellNetwork: positions must be (n, 3), got {p.shape}")
        if not np.all(np.isfinite(p)):
            raise InputError("CellNetwork: positions contain NaN or inf")
        lk = np.zeros((0, 2), np.int64) if links is None else np.asarray(links, np.int64).reshape(-1, 2)
        if len(lk) and (lk.min() < 0 or lk.max() >= len(p) or np.any(lk[:, 0] >= lk[:, 1])):
            raise InputError("CellNetwork: links must be (m, 2) cell ids with i < j")
        self.positions = frozen(p)
        self.links = frozen(lk)
        self.cs = float(cs)
        self.grid = str(grid)
        self.radius = float(radius)
        #: how ``cell__normal`` follows the source surface: "face" or "vertex" (interpolated)
        self.normal_mode = str(normals)
        self._boxes: dict[float, BoxIndex] = {}
        self._gated: dict[str, tuple[np.ndarray, sp.csr_matrix, np.ndarray]] = {}

    # -- sizes ----------------------------------------------------------------------------
    @property
    def n_cells(self) -> int:
        return len(self.positions)

    @property
    def n_links(self) -> int:
        return len(self.links)

    @property
    def linked(self) -> bool:
        """True once a linking rule ran (r_i is known)."""
        return self.radius > 0

    def location_shape(self, at: str) -> tuple[int, ...]:
        return (self.n_cells,)

    # -- derived --------------------------------------------------------------------------
    @cached_property
    def link_lengths(self) -> np.ndarray:
        d = self.positions[self.links[:, 1]] - self.positions[self.links[:, 0]]
        return np.sqrt(np.einsum("ij,ij->i", d, d))

    @cached_property
    def csr(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(indptr, indices, link id of every entry): both directions of every link.

        One counting sort by row (scipy's COO -> CSR); with the reversed directions listed
        first, each row's neighbours come out ascending because the links are sorted (i, j).
        """
        m = self.n_links
        rows = np.concatenate([self.links[:, 1], self.links[:, 0]])
        cols = np.concatenate([self.links[:, 0], self.links[:, 1]])
        lid = np.concatenate([np.arange(m), np.arange(m)])
        a = sp.coo_array((lid, (rows, cols)), shape=(self.n_cells, self.n_cells)).tocsr()
        return (a.indptr.astype(np.int64), a.indices.astype(np.int64),
                a.data.astype(np.int64, copy=False))

    @cached_property
    def degree(self) -> np.ndarray:
        return np.diff(self.csr[0])

    @cached_property
    def matrix(self) -> sp.csr_matrix:
        """Symmetric n x n 0/1 link matrix: ``A @ x`` sums x over every cell's neighbours."""
        indptr, indices, _ = self.csr
        return sp.csr_matrix((np.ones(len(indices)), indices, indptr),
                             shape=(self.n_cells, self.n_cells))

    def sending(self, send: np.ndarray, dtype: Any = np.float64) -> tuple[sp.csr_matrix, np.ndarray]:
        """(G, k): the link matrix with only the entries whose neighbour sends, and each cell's
        number of sending neighbours (``dtype``).

        The general-state gate of every rule (section 3.1: only ACTIVE / INFLUENCING cells
        count) precomputed: ``G @ x`` sums x over the sending neighbours with no mask product
        per step.  States change rarely, so the last gate per dtype is kept (a mask compare
        per step) and shared with the moved networks of :meth:`with_positions`.
        """
        send = np.asarray(send, bool)
        key = np.dtype(dtype).str
        hit = self._gated.get(key)
        if hit is not None and np.array_equal(hit[0], send):
            return hit[1], hit[2]
        indptr, indices, _ = self.csr
        keep = send[indices]
        rows = np.repeat(np.arange(self.n_cells), np.diff(indptr))[keep]
        ptr = np.concatenate([[0], np.cumsum(np.bincount(rows, minlength=self.n_cells))])
        g = sp.csr_matrix((np.ones(len(rows), dtype), indices[keep], ptr),
                          shape=(self.n_cells, self.n_cells))
        k = np.diff(ptr).astype(dtype)
        self._gated[key] = (send.copy(), g, k)
        return g, k

    def averaging(self, send: np.ndarray, dtype: Any = np.float64) -> sp.csr_matrix:
        """M = diag(1 / (k + 1)) (I + G): ``M @ x`` is Table 1's (x + sum x_n) / (k + 1) over
        the sending neighbours in one product (cached with :meth:`sending`)."""
        key = "mean" + np.dtype(dtype).str
        hit = self._gated.get(key)
        if hit is not None and np.array_equal(hit[0], send):
            return hit[1]
        g, k = self.sending(send, dtype)
        m = (sp.diags((1 / (k + 1)).astype(dtype)) @ (g + sp.identity(self.n_cells, dtype, format="csr"))).tocsr()
        self._gated[key] = (np.asarray(send, bool).copy(), m, k)
        return m

    def cell_centres(self) -> np.ndarray:
        """(n, 3) cell positions (the CA layer's seed_points are matched against these)."""
        return self.positions

    def normals(self) -> np.ndarray:
        """``cell__normal`` if set, else +z for every cell."""
        if "cell__normal" in self:
            return np.asarray(self["cell__normal"], float)
        return np.tile([0.0, 0.0, 1.0], (self.n_cells, 1))

    @cached_property
    def graph(self) -> CellGraph:
        indptr, indices, lid = self.csr
        rows = np.repeat(np.arange(self.n_cells), np.diff(indptr))
        return CellGraph(indptr, indices, link_directions(self.positions, self.normals(), rows,
                                                          indices, self.cs),
                         np.zeros(len(indices), bool))

    def cell_graph(self, neighbourhood: str = "moore") -> CellGraph:
        """The links as a CellGraph (the cell-domain protocol of :mod:`procgen.ca.cells`)."""
        return self.graph.neighbourhood(neighbourhood)

    def box_index(self, size: float) -> BoxIndex:
        """The sparse box index of side ``size`` (built once per network and size)."""
        if size not in self._boxes:
            self._boxes[size] = BoxIndex.build(self.positions, size)
        return self._boxes[size]

    # -- new networks ---------------------------------------------------------------------
    def _derived(self, positions: np.ndarray, links: np.ndarray) -> "CellNetwork":
        out = CellNetwork(positions, links, cs=self.cs, grid=self.grid, radius=self.radius,
                          normals=self.normal_mode)
        out.copy_fields_from(self, {"cell": "cell", "domain": "domain"})
        return out

    def with_positions(self, positions: np.ndarray) -> "CellNetwork":
        """The same cells and links at new positions; cached box indexes follow the moves and
        the link structure (CSR, matrix) is shared."""
        out = self._derived(positions, self.links)
        out._boxes = {s: b.moved(out.positions) for s, b in self._boxes.items()}
        for name in ("csr", "degree", "matrix"):
            if name in self.__dict__:
                out.__dict__[name] = self.__dict__[name]
        out._gated = dict(self._gated)
        return out

    def with_links(self, links: np.ndarray, radius: float | None = None) -> "CellNetwork":
        out = self._derived(self.positions, links)
        if radius is not None:
            out.radius = float(radius)
        out._boxes = dict(self._boxes)
        return out

    # -- persistence ----------------------------------------------------------------------
    def topology_arrays(self) -> dict[str, np.ndarray]:
        return {"positions": self.positions, "links": self.links}

    def topology_meta(self) -> dict[str, Any]:
        return {"cs": self.cs, "grid": self.grid, "radius": self.radius, "normals": self.normal_mode}

    @classmethod
    def from_topology(cls, arrays: dict[str, np.ndarray], meta: dict[str, Any]) -> "CellNetwork":
        return cls(arrays["positions"], arrays["links"], cs=meta["cs"], grid=meta["grid"],
                   radius=meta.get("radius", 0.0), normals=meta.get("normals", "face"))


def tangent_frames(normals: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(u, w) per cell: world +x projected onto the tangent plane (+y if degenerate), n x u."""
    n = np.asarray(normals, float)
    u = np.array([1.0, 0.0, 0.0]) - n * n[:, :1]
    weak = np.linalg.norm(u, axis=1) < 1e-6
    u[weak] = np.array([0.0, 1.0, 0.0]) - n[weak] * n[weak, 1:2]
    u /= np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-300)
    return u, np.cross(n, u)


def link_directions(positions: np.ndarray, normals: np.ndarray, rows: np.ndarray,
                    cols: np.ndarray, cs: float) -> np.ndarray:
    """Moore slot (0..7) of every directed link in the tangent frame of its first cell."""
    u, w = tangent_frames(normals)
    a = np.zeros(len(rows))
    b = np.zeros(len(rows))
    d2 = np.zeros(len(rows))
    for k in range(3):                  # one coordinate at a time: no (m, 3) temporaries
        pk = np.ascontiguousarray(positions[:, k])
        d = pk[cols] - pk[rows]
        a += d * np.ascontiguousarray(u[:, k])[rows]
        b += d * np.ascontiguousarray(w[:, k])[rows]
        d2 += d * d
    diag = d2 > (DIAGONAL_CS * cs) ** 2
    side_a = np.abs(a) >= np.abs(b)
    di = np.where(diag | side_a, np.where(a >= 0, 1, -1), 0)
    dj = np.where(diag | ~side_a, np.where(b >= 0, 1, -1), 0)
    return _WINDOW_TO_SLOT[(dj + 1) * 3 + di + 1].astype(np.int8)
