"""3DSCA cell construction (thesis ch. 3.2): one square grid per triangle, cells clipped to it.

Each triangle gets its own 2-D frame with A = (0, 0), B = (0, |AB|) and C = (cx > 0, cy), and a
grid of square cells of one common size ``s`` covering its bounding rectangle.  A cell is active
when it overlaps the triangle with positive area (exact Sutherland-Hodgman clip, vectorised over
all candidate cells); it is COMP-IN when its centre lies inside the triangle, PART-IN otherwise.
Pure numpy: no procgen state involved, so later CA families and tests can call it directly.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from procgen.errors import InputError
from procgen.geometry import orient2d, triangle_cross

MAX_POLY = 8          # a square clipped by 3 half-planes has at most 7 vertices
DEGENERATE_RATIO = 1e-10  # 2*area / longest_edge^2 below this = degenerate (zero height)


@dataclass(frozen=True)
class FaceFrames:
    """Per-triangle 2-D frames: 3-D origin and axes plus each original corner's 2-D position."""

    origin: np.ndarray   # (m, 3) vertex A in 3-D
    ex: np.ndarray       # (m, 3) unit x axis (towards C)
    ey: np.ndarray       # (m, 3) unit y axis (along AB)
    corners2d: np.ndarray  # (m, 3, 2) 2-D position of faces[f, k] for k = 0, 1, 2
    valid: np.ndarray    # (m,) False for degenerate triangles (no cells)

    def to_3d(self, face: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """3-D points of 2-D frame coordinates ``xy`` (n, 2) on faces ``face`` (n,)."""
        return (self.origin[face] + xy[:, :1] * self.ex[face] + xy[:, 1:2] * self.ey[face])

    def to_2d(self, face: np.ndarray, xyz: np.ndarray) -> np.ndarray:
        d = xyz - self.origin[face]
        return np.column_stack([np.sum(d * self.ex[face], 1), np.sum(d * self.ey[face], 1)])


def face_frames(vertices: np.ndarray, faces: np.ndarray, frame: str = "thesis") -> FaceFrames:
    """Frames per triangle.

    ``thesis``: A = first vertex, AB = first edge, A and B swapped when C projects below A
    (seed-003 digest 4.7).  ``longest``: AB = the longest edge (fewer thin-triangle cases).
    """
    p = vertices[faces]                                   # (m, 3, 3)
    m = len(faces)
    lens = np.linalg.norm(p[:, [1, 2, 0]] - p, axis=2)    # edge k: corner k -> k+1
    if frame == "longest":
        a_idx = np.argmax(lens, axis=1)
    elif frame == "thesis":
        a_idx = np.zeros(m, np.int64)
    else:
        raise InputError(f"frame must be 'thesis' or 'longest', got {frame!r}")
    b_idx = (a_idx + 1) % 3
    c_idx = (a_idx + 2) % 3
    rows = np.arange(m)
    a, b, c = p[rows, a_idx], p[rows, b_idx], p[rows, c_idx]
    swap = np.sum((c - a) * (b - a), axis=1) < 0
    a_idx, b_idx = np.where(swap, b_idx, a_idx), np.where(swap, a_idx, b_idx)
    a, b = np.where(swap[:, None], b, a), np.where(swap[:, None], a, b)
    ab = b - a
    lab = np.linalg.norm(ab, axis=1)
    ey = ab / np.where(lab > 0, lab, 1.0)[:, None]
    ac = c - a
    perp = ac - np.sum(ac * ey, axis=1)[:, None] * ey
    cx = np.linalg.norm(perp, axis=1)
    ex = perp / np.where(cx > 0, cx, 1.0)[:, None]
    longest = lens.max(axis=1)
    valid = (lab > 0) & (cx * lab > DEGENERATE_RATIO * longest ** 2)
    d = p - a[:, None, :]
    corners = np.stack([np.sum(d * ex[:, None], 2), np.sum(d * ey[:, None], 2)], axis=2)
    corners[rows, a_idx] = 0.0                            # exact zeros for A
    corners[rows, b_idx, 0] = 0.0
    return FaceFrames(origin=a, ex=ex, ey=ey, corners2d=corners, valid=valid)


def edge_half_planes(corners2d: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inward unit normals (m, 3, 2) and offsets (m, 3) of each triangle edge k (corner k -> k+1).

    A point q is inside edge k's half-plane when normals[k] . q - offsets[k] >= 0.
    """
    p0 = corners2d
    p1 = corners2d[:, [1, 2, 0]]
    e = p1 - p0
    orient = np.sign(orient2d(p0[:, 0], p0[:, 1], p0[:, 2]))[:, None]       # +1 counter-clockwise
    nrm = np.stack([-e[..., 1], e[..., 0]], axis=2) * orient[..., None]
    ln = np.linalg.norm(nrm, axis=2, keepdims=True)
    nrm = nrm / np.where(ln > 0, ln, 1.0)
    off = np.sum(nrm * p0, axis=2)
    return nrm, off


def clip_squares(lo: np.ndarray, size: float, normals: np.ndarray,
                 offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Clip axis-aligned squares [lo, lo + size] by 3 half-planes each (Sutherland-Hodgman).

    lo (K, 2); normals (K, 3, 2); offsets (K, 3).  Returns polygons (K, MAX_POLY, 2) and vertex
    counts (K,).  Vectorised: every polygon keeps a fixed-size buffer, compacted after each clip.
    """
    k = len(lo)
    poly = np.zeros((k, MAX_POLY, 2))
    sq = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float) * size
    poly[:, :4] = lo[:, None, :] + sq
    cnt = np.full(k, 4, np.int64)
    slot = np.arange(MAX_POLY)
    for e in range(3):
        n = normals[:, e][:, None, :]
        d = np.sum(poly * n, axis=2) - offsets[:, e][:, None]          # (K, MAX_POLY)
        valid = slot[None, :] < cnt[:, None]
        nxt = np.where(slot[None, :] + 1 < cnt[:, None], slot[None, :] + 1, 0)
        pn = np.take_along_axis(poly, nxt[..., None], axis=1)
        dn = np.take_along_axis(d, nxt, axis=1)
        ins, insn = d >= 0, dn >= 0
        cross = valid & (ins != insn)
        with np.errstate(invalid="ignore", divide="ignore"):
            t = np.where(cross, d / np.where(cross, d - dn, 1.0), 0.0)
        ip = poly + t[..., None] * (pn - poly)
        cand = np.empty((k, 2 * MAX_POLY, 2))
        cand[:, 0::2], cand[:, 1::2] = poly, ip
        keep = np.empty((k, 2 * MAX_POLY), bool)
        keep[:, 0::2], keep[:, 1::2] = valid & ins, cross
        order = np.argsort(~keep, axis=1, kind="stable")[:, :MAX_POLY]
        poly = np.take_along_axis(cand, order[..., None], axis=1)
        cnt = keep.sum(axis=1)
    poly[slot[None, :] >= cnt[:, None]] = 0.0
    return poly, cnt


def polygon_areas(poly: np.ndarray, cnt: np.ndarray) -> np.ndarray:
    """Shoelace areas (absolute) of buffered polygons."""
    slot = np.arange(poly.shape[1])
    nxt = np.where(slot[None, :] + 1 < cnt[:, None], slot[None, :] + 1, 0)
    pn = np.take_along_axis(poly, nxt[..., None], axis=1)
    valid = slot[None, :] < cnt[:, None]
    cr = poly[..., 0] * pn[..., 1] - pn[..., 0] * poly[..., 1]
    return 0.5 * np.abs(np.sum(np.where(valid, cr, 0.0), axis=1))


@dataclass(frozen=True)
class CellLayout:
    """Active cells of every triangle grid, plus the flat lookup (face, i, j) -> cell id."""

    size: float
    frames: FaceFrames
    nx: np.ndarray          # (m,) grid columns per face (0 for degenerate faces)
    ny: np.ndarray          # (m,) grid rows
    grid_offset: np.ndarray  # (m + 1,) start of each face's block in ``lookup``
    lookup: np.ndarray      # (sum nx*ny,) cell id or -1 (OUT); index = offset + i*ny + j
    face: np.ndarray        # (n,) owning triangle
    ij: np.ndarray          # (n, 2) column i (x), row j (y)
    comp_in: np.ndarray     # (n,) True = COMP-IN (centre inside), False = PART-IN
    area: np.ndarray        # (n,) clipped area
    center2d: np.ndarray    # (n, 2)
    center3d: np.ndarray    # (n, 3)

    @property
    def n_cells(self) -> int:
        return len(self.face)

    def cell_at(self, face: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        """Cell ids at grid positions (-1 outside the grid or OUT)."""
        ok = (i >= 0) & (j >= 0) & (i < self.nx[face]) & (j < self.ny[face])
        idx = self.grid_offset[face] + np.where(ok, i, 0) * self.ny[face] + np.where(ok, j, 0)
        return np.where(ok, self.lookup[np.minimum(idx, max(len(self.lookup) - 1, 0))], -1)

    def cell_polygons(self, cells: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Clipped 2-D polygons (k, MAX_POLY, 2) and vertex counts of ``cells`` (default all)."""
        c = np.arange(self.n_cells) if cells is None else np.asarray(cells)
        nrm, off = edge_half_planes(self.frames.corners2d)
        lo = self.ij[c] * self.size
        return clip_squares(lo.astype(float), self.size, nrm[self.face[c]], off[self.face[c]])


def _grid_dims(frames: FaceFrames, s: float) -> tuple[np.ndarray, np.ndarray]:
    c2 = frames.corners2d
    w = c2[..., 0].max(axis=1)
    h = c2[..., 1].max(axis=1)
    nx = np.where(frames.valid, np.maximum(np.ceil(w / s - 1e-9), 1), 0).astype(np.int64)
    ny = np.where(frames.valid, np.maximum(np.ceil(h / s - 1e-9), 1), 0).astype(np.int64)
    return nx, ny


BYTES_PER_CANDIDATE = 900   # clip buffers (2 x 16 x 2 floats and friends) per candidate cell
BYTES_PER_CELL = 260        # finished domain: cell arrays, lookup, 8-entry CSR graph, normals


def build_cells(vertices: np.ndarray, faces: np.ndarray, size: float, *, frame: str = "thesis",
                max_cells: int = 20_000_000, chunk: int = 400_000) -> CellLayout:
    """Build every active cell of every (non-degenerate) triangle for cell size ``size``.

    Refuses (InputError, before allocating) when the candidate count would exceed ``max_cells``.
    """
    if not np.isfinite(size) or size <= 0:
        raise InputError(f"cell size must be a positive number, got {size}")
    frames = face_frames(vertices, faces, frame)
    nx, ny = _grid_dims(frames, size)
    n_cand = int(np.sum(nx * ny))
    from procgen.recipes import memory_limit_bytes
    need = n_cand * BYTES_PER_CELL + min(n_cand, chunk) * BYTES_PER_CANDIDATE
    if need > memory_limit_bytes():
        raise InputError(
            f"cell size {size:g} needs about {n_cand:,} candidate cells, ~{need / 1e9:.1f} GB, "
            f"more than this machine's {memory_limit_bytes() / 1e9:.1f} GB budget; use a larger cell size")
    if n_cand > max_cells:
        raise InputError(
            f"cell size {size:g} needs about {n_cand:,} candidate cells "
            f"(~{n_cand * BYTES_PER_CANDIDATE / 1e9:.1f} GB while building), over max_cells="
            f"{max_cells:,}; use a larger cell size or a smaller target count")
    offset = np.concatenate([[0], np.cumsum(nx * ny)])
    nrm, off = edge_half_planes(frames.corners2d)
    lookup = np.full(n_cand, -1, np.int64)
    parts: list[tuple[np.ndarray, ...]] = []
    counts = nx * ny
    face_of_all = np.repeat(np.arange(len(faces)), counts)
    for start in range(0, n_cand, chunk):           # chunks bound peak memory, not a per-cell loop
        g = np.arange(start, min(start + chunk, n_cand))
        f = face_of_all[g]
        local = g - offset[f]
        i, j = local // ny[f], local % ny[f]
        lo = np.column_stack([i, j]).astype(float) * size
        # corner tests first: squares wholly inside need no clip, squares wholly outside one
        # edge's half-plane have no area; only the rest (the triangle's border) is clipped
        corner = lo[:, None, :] + np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float) * size
        d = np.einsum("nkd,ncd->nkc", nrm[f], corner) - off[f][:, :, None]      # (K, 3, 4)
        inside = np.all(d >= 0, axis=(1, 2))
        outside = np.any(np.all(d <= 0, axis=2), axis=1)
        area = np.where(inside, size * size, 0.0)
        edge = ~inside & ~outside
        if edge.any():
            poly, cnt = clip_squares(lo[edge], size, nrm[f[edge]], off[f[edge]])
            area[edge] = polygon_areas(poly, cnt)
        act = area > 1e-9 * size * size
        g, f, i, j, area = g[act], f[act], i[act], j[act], area[act]
        ctr = (np.column_stack([i, j]) + 0.5) * size
        inside = np.all(np.einsum("nkd,nd->nk", nrm[f], ctr) - off[f] >= 0, axis=1)
        parts.append((g, f, i, j, area, ctr, inside))
    if parts:
        g, f, i, j, area, ctr, inside = (np.concatenate(x) for x in zip(*parts))
    else:
        g = f = i = j = np.zeros(0, np.int64)
        area, ctr, inside = np.zeros(0), np.zeros((0, 2)), np.zeros(0, bool)
    lookup[g] = np.arange(len(g))
    c3 = frames.to_3d(f, ctr) if len(f) else np.zeros((0, 3))
    return CellLayout(size=float(size), frames=frames, nx=nx, ny=ny, grid_offset=offset,
                      lookup=lookup, face=f, ij=np.column_stack([i, j]).astype(np.int64),
                      comp_in=inside, area=area, center2d=ctr, center3d=c3)


def triangle_metrics(vertices: np.ndarray, faces: np.ndarray) -> dict[str, np.ndarray]:
    """Side lengths (m, 3), heights (m, 3), areas (m,) and the degenerate mask of each triangle."""
    p = vertices[faces]
    sides = np.linalg.norm(p[:, [1, 2, 0]] - p, axis=2)
    area = 0.5 * np.linalg.norm(triangle_cross(vertices, faces), axis=1)
    with np.errstate(divide="ignore", invalid="ignore"):
        heights = np.where(sides > 0, 2 * area[:, None] / np.where(sides > 0, sides, 1), 0.0)
    longest = sides.max(axis=1)
    degenerate = ~(2 * area > DEGENERATE_RATIO * longest ** 2) | (longest <= 0)
    return {"sides": sides, "heights": heights, "area": area, "degenerate": degenerate}


def choose_cell_size(vertices: np.ndarray, faces: np.ndarray, *, cell_size: float | None = None,
                     target_cells: int | None = None, k: float | None = None) -> float:
    """The common cell size: explicit, from a target cell count, or min(side, height) / k.

    Exactly one of the three must be given.  Checks the size against the mesh extent.
    """
    given = [x is not None for x in (cell_size, target_cells, k)]
    if sum(given) != 1:
        raise InputError("give exactly one of cell_size, target_cells, k for the cell size")
    met = triangle_metrics(vertices, faces)
    ok = ~met["degenerate"]
    if not ok.any():
        raise InputError("mesh has no non-degenerate triangle to put cells on")
    if cell_size is not None:
        s = float(cell_size)
    elif target_cells is not None:
        if target_cells < 1:
            raise InputError(f"target_cells must be >= 1, got {target_cells}")
        s = float(np.sqrt(met["area"][ok].sum() / target_cells))
        # boundary (PART-IN) cells add O(perimeter / s): one fixed-point correction
        perim = met["sides"][ok].sum()
        for _ in range(3):
            est = met["area"][ok].sum() / s ** 2 + 0.5 * perim / s
            s *= np.sqrt(est / target_cells)
    else:
        if k <= 0:
            raise InputError(f"k must be > 0, got {k}")
        s = float(min(met["sides"][ok].min(), met["heights"][ok].min()) / k)
    extent = float(np.linalg.norm(vertices.max(axis=0) - vertices.min(axis=0)))
    if not np.isfinite(s) or s <= 0:
        raise InputError(f"cell size must be a positive number, got {s}")
    if s > extent:
        raise InputError(f"cell size {s:g} is larger than the mesh (bounding-box diagonal {extent:g})")
    return s
