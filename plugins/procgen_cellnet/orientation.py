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
opposite directions.  Those shared stretches are found by sorting, not by comparing every
edge with every other: edges are grouped by supporting line (direction, then offset), then
by interval along it, so a soup of 100,000 polygons takes seconds.  The flips travel over the
polygon adjacency (a spanning tree, flips accumulated by pointer doubling); each connected object then faces away from its centroid on
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


def _edges(polys: list[list[np.ndarray]]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(start, end, polygon, on the outline?) of every boundary edge."""
    loops = [lp for loops in polys for lp in loops]
    sizes = np.array([len(lp) for lp in loops])
    a = np.concatenate(loops)
    first = np.cumsum(sizes) - sizes                    # each loop's first vertex
    nxt = np.arange(len(a)) + 1
    nxt[first + sizes - 1] = first                      # the last vertex closes the loop
    per_poly = [len(loops) for loops in polys]
    owner = np.repeat(np.repeat(np.arange(len(polys)), per_poly), sizes)
    outline = np.repeat(np.concatenate([np.arange(k) == 0 for k in per_poly]), sizes)
    return a, a[nxt], owner, outline


#: clustering tolerance of the direction (the entries of u u^T, i.e. about 1e-6 rad): edges
#: that share a run lie on one line up to rounding, ~1e-16 rad apart
DIR_TOL = 1e-6
#: clustering tolerance of the line's foot point, in scene sizes: at least DIR_TOL times the
#: farthest an edge sits from the scene's corner (sqrt 3 sizes), plus the collinearity tolerance
FOOT_TOL = 1e-5


def _clusters(keys: list[np.ndarray], tols: list[float]) -> np.ndarray:
    """Group label of every row: rows whose keys differ by at most ``tols`` share a group.

    Key after key, the rows of each group so far are sorted by that key and split where two
    neighbours differ by more than its tolerance (single linkage in 1-D: values closer than the
    tolerance are never split, whatever lies between them).  Groups may hold rows farther apart
    (chains); the caller tests the rows it pairs exactly.
    """
    group = np.zeros(len(keys[0]), np.int64)
    for key, tol in zip(keys, tols):
        order = np.lexsort((key, group))
        g, v = group[order], key[order]
        new = np.concatenate([[False], (g[1:] != g[:-1]) | (np.diff(v) > tol)])
        group[order] = np.cumsum(new)
    return group


def _overlapping(group: np.ndarray, lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(i, j) of every two intervals [lo, hi] of one group where j starts at or after i's start
    and before i's end: each overlapping pair once, found by one sort of starts and ends."""
    n = len(group)
    order = np.lexsort((lo, group))
    # the ends are merged into the sorted starts (an end sorts before an equal start): the
    # starts before i's end in its group follow i's own start in that order
    g = np.concatenate([group[order], group[order]])
    v = np.concatenate([lo[order], hi[order]])
    kind = np.concatenate([np.ones(n, np.int64), np.zeros(n, np.int64)])
    ev = np.lexsort((kind, v, g))
    starts_before = np.cumsum(kind[ev]) - kind[ev]
    end = np.empty(n, np.int64)
    is_end = ev >= n
    end[ev[is_end] - n] = starts_before[is_end]
    count = np.maximum(end - np.arange(n) - 1, 0)
    first = np.repeat(np.arange(n) + 1 - (np.cumsum(count) - count), count) + np.arange(count.sum())
    return order[np.repeat(np.arange(n), count)], order[first]


def shared_runs(a: np.ndarray, b: np.ndarray, owner: np.ndarray,
                tol: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(polygon p, polygon q, same direction?) for every pair of edges of two polygons that
    lie on one line and overlap over more than ``tol``.

    O(E log E): the edges are grouped by their supporting line (its direction as u u^T, the
    same for both windings, then the foot of the perpendicular from the scene's corner), and
    within a line by their interval along it, so only collinear overlapping edges are paired;
    each such pair then gets the exact test (both ends of the later edge within ``tol`` of the
    earlier edge's line, overlap > ``tol``).
    """
    d = b - a
    length = np.linalg.norm(d, axis=1)
    live = np.nonzero(length > tol)[0]          # a shorter edge overlaps nothing by > tol
    u = d / np.maximum(length, 1e-300)[:, None]
    corner = np.concatenate([a, b]).min(axis=0)
    scale = max(float(np.ptp(np.concatenate([a, b]), axis=0).max()), 1e-300)
    a0 = a[live] - corner
    ul = u[live]
    foot = a0 - np.einsum("ij,ij->i", a0, ul)[:, None] * ul
    uu = [ul[:, 0] * ul[:, 0], ul[:, 1] * ul[:, 1], ul[:, 2] * ul[:, 2],
          ul[:, 0] * ul[:, 1], ul[:, 0] * ul[:, 2], ul[:, 1] * ul[:, 2]]
    line = _clusters(uu + [foot[:, k] for k in range(3)], [DIR_TOL] * 6 + [FOOT_TOL * scale] * 3)
    # one direction per line (its first edge's) to measure the intervals along it
    ref = ul[np.unique(line, return_index=True)[1]][line]
    s0 = np.einsum("ij,ij->i", a0, ref)
    s1 = np.einsum("ij,ij->i", b[live] - corner, ref)
    ci, cj = _overlapping(line, np.minimum(s0, s1), np.maximum(s0, s1))
    return collinear_runs(a, b, owner, tol, live[np.minimum(ci, cj)], live[np.maximum(ci, cj)])


def collinear_runs(a: np.ndarray, b: np.ndarray, owner: np.ndarray, tol: float,
                   i: np.ndarray, j: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The exact test of candidate edge pairs i < j: :func:`shared_runs`' answer for them."""
    d = b - a
    length = np.linalg.norm(d, axis=1)
    u = d / np.maximum(length, 1e-300)[:, None]
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
    a, b, owner, outline = _edges(polys)
    scale = float(np.ptp(np.concatenate([a, b]), axis=0).max())
    p, q, same = shared_runs(a, b, owner, 1e-9 * max(scale, 1e-300))
    # a shared run walked the same way by both polygons means one of them must flip
    vote = sp.coo_matrix((np.where(same, 1.0, -1.0), (p, q)), shape=(n, n)).tocsr()
    vote = (vote + vote.T).tocsr()
    vote.eliminate_zeros()
    n_comp, comp = connected_components(vote, directed=False)
    # one breadth-first search from a virtual root joined to each object's first polygon
    firsts = np.unique(comp, return_index=True)[1]
    hub = sp.coo_matrix((np.ones(n_comp), (np.full(n_comp, n), firsts)), shape=(n + 1, n + 1))
    graph = sp.bmat([[abs(vote), None], [None, sp.csr_matrix((1, 1))]]).tocsr() + hub.tocsr()
    order, pred = breadth_first_order(graph, n, directed=False, return_predecessors=True)
    parent = pred[:n].astype(np.int64)
    parent[firsts] = firsts
    rel = np.asarray(vote[parent, np.arange(n)]).ravel() > 0     # flips relative to the parent
    up, acc = parent.copy(), rel & (parent != np.arange(n))
    while np.any(up != up[up]):                          # XOR along the path to the root
        acc ^= acc[up]
        up = up[up]
    # one side per object: away from its centroid on the whole, else the side of most area
    normals = np.stack([np.bincount(owner[outline], np.cross(a, b)[outline][:, k], n)
                        for k in range(3)], 1)
    centres = np.stack([np.bincount(owner[outline], a[outline, k], n) for k in range(3)], 1)
    centres /= np.bincount(owner[outline], minlength=n)[:, None]
    area = np.linalg.norm(normals, axis=1)
    centre = np.stack([np.bincount(comp, area * centres[:, k], n_comp) for k in range(3)], 1)
    centre /= np.maximum(np.bincount(comp, area, n_comp), 1e-300)[:, None]
    sign = np.where(acc, -1.0, 1.0)
    away = np.bincount(comp, sign * np.einsum("ij,ij->i", normals, centres - centre[comp]), n_comp)
    size = np.bincount(comp, area * np.linalg.norm(centres - centre[comp], axis=1), n_comp)
    kept = np.bincount(comp, sign * area, n_comp)
    flip = np.where(np.abs(away) > 1e-9 * np.maximum(size, 1e-300), away < 0, kept < 0)
    return list(acc ^ flip[comp])
