"""One consistent side for the cell normals of every connected surface.

Polygons arrive with any winding (section 3.1: "any polygons"; Figure 8 builds one pyramid from
triangles, convex and concave polygons), so the face normals a network is seeded with point in
or out polygon by polygon.  Rendering does not mind (splats are lit from both sides), but every
behaviour that averages normals does: melting (Table 1) sums a cell's normal with its
neighbours', and across a fold between an inward and an outward polygon the sum turns
sideways - splats stand on edge along the fold (the streaks of Figure 8(f)) - or cancels.

Orientation travels along the links, as in Hoppe et al.'s surface reconstruction (1992): a
maximum spanning tree of the links by confidence, the flips propagated from each root.  The
confidence of a link is n_i . n_j on a smooth piece and, across a fold, a test in the profile
plane of the fold that holds at any dihedral angle (:func:`link_confidence`).  Each connected surface then
takes the side whose normals point away from its centroid on the whole (sum n . (p - c) > 0:
outward on a closed surface, by the divergence theorem), or, when that sum is nil (a flat
sheet), the side most of its cells were seeded with.
"""
from __future__ import annotations

import numpy as np
import scipy.sparse as sp
from scipy.sparse.csgraph import breadth_first_order, connected_components, minimum_spanning_tree


#: normals closer than this angle's sine are one smooth piece: their dot product decides
FOLD_SINE = 0.2


def link_confidence(positions: np.ndarray, normals: np.ndarray, links: np.ndarray) -> np.ndarray:
    """+1 when cells i and j of each link face one side, -1 when opposite (magnitude: trust).

    On one smooth piece, n_i . n_j.  Across a fold (normals apart by more than asin
    FOLD_SINE), in the profile plane across the fold edge e = n_i x n_j: with O the edge point
    and u_i, u_j the directions from O to the cells, the surface walked from i to j turns its
    normal with it exactly when (-u_i x n_i) and (u_j x n_j) point the same way along e - true
    for a fold of any sharpness (a cube edge, Figure 8's 45 degree base edge), where n_i . n_j
    says nothing (0 at a right angle) or the wrong thing.
    """
    p_i, p_j = positions[links[:, 0]], positions[links[:, 1]]
    n_i, n_j = normals[links[:, 0]], normals[links[:, 1]]
    dot = np.einsum("ij,ij->i", n_i, n_j)
    e = np.cross(n_i, n_j)
    ee = np.einsum("ij,ij->i", e, e)
    fold = ee > FOLD_SINE ** 2
    if not fold.any():
        return dot
    p_i, p_j, n_i, n_j, e, ee = p_i[fold], p_j[fold], n_i[fold], n_j[fold], e[fold], ee[fold]
    c_i, c_j = np.einsum("ij,ij->i", n_i, p_i), np.einsum("ij,ij->i", n_j, p_j)
    c_e = np.einsum("ij,ij->i", e, p_i)
    # the point of both planes nearest p_i along e (three-plane intersection, det = |e|^2)
    o = (c_i[:, None] * np.cross(n_j, e) + c_j[:, None] * np.cross(e, n_i)
         + c_e[:, None] * e) / ee[:, None]
    eh = e / np.sqrt(ee)[:, None]

    def across(p):
        u = p - o
        u -= np.einsum("ij,ij->i", u, eh)[:, None] * eh
        return u / np.maximum(np.linalg.norm(u, axis=1, keepdims=True), 1e-300)
    side = np.einsum("ij,ij->i", np.cross(-across(p_i), n_i), np.cross(across(p_j), n_j))
    out = dot.copy()
    out[fold] = side
    return out


def orient_normals(positions: np.ndarray, normals: np.ndarray, links: np.ndarray) -> np.ndarray:
    """The normals with signs made consistent over every linked component (see module doc)."""
    n = len(positions)
    if n == 0:
        return normals.copy()
    links = np.asarray(links, np.int64).reshape(-1, 2)
    conf = link_confidence(positions, normals, links)
    # minimum spanning tree of 2 - |confidence| (> 0: scipy drops zero weights)
    w = sp.coo_matrix((2.0 - np.abs(conf), (links[:, 0], links[:, 1])), shape=(n, n)).tocsr()
    tree = minimum_spanning_tree(w)
    tree = (tree + tree.T).tocsr()
    n_comp, comp = connected_components(tree, directed=False)
    parent = np.arange(n)
    roots = np.unique(comp, return_index=True)[1]
    for r in roots[np.bincount(comp) > 1]:              # one BFS per connected surface
        order, pred = breadth_first_order(tree, r, directed=False, return_predecessors=True)
        parent[order[1:]] = pred[order[1:]]
    # flip relative to the parent where the tree link says the sides differ
    child = np.nonzero(parent != np.arange(n))[0]
    rel = np.zeros(n, bool)
    if len(child):
        pair_conf = link_confidence(positions, normals, np.column_stack([parent[child], child]))
        rel[child] = pair_conf < 0
    # XOR of the flips on the path to the root, by pointer doubling (log depth passes)
    up, acc = parent.copy(), rel.copy()
    while np.any(up != up[up]):
        acc ^= acc[up]
        up = up[up]
    out = np.where(acc[:, None], -normals, normals)
    # one side per component: outward on the whole, else the side most cells had
    centre = np.stack([np.bincount(comp, positions[:, k], n_comp) for k in range(3)], 1)
    centre /= np.bincount(comp, minlength=n_comp)[:, None]
    spread = np.bincount(comp, np.linalg.norm(positions - centre[comp], axis=1), n_comp)
    away = np.bincount(comp, np.einsum("ij,ij->i", out, positions - centre[comp]), n_comp)
    kept = np.bincount(comp, np.where(acc, -1.0, 1.0), n_comp)
    flip = np.where(np.abs(away) > 1e-6 * spread, away < 0, kept < 0)
    return np.where(flip[comp][:, None], -out, out)
