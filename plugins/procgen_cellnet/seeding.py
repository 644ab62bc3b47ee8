"""Cells from polygons: regular or random patterns laid on every planar region (section 3).

The paper seeds its free cells on any polygons "by a square, triangle, hexagon or random
pattern" (section 3.2, Figures 5-6) and never says where a lattice starts.  Figure 8 shows that
one pyramid built from triangles, from convex or from concave polygons gives the *same* cells,
so the lattice frame here depends on the plane only: faces are grouped by plane, each plane
gets a frame (u = world +x projected onto it, or +y when +x is nearly normal; origin = the
world origin projected, offset by (cs/2, cs/2)), and a lattice node is kept when it lies in
any triangle of that plane (closed test), so concave and holed polygons need nothing special.
Cells closer than cs/4 (across creases) are merged.

Grids (bond length = cs for every grid): square (4 or 8 links), triangle (6 links: nodes of
the triangular lattice) and hexagon (3 links: the *vertices* of a honeycomb, as the paper's
3-neighbour count implies), or random points (round(area / cs^2) per plane, area-weighted).
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from procgen import InputError

from .boxes import unique_rows
from .network import tangent_frames

GRIDS = ("square4", "square8", "triangle", "hexagon", "random")

#: cells per cs^2 of each grid at bond length cs (square 1, triangular 2/sqrt 3, honeycomb
#: 4/(3 sqrt 3), random exactly 1)
DENSITY = {"square4": 1.0, "square8": 1.0, "triangle": 2 / math.sqrt(3),
           "hexagon": 4 / (3 * math.sqrt(3)), "random": 1.0}

#: the first distance shell a cell must not reach, in cs (section 4.3: r_i = shell - eps)
SHELL = {"square4": math.sqrt(2), "square8": 2.0, "triangle": math.sqrt(3),
         "hexagon": math.sqrt(3), "random": math.sqrt(3)}

#: ideal degree (links kept by pruning, section 4.4); random grids keep 6
DEGREE = {"square4": 4, "square8": 8, "triangle": 6, "hexagon": 3, "random": 6}

#: bytes per seeded cell across seeding and linking (positions, normals, ids, ~6 links, fields)
BYTES_PER_CELL = 600

#: planes are the same when normals agree to this and offsets to this times the scene size
_NORMAL_TOL, _OFFSET_TOL = 1e-6, 1e-9


def link_radius(grid: str, cs: float, eps: float) -> float:
    """r_i = (shell - eps) * cs: just inside the first shell a cell must not reach."""
    return (SHELL[grid] - eps) * cs


def bond_length(grid: str, cs: float, equal_density: bool) -> float:
    """Lattice bond for nominal size cs; with ``equal_density`` every grid has cs^2 per cell."""
    return cs * math.sqrt(DENSITY[grid]) if equal_density else cs


@dataclass(frozen=True)
class Seeded:
    """Cells seeded on a mesh: positions, unit normals, source face and plane region."""

    positions: np.ndarray
    normals: np.ndarray
    face: np.ndarray
    region: np.ndarray


def plane_regions(vertices: np.ndarray, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Group faces by plane: (region of every face, unit normal and offset of every region).

    Normals are made canonical (first non-zero component positive) so a plane's faces group
    whatever their winding; the region normal is the area-weighted mean of its faces.
    """
    v, f = vertices, faces
    cr = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    area2 = np.linalg.norm(cr, axis=1)
    n = cr / area2[:, None]
    lead = np.take_along_axis(n, np.argmax(np.abs(n) > 1e-9, axis=1)[:, None], axis=1)
    n = n * np.sign(lead)
    d = np.einsum("ij,ij->i", n, v[f[:, 0]])
    scale = max(float(np.ptp(v, axis=0).max()), 1e-300)
    key = np.column_stack([np.round(n / _NORMAL_TOL), np.round(d / (scale * _OFFSET_TOL))])
    region = unique_rows(key.astype(np.int64))[2]
    acc = np.zeros((region.max() + 1, 3))
    np.add.at(acc, region, n * area2[:, None])
    rn = acc / np.linalg.norm(acc, axis=1, keepdims=True)
    rd = np.bincount(region, weights=d * area2) / np.bincount(region, weights=area2)
    return region, rn, rd


def plane_frames(normals: np.ndarray, offsets: np.ndarray, cs: float) -> tuple[np.ndarray, ...]:
    """(origin, u, w) per plane: u = world +x projected (+y if degenerate), w = n x u."""
    u, w = tangent_frames(normals)
    origin = normals * offsets[:, None] + 0.5 * cs * (u + w)
    return origin, u, w


def lattice_basis(grid: str, cs: float) -> tuple[np.ndarray, np.ndarray]:
    """(2x2 matrix whose columns are the lattice vectors, (s, 2) site offsets) in plane units."""
    if grid in ("square4", "square8"):
        return np.array([[cs, 0.0], [0.0, cs]]), np.zeros((1, 2))
    if grid == "triangle":
        return np.array([[cs, cs / 2], [0.0, cs * math.sqrt(3) / 2]]), np.zeros((1, 2))
    r3 = math.sqrt(3)
    return (np.array([[r3 * cs, r3 * cs / 2], [0.0, 1.5 * cs]]),
            np.array([[0.0, 0.0], [0.0, cs]]))


def lattice_points(i: np.ndarray, j: np.ndarray, basis: np.ndarray, site: np.ndarray) -> np.ndarray:
    """(k, 2) plane coordinates of lattice nodes i * e1 + j * e2 + site."""
    site = np.asarray(site, float).reshape(-1, 2)
    return np.column_stack([i * basis[0, 0] + j * basis[0, 1] + site[:, 0],
                            i * basis[1, 0] + j * basis[1, 1] + site[:, 1]])


def _inside(p: np.ndarray, a: np.ndarray, b: np.ndarray, c: np.ndarray, tol: float) -> np.ndarray:
    """Closed point-in-triangle test in 2-D (either winding), with a tolerance in length."""
    def side(p0, p1):
        e = p1 - p0
        cross = e[:, 0] * (p[:, 1] - p0[:, 1]) - e[:, 1] * (p[:, 0] - p0[:, 0])
        return cross / np.maximum(np.linalg.norm(e, axis=1), 1e-300)
    s0, s1, s2 = side(a, b), side(b, c), side(c, a)
    pos = (s0 >= -tol) & (s1 >= -tol) & (s2 >= -tol)
    neg = (s0 <= tol) & (s1 <= tol) & (s2 <= tol)
    return pos | neg


def _row_spans(ij: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Candidate lattice nodes (face, i, j) of triangles given in lattice coordinates (m, 3, 2).

    Row by row (integer j): the i-interval where the row crosses the triangle's edges, one
    node wider each side, so the candidates are a superset of the nodes the closed inside test
    keeps and barely more (a bounding box would test twice the nodes of a big triangle).
    """
    jmin, jmax = ij[:, :, 1].min(axis=1), ij[:, :, 1].max(axis=1)
    lo = np.floor(jmin - 1e-6).astype(np.int64)
    rows = np.floor(jmax + 1e-6).astype(np.int64) - lo + 1
    fid = np.repeat(np.arange(len(ij)), rows)
    j = (np.arange(rows.sum()) - np.repeat(np.cumsum(rows) - rows, rows) + lo[fid]).astype(float)
    ilo = np.full(len(j), np.inf)
    ihi = np.full(len(j), -np.inf)
    for k in range(3):
        P, Q = ij[fid, k], ij[fid, (k + 1) % 3]
        dj = Q[:, 1] - P[:, 1]
        flat = np.abs(dj) < 1e-9
        t = np.clip((j - P[:, 1]) / np.where(flat, 1.0, dj), 0.0, 1.0)
        crosses = (j >= np.minimum(P[:, 1], Q[:, 1]) - 1e-6) & (j <= np.maximum(P[:, 1], Q[:, 1]) + 1e-6)
        x = P[:, 0] + t * (Q[:, 0] - P[:, 0])
        for x in (np.where(flat, P[:, 0], x), np.where(flat, Q[:, 0], x)):   # a flat edge: both ends
            ilo = np.where(crosses, np.minimum(ilo, x), ilo)
            ihi = np.where(crosses, np.maximum(ihi, x), ihi)
    has = ihi >= ilo
    fid, j, ilo, ihi = fid[has], j[has], ilo[has], ihi[has]
    first = np.floor(ilo).astype(np.int64) - 1
    count = np.ceil(ihi).astype(np.int64) + 1 - first + 1
    row = np.repeat(np.arange(len(j)), count)
    ci = np.arange(count.sum()) - np.repeat(np.cumsum(count) - count, count) + first[row]
    return fid[row], ci, j[row].astype(np.int64)


def _lattice_cells(v: np.ndarray, f: np.ndarray, region: np.ndarray, frames: tuple[np.ndarray, ...],
                   grid: str, cs: float) -> tuple[np.ndarray, np.ndarray]:
    """Lattice nodes inside the faces: (region, i, j, site) ids and the source face, deduped."""
    origin, u, w = frames
    basis, sites = lattice_basis(grid, cs)
    inv = np.linalg.inv(basis)
    o, uu, ww = origin[region], u[region], w[region]
    tri = v[f] - o[:, None, :]                                    # (m, 3, 3)
    uv = np.stack([np.einsum("mkj,mj->mk", tri, uu), np.einsum("mkj,mj->mk", tri, ww)], -1)
    ids, face = [], []
    for s, site in enumerate(sites):
        ij = np.einsum("ab,mkb->mka", inv, uv - site)             # lattice coordinates
        fid, ci, cj = _row_spans(ij)
        p = lattice_points(ci, cj, basis, site)
        q = uv[fid]
        ok = _inside(p, q[:, 0], q[:, 1], q[:, 2], 1e-9 * cs)
        ids.append(np.column_stack([region[fid[ok]], ci[ok], cj[ok], np.full(ok.sum(), s)]))
        face.append(fid[ok])
    ids_a, face_a = np.concatenate(ids), np.concatenate(face)
    # sorted by (region, i, j, site): the order, and so which duplicate a merge keeps, does
    # not depend on how the planes were cut into faces
    uniq, first, _ = unique_rows(ids_a)
    return uniq, face_a[first]


def _random_cells(v: np.ndarray, f: np.ndarray, region: np.ndarray, cs: float,
                  rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """round(area / cs^2) uniform points per plane region: (positions, source face)."""
    area = 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)
    order = np.argsort(region, kind="stable")
    cum = np.cumsum(area[order])
    r_area = np.bincount(region, weights=area)
    r_start = np.concatenate([[0.0], np.cumsum(r_area)[:-1]])
    count = np.round(r_area / cs ** 2).astype(np.int64)
    reg = np.repeat(np.arange(len(r_area)), count)
    target = r_start[reg] + rng.random(len(reg)) * r_area[reg]
    face = order[np.minimum(np.searchsorted(cum, target, side="right"), len(f) - 1)]
    a, b = rng.random(len(face)), rng.random(len(face))
    flip = a + b > 1
    a[flip], b[flip] = 1 - a[flip], 1 - b[flip]
    tri = v[f[face]]
    p = tri[:, 0] + a[:, None] * (tri[:, 1] - tri[:, 0]) + b[:, None] * (tri[:, 2] - tri[:, 0])
    return p, face


def _barycentric(p: np.ndarray, tri: np.ndarray) -> np.ndarray:
    e0, e1, d = tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0], p - tri[:, 0]
    d00, d01, d11 = (e0 * e0).sum(1), (e0 * e1).sum(1), (e1 * e1).sum(1)
    d20, d21 = (d * e0).sum(1), (d * e1).sum(1)
    den = d00 * d11 - d01 * d01
    b1, b2 = (d11 * d20 - d01 * d21) / den, (d00 * d21 - d01 * d20) / den
    return np.column_stack([1 - b1 - b2, b1, b2])


def merge_close(points: np.ndarray, distance: float, region: np.ndarray) -> np.ndarray:
    """Indices of the points to keep: of every group closer than ``distance``, the lowest index.

    Two nodes of one plane's lattice are at least a bond apart, so only cells of different
    planes (across creases, where objects touch) can merge: a one-plane scene skips the search.
    """
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    n = len(points)
    if n == 0 or np.all(region == region[0]):
        return np.arange(n)
    tree = cKDTree(points, balanced_tree=False, compact_nodes=False)
    pairs = tree.query_pairs(distance, output_type="ndarray")
    if len(pairs) == 0:
        return np.arange(n)
    g = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])), shape=(n, n))
    _, comp = connected_components(g, directed=False)
    _, first = np.unique(comp, return_index=True)
    return np.sort(first)


def snap(points: np.ndarray, extent: float) -> np.ndarray:
    """Round to a power-of-two quantum ~1e-12 of the scene: a cell meant to lie on a box
    boundary (z = 0 of an axis-aligned face) does so whichever face order produced it."""
    q = 2.0 ** (math.floor(math.log2(max(extent, 1e-300))) - 40)
    return np.round(points / q) * q


def expected_cells(vertices: np.ndarray, faces: np.ndarray, grid: str, cs: float) -> float:
    area = 0.5 * np.linalg.norm(np.cross(vertices[faces[:, 1]] - vertices[faces[:, 0]],
                                         vertices[faces[:, 2]] - vertices[faces[:, 0]]), axis=1).sum()
    return float(area) * DENSITY[grid] / cs ** 2


def seed_cells(vertices: np.ndarray, faces: np.ndarray, grid: str, cs: float, *,
               normals: str = "face", rng: np.random.Generator | None = None,
               vertex_normals: np.ndarray | None = None, max_bytes: int | None = None) -> Seeded:
    """Seed cells of bond length ``cs`` on the triangles (section 3.2-3.3)."""
    v = np.asarray(vertices, float)
    f = np.asarray(faces, np.int64)
    if grid not in GRIDS:
        raise InputError(f"cellnet.seed: grid {grid!r} is not one of {GRIDS}")
    extent = float(np.ptp(v, axis=0).max())
    if cs > extent:
        raise InputError(f"cellnet.seed: cell size {cs:g} is larger than the object "
                         f"(largest extent {extent:g})")
    n_est = expected_cells(v, f, grid, cs)
    if max_bytes is not None and n_est * BYTES_PER_CELL > max_bytes:
        raise InputError(f"cellnet.seed: cs = {cs:g} would make ~{n_est:.3g} cells "
                         f"(~{n_est * BYTES_PER_CELL / 2**30:.1f} GiB), more than the memory "
                         f"available ({max_bytes / 2**30:.1f} GiB)")
    region, rn, rd = plane_regions(v, f)
    if grid == "random":
        if rng is None:
            raise InputError("cellnet.seed: the random grid needs a generator")
        pos, face = _random_cells(v, f, region, cs, rng)
    else:
        frames = plane_frames(rn, rd, cs)
        ids, face = _lattice_cells(v, f, region, frames, grid, cs)
        origin, u, w = frames
        basis, sites = lattice_basis(grid, cs)
        uv = lattice_points(ids[:, 1], ids[:, 2], basis, sites[ids[:, 3]])
        r = ids[:, 0]
        pos = origin[r] + uv[:, :1] * u[r] + uv[:, 1:] * w[r]
        keep = merge_close(pos, 0.25 * cs, r)
        pos, face = snap(pos[keep], extent), face[keep]
    nrm = surface_normals(v, f, face, pos, normals, vertex_normals)
    return Seeded(pos, nrm, face, region[face])


def surface_normals(v: np.ndarray, f: np.ndarray, face: np.ndarray, pos: np.ndarray,
                    normals: str, vertex_normals: np.ndarray | None) -> np.ndarray:
    """Unit normals of the surface at ``pos`` on faces ``face``: the face's own ("face") or the
    vertex normals interpolated barycentrically ("vertex"; the face's where they cancel)."""
    tri = v[f[face]]
    fn = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    fn /= np.linalg.norm(fn, axis=1, keepdims=True)
    if normals == "face":
        return fn
    if normals != "vertex":
        raise InputError(f"cellnet: normals {normals!r} is not 'face' or 'vertex'")
    if vertex_normals is None:
        raise InputError("cellnet: interpolated normals need the mesh's vertex normals")
    nrm = np.einsum("nk,nkj->nj", _barycentric(pos, tri), np.asarray(vertex_normals)[f[face]])
    ln = np.linalg.norm(nrm, axis=1, keepdims=True)
    return np.where(ln > 1e-12, nrm / np.maximum(ln, 1e-300), fn)

