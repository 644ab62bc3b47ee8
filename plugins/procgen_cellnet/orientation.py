"""One consistent side for the polygons of every object, whatever the winding they came with.

Polygons arrive with any winding (section 3.3: "any polygons"; Figure 8 builds one pyramid from
triangles, convex and concave polygons), and a polygon's triangles face whichever way the
triangulation's plane frame happened to point.  Cells take their normals from their faces, so
they pointed in or out polygon by polygon.  Rendering does not mind (splats are lit from both
sides), but every behaviour that averages normals does: melting (Table 1) sums a cell's normal
with its neighbours', and across a fold between an inward and an outward polygon the sum turns
sideways - splats stand on edge along the fold (the streaks of Figure 8(f)) - or cancels.

So the polygons are oriented before they are triangulated, the way a mesh is oriented by its
edges: each polygon's loops are wound about its normal (outline counter-clockwise, holes
clockwise); two polygons whose boundaries share a stretch of a line - a whole edge, or part of
one at a T-junction (Figure 8's concave pyramid) - face one side when they run along it in
opposite directions.  The flips travel over the polygon adjacency (a spanning tree, flips
accumulated by pointer doubling); each connected object then faces away from its centroid on
the whole (outward on a closed or box-like surface), and a flat sheet keeps the side most of
its area was given.  Meshes that are not given as polygons (primitives, loaded files) keep the
orientation they come with.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, connected_components


def loop_normal(loop: np.ndarray) -> np.ndarray:
    """Newell's normal of a closed loop: its direction is the loop's winding, its length twice
    the loop's area."""
    return np.cross(loop, np.roll(loop, -1, axis=0)).sum(axis=0)


def wound(loops: list[np.ndarray], normal: np.ndarray) -> list[np.ndarray]:
    """The loops wound about ``normal``: the outline counter-clockwise, the holes clockwise."""
    out = []
    for k, lp in enumerate(loops):
        ccw = float(loop_normal(lp) @ normal) > 0
        out.append(lp if ccw == (k == 0) else lp[::-1])
    return out


def _edges(polys: list[list[np.ndarray]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(start, end, polygon) of every boundary edge."""
    a, b, owner = [], [], []
    for k, loops in enumerate(polys):
        for lp in loops:
            a.append(lp)
            b.append(np.roll(lp, -1, axis=0))
            owner.append(np.full(len(lp), k))
    return np.concatenate(a), np.concatenate(b), np.concatenate(owner)


def shared_runs(a: np.ndarray, b: np.ndarray, owner: np.ndarray,
                tol: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(polygon p, polygon q, same direction?) for every pair of edges of two polygons that
    lie on one line and overlap over more than ``tol``."""
    d = b - a
    length = np.linalg.norm(d, axis=1)
    u = d / np.maximum(length, 1e-300)[:, None]
    runs = [_runs(a, b, u, length, owner, tol, lo, min(lo + CHUNK_EDGES, len(a)))
            for lo in range(0, len(a), CHUNK_EDGES)]
    return tuple(np.concatenate(r) for r in zip(*runs))


#: edges whose pairs with every later edge are tested at once (bounds memory)
CHUNK_EDGES = 1024


def _runs(a, b, u, length, owner, tol, lo, hi):
    i = np.repeat(np.arange(lo, hi), len(a) - 1 - np.arange(lo, hi))
    j = np.concatenate([np.arange(k + 1, len(a)) for k in range(lo, hi)]) if hi > lo else i
    keep = owner[i] != owner[j]
    i, j = i[keep], j[keep]
    # j's ends within tol of i's line, i.e. the two edges lie on one line
    for end in (a, b):
        off = end[j] - a[i]
        perp = off - np.einsum("ij,ij->i", off, u[i])[:, None] * u[i]
        ok = np.einsum("ij,ij->i", perp, perp) < tol * tol
        i, j = i[ok], j[ok]
    s0 = np.einsum("ij,ij->i", a[j] - a[i], u[i])
    s1 = np.einsum("ij,ij->i", b[j] - a[i], u[i])
    overlap = np.minimum(np.maximum(s0, s1), length[i]) - np.maximum(np.minimum(s0, s1), 0.0)
    ok = overlap > tol
    i, j = i[ok], j[ok]
    return owner[i], owner[j], np.einsum("ij,ij->i", u[i], u[j]) > 0


def orient_polygons(polys: list[list[np.ndarray]]) -> list[bool]:
    """Whether to flip each polygon (loops given wound about their own outline normal)."""
    n = len(polys)
    a, b, owner = _edges(polys)
    scale = float(np.ptp(np.concatenate([a, b]), axis=0).max())
    p, q, same = shared_runs(a, b, owner, 1e-9 * max(scale, 1e-300))
    # a shared run walked the same way by both polygons means one of them must flip
    vote = np.bincount(p * n + q, np.where(same, 1.0, -1.0), n * n).reshape(n, n)
    vote = vote + vote.T
    pi, qi = np.nonzero(np.triu(vote != 0, 1))
    graph = sp.coo_matrix((np.ones(len(pi)), (pi, qi)), shape=(n, n)).tocsr()
    graph = graph + graph.T
    n_comp, comp = connected_components(graph, directed=False)
    parent = np.arange(n)
    for r in np.unique(comp, return_index=True)[1]:
        order, pred = breadth_first_order(graph, r, directed=False, return_predecessors=True)
        parent[order[1:]] = pred[order[1:]]
    rel = vote[parent, np.arange(n)] > 0                 # flips relative to the parent
    up, acc = parent.copy(), rel & (parent != np.arange(n))
    while np.any(up != up[up]):                          # XOR along the path to the root
        acc ^= acc[up]
        up = up[up]
    # one side per object: away from its centroid on the whole, else the side of most area
    normals = np.array([loop_normal(lp[0]) for lp in polys])
    centres = np.array([lp[0].mean(axis=0) for lp in polys])
    area = np.linalg.norm(normals, axis=1)
    centre = np.stack([np.bincount(comp, area * centres[:, k], n_comp) for k in range(3)], 1)
    centre /= np.maximum(np.bincount(comp, area, n_comp), 1e-300)[:, None]
    sign = np.where(acc, -1.0, 1.0)
    away = np.bincount(comp, sign * np.einsum("ij,ij->i", normals, centres - centre[comp]), n_comp)
    size = np.bincount(comp, area * np.linalg.norm(centres - centre[comp], axis=1), n_comp)
    kept = np.bincount(comp, sign * area, n_comp)
    flip = np.where(np.abs(away) > 1e-9 * np.maximum(size, 1e-300), away < 0, kept < 0)
    return list(acc ^ flip[comp])
