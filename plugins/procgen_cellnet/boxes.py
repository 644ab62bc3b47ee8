"""The boundless sparse box index of a cellular network (the paper's DDST, section 4.2, Figure 4).

"Generating Surface Textures based on Cellular Networks" (GMAI 2006) stores its free cells in
cubic boxes of side ``bs = kb * cs``: only non-empty boxes exist, box indices are unbounded
integer triples (Figure 4 names A(5,5,0), B(5,5,-4), C(5,5,-7)), and a cell is compared only
with the cells of its own box and the 26 around it (Figure 3).  The paper keeps the boxes in
sorted doubly-linked lists, x first, then y per x node, then z per (x, y) node.  Here the same
three sorted levels are flat arrays: the distinct x indices, the distinct (x, y) columns and
the boxes, each sorted, with a CSR from box to cells.  Looking a box up is one ``searchsorted``
of keys packed into an int64 when the occupied block fits (it keeps the (x, y, z) order), else a
walk down the three levels with ranks only (never overflows), and moving cells re-files only the
cells whose box changed, creating and freeing boxes as needed.  The README says why these
sorted arrays are the paper's linked lists in another form.

The 27-box search finds every partner within ``bs`` only.  The paper allows kb = 1, but every
link radius r_i is larger than cs (section 4.3), so a partner can sit two boxes away: the
linker refuses ``bs < r_i`` (:func:`check_stencil`).

Without numba the search runs as a column sweep (:func:`_column_sweep`): the three boxes of a
box column are one run sorted along the column, so a cell's partners in it are a
``searchsorted`` window; it gives cKDTree's links at about cKDTree's speed
(benchmarks/cellnet.py prints both).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property
from itertools import product

import numpy as np

from procgen import InputError
from procgen.accel import MIN_CELLS, kernels

#: the 27 box offsets of the stencil, (0, 0, 0) first
STENCIL = np.array([(0, 0, 0)] + [o for o in product((-1, 0, 1), repeat=3) if o != (0, 0, 0)],
                   np.int64)
#: the 13 offsets after (0, 0, 0) in lexicographic order: each box pair is visited once
HALF_STENCIL = STENCIL[1:][[tuple(o) > (0, 0, 0) for o in STENCIL[1:]]]


def unique_rows(a: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(sorted unique rows, first index of each, row of every input) of an integer array.

    One stable sort of the rows packed into an int64 when their bounding block fits (else a
    lexsort): much faster than ``np.unique(axis=0)`` on millions of rows.
    """
    a = np.asarray(a)
    order, first = _row_order(a)
    inverse = np.empty(len(a), np.int64)
    inverse[order] = np.cumsum(first) - 1
    return a[order[first]], order[first], inverse


def _row_order(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(stable order sorting the rows, whether each sorted row starts a run of equal rows)."""
    if len(a) == 0:
        return np.zeros(0, np.int64), np.zeros(0, bool)
    lo = a.min(axis=0)
    span = [int(s) for s in a.max(axis=0) - lo + 1]
    first = np.ones(len(a), bool)
    if math.prod(span) < 2 ** 62:
        key = np.zeros(len(a), np.int64)
        for c, s in enumerate(span):
            key = key * s + (a[:, c] - lo[c])
        if math.prod(span) * len(a) < 2 ** 62:
            # row then position in one int64: a plain sort of the values is the stable order
            sk, order = np.divmod(np.sort(key * len(a) + np.arange(len(a))), len(a))
        else:
            order = np.argsort(key, kind="stable")
            sk = key[order]
        first[1:] = sk[1:] != sk[:-1]
    else:
        order = np.lexsort(a.T[::-1])
        sa = a[order]
        first[1:] = np.any(sa[1:] != sa[:-1], axis=1)
    return order, first


def box_keys(points: np.ndarray, size: float) -> np.ndarray:
    """Integer box index (floor(p / bs)) of every point; negative indices are ordinary."""
    return np.floor(np.asarray(points, float) / size).astype(np.int64)


def _find(sorted_values: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """Position of each query in a sorted 1-D array, -1 where absent."""
    if len(sorted_values) == 0:
        return np.full(len(queries), -1, np.int64)
    pos = np.searchsorted(sorted_values, queries)
    hit = pos < len(sorted_values)
    hit[hit] = sorted_values[pos[hit]] == queries[hit]
    return np.where(hit, pos, -1)


@dataclass(frozen=True, eq=False)
class BoxIndex:
    """Non-empty boxes of side ``size`` (sorted x, then y, then z) and the cells each holds."""

    size: float
    keys: np.ndarray        # (B, 3) int64 box indices, lexicographically sorted
    start: np.ndarray       # (B + 1,) CSR into ``order``
    order: np.ndarray       # (n,) cell ids, box after box, ascending inside a box
    cell_box: np.ndarray    # (n,) box of every cell

    @classmethod
    def build(cls, points: np.ndarray, size: float) -> "BoxIndex":
        if not size > 0:
            raise InputError(f"box index: box side must be > 0, got {size}")
        return cls.from_keys(box_keys(points, size), size)

    @classmethod
    def from_keys(cls, cell_keys: np.ndarray, size: float) -> "BoxIndex":
        a = cell_keys.reshape(-1, 3)
        order, first = _row_order(a)            # the stable sort is also the cells' order
        cell_box = np.empty(len(a), np.int64)
        cell_box[order] = np.cumsum(first) - 1
        return cls.assemble(size, a[order[first]], cell_box, order)

    @classmethod
    def assemble(cls, size: float, keys: np.ndarray, cell_box: np.ndarray,
                 order: np.ndarray | None = None) -> "BoxIndex":
        """Index from sorted box keys and every cell's box (cells ascending inside a box;
        ``order``, if given, is already the cells sorted so)."""
        cell_box = np.asarray(cell_box, np.int64)
        if order is None:
            order = np.argsort(cell_box, kind="stable")
        start = np.concatenate([[0], np.cumsum(np.bincount(cell_box, minlength=len(keys)))])
        return cls(float(size), np.asarray(keys, np.int64).reshape(-1, 3), start.astype(np.int64),
                   order.astype(np.int64), cell_box)

    # -- the three sorted levels (x list, (x, y) columns, boxes) -------------------------
    @property
    def n_boxes(self) -> int:
        return len(self.keys)

    @cached_property
    def x_nodes(self) -> np.ndarray:
        """Distinct x indices (the DDST's x list)."""
        return np.unique(self.keys[:, 0])

    @cached_property
    def _ranks(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        uy, uz = np.unique(self.keys[:, 1]), np.unique(self.keys[:, 2])
        rx = np.searchsorted(self.x_nodes, self.keys[:, 0])
        ry = np.searchsorted(uy, self.keys[:, 1])
        col = rx * len(uy) + ry
        columns = np.unique(col)
        full = np.searchsorted(columns, col) * len(uz) + np.searchsorted(uz, self.keys[:, 2])
        return uy, uz, columns, full

    @property
    def n_columns(self) -> int:
        """Distinct (x, y) columns (the DDST's y-list nodes)."""
        return len(self._ranks[2])

    @cached_property
    def _packed(self) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """(lowest key - 1, span, packed keys) when the keys' bounding block (one box of margin
        each side) packs into one int64, else None.  Packing is row-major, so the packed keys
        keep the lexicographic order: a lookup is then one ``searchsorted``."""
        if self.n_boxes == 0:
            return None
        lo = self.keys.min(axis=0) - 1
        span = self.keys.max(axis=0) - lo + 2
        if math.prod(int(s) for s in span) >= 2 ** 62:
            return None
        return lo, span, self._pack(self.keys, lo, span)

    @staticmethod
    def _pack(q: np.ndarray, lo: np.ndarray, span: np.ndarray) -> np.ndarray:
        r = q - lo
        return (r[:, 0] * span[1] + r[:, 1]) * span[2] + r[:, 2]

    def lookup(self, queries: np.ndarray) -> np.ndarray:
        """Box id of each (q, 3) integer box index, -1 where that box does not exist.

        Through the packed keys when they fit in an int64 (any scene whose box extent is not
        astronomically large, wherever it sits), else by walking the three sorted levels
        (ranks only: never overflows).  Both give the same ids (tested).
        """
        q = np.asarray(queries, np.int64).reshape(-1, 3)
        packed = self._packed
        if packed is not None:
            lo, span, keys = packed
            r = q - lo
            inside = (r[:, 0] >= 0) & (r[:, 1] >= 0) & (r[:, 2] >= 0)
            inside &= (r[:, 0] < span[0]) & (r[:, 1] < span[1]) & (r[:, 2] < span[2])
            return np.where(inside, _find(keys, np.where(inside, self._pack(q, lo, span), -1)), -1)
        return self._walk(q)

    def _walk(self, q: np.ndarray) -> np.ndarray:
        """:meth:`lookup` by the x -> (x, y) -> (x, y, z) levels."""
        uy, uz, columns, full = self._ranks
        rx, ry, rz = _find(self.x_nodes, q[:, 0]), _find(uy, q[:, 1]), _find(uz, q[:, 2])
        ok = (rx >= 0) & (ry >= 0) & (rz >= 0)
        rc = _find(columns, np.where(ok, rx * len(uy) + ry, -1))
        ok &= rc >= 0
        return np.where(ok, _find(full, np.where(ok, rc * len(uz) + rz, -1)), -1)

    def cells_of(self, box: int) -> np.ndarray:
        return self.order[self.start[box]:self.start[box + 1]]

    @property
    def counts(self) -> np.ndarray:
        return np.diff(self.start)

    # -- dynamic update -------------------------------------------------------------------
    def moved(self, points: np.ndarray) -> "BoxIndex":
        """The index after cells moved to ``points``: only cells that changed box are re-filed.

        Boxes a move empties are freed and boxes it enters are created (section 4.2: "new
        boxes are easily added"); the result equals :meth:`build` on the new points (tested).
        """
        new_keys = box_keys(points, self.size)
        movers = np.nonzero(np.any(new_keys != self.keys[self.cell_box], axis=1))[0]
        if len(movers) == 0:
            return self
        stay = np.ones(len(self.cell_box), bool)
        stay[movers] = False
        occupied = np.bincount(self.cell_box[stay], minlength=self.n_boxes) > 0
        mk = new_keys[movers]
        keys = unique_rows(np.concatenate([self.keys[occupied], mk]))[0]
        skeleton = BoxIndex(self.size, keys, np.zeros(1, np.int64), np.zeros(0, np.int64),
                            np.zeros(0, np.int64))
        renumber = np.full(self.n_boxes, -1, np.int64)
        renumber[occupied] = skeleton.lookup(self.keys[occupied])
        cell_box = renumber[self.cell_box]
        cell_box[movers] = skeleton.lookup(mk)
        return BoxIndex.assemble(self.size, keys, cell_box)

    # -- the 27-box search ----------------------------------------------------------------
    def neighbour_boxes(self, box: int) -> np.ndarray:
        """Ids of the existing boxes among the 27 around ``box`` (itself first)."""
        ids = self.lookup(self.keys[box] + STENCIL)
        return ids[ids >= 0]

    def dump(self) -> str:
        """The x -> y -> z lists as text (Figure 4): one line per x node."""
        lines = []
        for x in self.x_nodes:
            rows = self.keys[self.keys[:, 0] == x]
            ys = []
            for y in np.unique(rows[:, 1]):
                zs = rows[rows[:, 1] == y, 2]
                ys.append(f"Y[{y}]: " + " <-> ".join(f"Z[{z}]" for z in zs))
            lines.append(f"X[{x}] -> " + " | ".join(ys))
        return "\n".join(lines)


def check_stencil(radius: float, size: float, cs: float, where: str = "cellnet.link") -> None:
    """Refuse a box smaller than the link radius: the 27-box stencil would miss links."""
    if size < radius:
        raise InputError(f"{where}: box side {size:g} (kb = {size / cs:g}) is smaller than the link "
                         f"radius {radius:g}; the 27-box search would miss links "
                         f"(use kb >= {math.ceil(radius / cs - 1e-12)})")


def _near(points: np.ndarray, i: np.ndarray, j: np.ndarray, radius: float) -> np.ndarray:
    """``|p_i - p_j| < radius`` for each pair, one expression shared by every linker.

    ``points`` is (n, 3) or its three coordinate columns; see :func:`_within`.
    """
    cols = points if isinstance(points, tuple) else tuple(np.ascontiguousarray(points[:, k])
                                                          for k in range(3))
    return _within([c[i] for c in cols], [c[j] for c in cols], radius)


def _within(pi: list[np.ndarray], pj: list[np.ndarray], radius: float) -> np.ndarray:
    """``|p_i - p_j| < radius`` from the coordinate columns of both ends: dx^2 + dy^2 + dz^2 in
    that order and one comparison against radius^2, so the box search, cKDTree and brute force
    agree bit for bit on pairs at exactly the radius."""
    d2 = None
    for a, b in zip(pi, pj):
        d = a - b
        d *= d
        if d2 is None:
            d2 = d                      # 0 + dx^2 is dx^2 exactly
        else:
            d2 += d
    return d2 < radius * radius


def pairs_within(points: np.ndarray, radius: float, index: BoxIndex,
                 guard: bool = True, accelerate: bool | None = None) -> np.ndarray:
    """All cell pairs (i < j) closer than ``radius``, from the 27-box search of ``index``.

    ``guard=False`` runs the stencil even when boxes are smaller than the radius, which shows
    the links kb = 1 loses (paper section 4, the stencil flaw).  ``accelerate`` selects the
    compiled walk of the same boxes (``boxes_kernels``; same links, tested), by default from
    ``MIN_CELLS`` cells when numba is installed (:func:`procgen.accel.kernels`); else
    :func:`_column_sweep` searches the same 27 boxes with numpy.
    """
    if guard and index.size < radius:
        raise InputError(f"box search: box side {index.size:g} < link radius {radius:g} "
                         "would miss links")
    order, start = index.order, index.start
    packed = index._packed
    kern = kernels("procgen_cellnet.boxes_kernels", accelerate, len(order), MIN_CELLS)
    if kern is not None and packed is not None:
        lo, span, keys = packed
        offsets = np.array([(o[0] * span[1] + o[1]) * span[2] + o[2] for o in HALF_STENCIL], np.int64)
        cols = tuple(np.ascontiguousarray(np.asarray(points, float)[order, k]) for k in range(3))
        return kern.pairs_within(keys, offsets, start, order, cols, radius)
    return _column_sweep(np.asarray(points, float), radius, index)


#: the (o1, o2) offsets of the four neighbour columns after a column: each column pair once
FORWARD_COLUMNS = np.array([(0, 1, 0), (1, -1, 0), (1, 0, 0), (1, 1, 0)], np.int64)


def _column_sweep(points: np.ndarray, radius: float, index: BoxIndex) -> np.ndarray:
    """The 27-box search as sorted runs: the links of :func:`pairs_within` with numpy only.

    The three boxes of a cell's box column along one axis (the scene's longest, the sweep
    axis) are one run once the column's cells are sorted by that coordinate (floor(s / bs) is
    monotone in s), and the partners of a cell in it lie in the window |s_j - s_i| < r of that
    run: two ``searchsorted``.  So every cell is matched against its own column's cells ahead
    of it within r and against the window of each of the four forward neighbour columns it
    comes within r of - the 27 boxes, each pair once, cut to a slab 2r thick along the sweep
    axis instead of 3 boxes.  The sort key is (column rank * stride + s - column start) in
    float; windows are padded by its rounding, so they only ever hold more candidates, and the
    exact test is ``_within``.  Boxes smaller than the radius (``guard=False``) keep only
    partners at most one box away along the sweep axis too, which is what the 27 boxes hold.

    No candidate list is built: the windows are walked k-th cell after k-th cell, all windows
    at once, longest windows first (so the windows still open are a prefix), which bounds the
    memory by the number of windows (at most five per cell).
    """
    size = index.size
    n = len(points)
    if n == 0:
        return np.zeros((0, 2), np.int64)
    bk = index.keys
    ax = int(np.argmax(np.ptp(bk, axis=0)))
    o1, o2 = [k for k in range(3) if k != ax]
    columns = BoxIndex.from_keys(np.column_stack([bk[:, o1], bk[:, o2], np.zeros(len(bk), np.int64)]),
                                 size)
    first = np.minimum.reduceat(bk[columns.order, ax], columns.start[:-1])
    last = np.maximum.reduceat(bk[columns.order, ax], columns.start[:-1])
    stride = float(np.max(last - first) + 1) * size + 4 * radius
    base = first * size                                 # each column's lowest box face
    col = columns.cell_box[index.cell_box]
    s = points[:, ax]
    key = col * stride + (s - base[col])
    order = np.argsort(key)             # ties in any order: windows go by value
    sk = key[order]
    cols = tuple(np.ascontiguousarray(points[order, k]) for k in range(3))
    pad = 1e-9 * size + 16 * float(np.spacing(max(np.abs(sk).max(), np.abs(s).max(), stride)))
    reach = radius + pad
    # own column: the cells after i in sort order up to s_i + r
    rows, lo = [np.arange(n)], [np.arange(1, n + 1)]
    hi = [np.searchsorted(sk, sk + reach, side="right")]
    # forward neighbour columns the cell comes within r of (its box's padded cross-section);
    # a column's cells are one run of the sort order
    per_col = np.bincount(col, minlength=columns.n_boxes)
    col_first = np.cumsum(per_col) - per_col
    for off in FORWARD_COLUMNS:
        nb = columns.lookup(columns.keys + off)
        have = np.nonzero(nb >= 0)[0]
        cnt = per_col[have]
        i = np.repeat(col_first[have] - (np.cumsum(cnt) - cnt), cnt) + np.arange(cnt.sum())
        own = np.repeat(have, cnt)
        gap2 = np.zeros(len(i))
        for d, c, k in ((off[0], cols[o1][i], columns.keys[own, 0]),
                        (off[1], cols[o2][i], columns.keys[own, 1])):
            if d > 0:
                gap2 += np.maximum((k + 1) * size - pad - c, 0.0) ** 2
            elif d < 0:
                gap2 += np.maximum(c - k * size - pad, 0.0) ** 2
        near = gap2 < reach * reach
        i = i[near]
        # a partner that far across lies within sqrt(r^2 - gap^2) along the sweep axis
        half = np.sqrt(reach * reach - gap2[near]) + pad
        c = nb[own[near]]
        at = c * stride + (cols[ax][i] - base[c])
        rows.append(i)
        lo.append(np.searchsorted(sk, at - half, side="left"))
        hi.append(np.searchsorted(sk, at + half, side="right"))
    rows, lo = np.concatenate(rows), np.concatenate(lo)
    count = np.concatenate(hi) - lo
    # longest first; windows hold a few dozen cells at most (cells are >= ~cs apart), so the
    # short integer sort is a radix sort
    short = np.int16 if len(count) == 0 or count.max() < 2 ** 15 else np.int64
    longest = np.argsort((count.max(initial=0) - count).astype(short), kind="stable")
    longest = longest[count[longest] > 0]
    if len(longest) == 0:
        return np.zeros((0, 2), np.int64)
    rows, lo, count = rows[longest], lo[longest], count[longest]
    open_at = np.searchsorted(-count, -np.arange(1, count[0] + 1), side="right")
    ci_cols = [c[rows] for c in cols]
    out_i, out_j = [], []
    for k, m in enumerate(open_at):     # the k-th cell of every window still open
        j = lo[:m] + k
        hit = np.nonzero(_within([c[:m] for c in ci_cols], [c[j] for c in cols], radius))[0]
        out_i.append(rows[hit])
        out_j.append(j[hit])
    ci, cj = order[np.concatenate(out_i)], order[np.concatenate(out_j)]
    if size < radius:                   # the stencil's reach along the sweep axis: one box
        ka = index.keys[index.cell_box, ax]
        ok = np.abs(ka[ci] - ka[cj]) <= 1
        ci, cj = ci[ok], cj[ok]
    # each pair was met once and never with itself: sorting the keys is canonical_links
    return _rows(np.sort(np.minimum(ci, cj) * n + np.maximum(ci, cj)), n)


def canonical_links(pairs: np.ndarray) -> np.ndarray:
    """Links as (m, 2) int64 rows i < j, sorted, without duplicates."""
    p = np.asarray(pairs, np.int64).reshape(-1, 2)
    lo, hi = np.minimum(p[:, 0], p[:, 1]), np.maximum(p[:, 0], p[:, 1])
    if len(p) == 0 or not np.any(lo != hi):
        return np.zeros((0, 2), np.int64)
    n = int(hi.max()) + 1
    key = np.sort(lo[lo != hi] * n + hi[lo != hi])      # one int64 per pair: sorts as (i, j)
    return _rows(key[np.concatenate([[True], key[1:] != key[:-1]])], n)


def _rows(key: np.ndarray, n: int) -> np.ndarray:
    """(m, 2) rows (key // n, key % n) of sorted pair keys i * n + j."""
    out = np.empty((len(key), 2), np.int64)
    np.divmod(key, n, out=(out[:, 0], out[:, 1]))
    return out


def pairs_kdtree(points: np.ndarray, radius: float) -> np.ndarray:
    """The same link set from scipy's cKDTree (candidates within a hair more, then ``< r``)."""
    from scipy.spatial import cKDTree

    tree = cKDTree(points, balanced_tree=False, compact_nodes=False)    # its fastest build
    cand = tree.query_pairs(radius * (1 + 1e-9), output_type="ndarray")
    cand = cand.astype(np.int64).reshape(-1, 2)
    return canonical_links(cand[_near(points, cand[:, 0], cand[:, 1], radius)])


#: largest cell count the brute-force linker accepts (n^2 / 2 distances)
BRUTE_MAX = 20_000


def pairs_brute(points: np.ndarray, radius: float) -> np.ndarray:
    """The same link set by testing every pair (reference for small networks)."""
    n = len(points)
    if n > BRUTE_MAX:
        raise InputError(f"cellnet.link: method 'brute' tests every pair; {n} cells is more than "
                         f"{BRUTE_MAX}")
    i, j = np.triu_indices(n, 1)
    near = _near(points, i, j, radius)
    return canonical_links(np.column_stack([i[near], j[near]]))
