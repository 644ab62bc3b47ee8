"""Connected regions and hop distances over a :class:`CellGraph`, for every cell rule.

Many cell models need "which cells hang together" (the peeling groups cut out by cracks, holes
in a corroded sheet, islands of a Voronoi label) and "how many links from the nearest seed"
(an age or distance-transform level).  The 3DSCA thesis floods group ids cell to cell with
recursive "semi-cellular" functions (Gobron, ch. 5.3.2, SCA-Functions 5.3-5.5); here the same
answers come from scipy's compiled graph routines on the CSR graph, with no Python recursion
and no per-cell loop.

Links are taken as undirected (a one-way cross-edge link still joins its two cells).  A cell
``mask`` keeps only the cells that may belong to a region (e.g. not cracked); a per-entry
``keep`` mask drops individual links (e.g. links across a sharp mesh edge).
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse import csgraph

from ..errors import InputError
from .graph import CellGraph


def _links(graph: CellGraph, mask: np.ndarray | None, keep: np.ndarray | None) -> sp.csr_matrix:
    """Symmetric 0/1 adjacency of the kept links between two masked cells."""
    n = graph.n_cells
    ok = np.ones(len(graph.indices), bool) if keep is None else np.asarray(keep, bool)
    if ok.shape != graph.indices.shape:
        raise InputError(f"link mask has shape {ok.shape}, the graph has {len(graph.indices)} entries")
    if mask is not None:
        m = _cell_mask(graph, mask)
        ok = ok & m[graph.rows] & m[graph.indices]
    r, c = graph.rows[ok], graph.indices[ok]
    a = sp.csr_matrix((np.ones(len(r), np.int8), (r, c)), shape=(n, n))
    return (a + a.T).tocsr()


def _cell_mask(graph: CellGraph, mask: np.ndarray) -> np.ndarray:
    m = np.asarray(mask, bool)
    if m.shape != (graph.n_cells,):
        raise InputError(f"cell mask has shape {m.shape}, the graph has {graph.n_cells} cells")
    return m


def connected_components(graph: CellGraph, mask: np.ndarray | None = None,
                         keep: np.ndarray | None = None) -> tuple[np.ndarray, int]:
    """Label the connected regions of the masked cells along the kept links.

    Returns ``(labels, count)``: labels (n,) int64 in 0..count-1, -1 outside ``mask``.
    Regions are numbered in the order of their smallest cell index, so the labelling depends
    only on the graph and the masks (the thesis's "smallest id wins" rule, SCA-Function 5.4).
    """
    n = graph.n_cells
    inside = np.ones(n, bool) if mask is None else _cell_mask(graph, mask)
    _, raw = csgraph.connected_components(_links(graph, inside, keep), directed=False)
    cells = np.nonzero(inside)[0]
    labels = np.full(n, -1, np.int64)
    if len(cells) == 0:
        return labels, 0
    uniq, first, inverse = np.unique(raw[cells], return_index=True, return_inverse=True)
    rank = np.empty(len(uniq), np.int64)
    rank[np.argsort(first, kind="stable")] = np.arange(len(uniq))
    labels[cells] = rank[inverse]
    return labels, len(uniq)


def hop_distance(graph: CellGraph, sources: np.ndarray, mask: np.ndarray | None = None,
                 keep: np.ndarray | None = None) -> np.ndarray:
    """Multi-source breadth-first distance: links from the nearest source, -1 if unreachable.

    ``sources``: bool (n,) or cell indices.  Paths run only through masked cells (sources always
    count as masked) and kept links.  On the 4-neighbour grid
    graph this is the city-block distance transform, on the 8-neighbour one the chessboard one.
    """
    n = graph.n_cells
    src = np.asarray(sources)
    if src.dtype == bool:
        src = np.nonzero(_cell_mask(graph, src))[0]
    src = np.unique(src.astype(np.int64))
    if len(src) and (src[0] < 0 or src[-1] >= n):
        raise InputError(f"hop_distance: source cell index out of range 0..{n - 1}")
    dist = np.full(n, -1, np.int64)
    if len(src) == 0:
        return dist
    inside = np.ones(n, bool) if mask is None else _cell_mask(graph, mask).copy()
    inside[src] = True
    d = csgraph.dijkstra(_links(graph, inside, keep), directed=False, indices=src,
                         unweighted=True, min_only=True)
    ok = np.isfinite(d)
    dist[ok] = d[ok].astype(np.int64)
    return dist
