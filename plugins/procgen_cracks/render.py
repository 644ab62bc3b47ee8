"""Anti-aliased multi-thickness linked segments on micro-cells (3DSCA thesis 5.2.5.a, App. B 2).

A crack is finer than a cell, so the thesis subdivides every cracked cell into k x k micro-cells
and gives each one a "crack coverage" in [0, 1] (Figure 5.14, Table 5.2, plate 5.4).  Across the
crack the intensity follows a width profile f(x) (x = distance from the path, C_t = crack width,
C_s = micro-cell side).  App. B 2.2.2 normalises every profile so that the central micro-cell is
fully covered, int_0^{C_s/2} f = 1/2 ("V" types) or int_d^{d+C_s/2} f = 1/2 ("U" types, which
saturate at 1/C_s over the central half-width d = (C_t/2) C%):

    V linear       f = k (C_t/2 - x)        k = 2 / (C_s (C_t - C_s/2))
    V parabolic A  f = k (C_t^2/4 - x^2)    k = 4 / (C_s (C_t^2 - C_s^2/3))
    V parabolic B  f = k (x - C_t/2)^2      k = 4 / (C_s (C_t^2 - C_t C_s + C_s^2/3))
    U linear       f = k (C_t/2 - x)        k = 1 / (C_s (C_t/2 - C_s/4 - d))
    U parabolic A  f = k (C_t^2/4 - x^2)    k = 1 / (C_s (C_t^2/4 - C_s^2/12 - d (d + C_s/2)))
    U parabolic B  f = k (x - C_t/2)^2      k = 1 / (C_s ((C_s^2/3 + C_t^2 - C_s C_t)/4 + d (d + C_s/2 - C_t)))

(the last constant's printed "+ C_s C_t" contradicts the integral; the "-" sign is the one that
satisfies it, which tests/test_crack_render.py checks for all six).  The "constant" profile is
f = 1/C_s inside the band: the micro-cell value is then exactly the area fraction it shares with
a band of width C_t.  A V or U normalisation needs the profile to span the central micro-cell
(C_t >= C_s, resp. C_t (1 - C%) >= C_s); thinner cracks use the constant profile, which is the
exact area fraction of a hairline.

The thesis approximates the coverage double integral by the clipped lengths of l offset lines
(sum of f(X_i) dx dl / C_s).  Here the same integral, (1/C_s) \\iint_cell f(dist) dA, is evaluated
exactly for a straight segment: the micro-cell's chord length at normal offset t is a trapezoid,
f is piecewise polynomial, so a 3-point Gauss-Legendre rule per piece between the breakpoints is
exact.  Everything is numpy over the (segment piece, micro-cell) pairs within reach: per piece
and micro-cell row, the columns inside the piece's capsule (not its bounding box); several pieces
over one micro-cell combine by their maximum.  A crack many cells wide overlaps itself over several pieces
(each piece's round ends reach far past it), so a pair is only integrated when a cheap upper
bound of its coverage (:func:`coverage_bound`) reaches the micro-cell's current value: the
result is the same maximum, bit for bit.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from procgen.accel import MIN_MICRO_PAIRS, kernels
from procgen.errors import InputError
from procgen.geometry import orient2d as geo_orient

PROFILES = ("constant", "v_linear", "v_parabolic_a", "v_parabolic_b",
            "u_linear", "u_parabolic_a", "u_parabolic_b")

_GL_X = np.array([-np.sqrt(0.6), 0.0, np.sqrt(0.6)])
_GL_W = np.array([5.0, 8.0, 5.0]) / 9.0
_PAIR_CHUNK = 200_000            # (piece, micro-cell) pairs scanned at once
_EVAL_CHUNK = 8_192              # pairs integrated at once (temporaries stay in cache)


def _check_profile(profile: str) -> None:
    if profile not in PROFILES:
        raise InputError(f"crack profile must be one of {', '.join(PROFILES)}; got {profile!r}")


def profile_constants(ct: np.ndarray, cs: float, profile: str,
                      saturation: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(k, d, constant) per crack width: App. B 2.2.2 constant, U half-width, fallback mask."""
    _check_profile(profile)
    ct = np.asarray(ct, dtype=float)
    u = profile.startswith("u_")
    d = 0.5 * ct * saturation if u else np.zeros_like(ct)
    usable = (ct * (1.0 - saturation) >= cs) if u else (ct >= cs)
    constant = ~usable | (profile == "constant")
    if profile in ("constant",):
        den = np.ones_like(ct) * cs
    elif profile == "v_linear":
        den = 0.5 * cs * (ct - 0.5 * cs)
    elif profile == "v_parabolic_a":
        den = 0.25 * cs * (ct ** 2 - cs ** 2 / 3.0)
    elif profile == "v_parabolic_b":
        den = 0.25 * cs * (ct ** 2 - ct * cs + cs ** 2 / 3.0)
    elif profile == "u_linear":
        den = cs * (0.5 * ct - 0.25 * cs - d)
    elif profile == "u_parabolic_a":
        den = cs * (0.25 * ct ** 2 - cs ** 2 / 12.0 - d * (d + 0.5 * cs))
    else:
        den = cs * (0.25 * (cs ** 2 / 3.0 + ct ** 2 - cs * ct) + d * (d + 0.5 * cs - ct))
    k = np.where(constant, 1.0 / cs, 1.0 / np.where(constant, 1.0, den))
    return k, np.where(constant, 0.0, d), constant


def profile_density(x: np.ndarray, ct: np.ndarray, cs: float, profile: str,
                    saturation: float = 0.5) -> np.ndarray:
    """f(|x|) per unit width (1/length) at distance ``x`` from the path of a crack ``ct`` wide."""
    x = np.abs(np.asarray(x, dtype=float))
    ct = np.broadcast_to(np.asarray(ct, dtype=float), x.shape)
    return _density(x, ct, *profile_constants(ct, cs, profile, saturation), cs, profile)


def _density(x: np.ndarray, ct: np.ndarray, k: np.ndarray, d: np.ndarray, constant: np.ndarray,
             cs: float, profile: str) -> np.ndarray:
    """f(x >= 0) from precomputed constants (broadcasting against x)."""
    h = 0.5 * ct
    if profile.endswith("linear"):
        shape = h - x
    elif profile.endswith("parabolic_a"):
        shape = h ** 2 - x ** 2
    elif profile.endswith("parabolic_b"):
        shape = (x - h) ** 2
    else:
        shape = 1.0
    f = np.where(constant | (x <= d), 1.0 / cs, k * shape)      # U types: saturated centre
    return np.where(x <= h, f, 0.0)


def _chord(t: np.ndarray, cs: float, c: np.ndarray, s: np.ndarray) -> np.ndarray:
    """Length of a square (side cs) cut by a line at normal offset ``t`` from its centre.

    The line's direction has |cos| = c and |sin| = s against the square's axes: a trapezoid in t
    of area cs^2, flat (cs / max(c, s)) up to cs |c - s| / 2, zero beyond cs (c + s) / 2.
    """
    h = 0.5 * cs * (c + s)
    top = cs / np.maximum(c, s)
    ramp = (h - np.abs(t)) / np.maximum(c * s, 1e-12)
    return np.clip(np.minimum(top, ramp), 0.0, None)


def band_coverage(dist: np.ndarray, c: np.ndarray, s: np.ndarray, ct: np.ndarray, cs: float,
                  profile: str, saturation: float = 0.5) -> np.ndarray:
    """Coverage (1/C_s) \\iint_cell f(dist) dA of a micro-cell by a straight crack, in [0, 1].

    ``dist``: distance of the micro-cell centre from the crack's centre line; ``c``, ``s``: |cos|
    and |sin| of the crack direction in the micro-grid's axes; ``ct``: crack width.
    """
    dist, c, s, ct = np.broadcast_arrays(*(np.asarray(a, dtype=float) for a in (dist, c, s, ct)))
    kk, d, constant = profile_constants(ct, cs, profile, saturation)
    h = 0.5 * cs * (c + s)
    g = 0.5 * cs * np.abs(c - s)
    half = 0.5 * ct
    zero = np.zeros_like(dist)
    bp = np.stack([dist - h, dist - g, dist + g, dist + h, -half, -d, zero, d, half], axis=-1)
    bp = np.sort(np.clip(bp, (dist - h)[..., None], (dist + h)[..., None]), axis=-1)
    lo, hi = bp[..., :-1], bp[..., 1:]                               # (..., 8) pieces
    mid, rad = 0.5 * (lo + hi), 0.5 * (hi - lo)
    x = mid[..., None] + rad[..., None] * _GL_X                     # (..., 8, 3)
    ex = (..., None, None)
    f = _density(np.abs(x), ct[ex], kk[ex], d[ex], constant[ex], cs, profile)
    chord = _chord(x - dist[ex], cs, c[ex], s[ex])
    total = np.sum(f * chord * _GL_W * rad[..., None], axis=(-1, -2))
    return np.clip(total / cs, 0.0, 1.0)


def coverage_bound(dist: np.ndarray, c: np.ndarray, s: np.ndarray, ct: np.ndarray, cs: float,
                   profile: str, saturation: float = 0.5) -> np.ndarray:
    """An upper bound of :func:`band_coverage` (same arguments), cheap enough to prune with.

    Over the micro-cell the offsets run through [dist - h, dist + h]; the density there is at
    most its supremum F beyond x0 = max(0, dist - h) (U types jump up past the saturated
    centre d, so the sup also takes k shape(max(x0, d))), the chord at most cs / max(c, s) and
    its integral cs^2, over the part of the offsets inside the band: coverage <= F min(cs^2,
    chord * length) / cs.  Inflated by 1e-6 so that rounding never puts it below the value.
    """
    kk, d, constant = profile_constants(ct, cs, profile, saturation)
    h = 0.5 * cs * (c + s)
    half = 0.5 * ct
    x0 = np.maximum(dist - h, 0.0)
    xd = np.maximum(x0, d)
    f = np.maximum(_density(x0, ct, kk, d, constant, cs, profile),
                   np.where(constant | (xd > half), 0.0,
                            _density(xd, ct, kk, np.full_like(d, -1.0), constant, cs, profile)))
    inside = np.clip(np.minimum(dist + h, half) - np.maximum(dist - h, -half), 0.0, None)
    area = np.minimum(cs * cs, inside * cs / np.maximum(c, s))
    return np.maximum(f, 0.0) * area / cs * (1.0 + 1e-6) + 1e-12


@dataclass(frozen=True)
class Segments:
    """Crack segments in facet frames: face, endpoints (2-D), widths at the endpoints."""

    face: np.ndarray    # (S,) facet
    a: np.ndarray       # (S, 2) start in the facet's 2-D frame
    b: np.ndarray       # (S, 2) end
    wa: np.ndarray      # (S,) width at a
    wb: np.ndarray      # (S,) width at b

    def __len__(self) -> int:
        return len(self.face)

    def select(self, keep: np.ndarray) -> "Segments":
        return Segments(self.face[keep], self.a[keep], self.b[keep], self.wa[keep], self.wb[keep])

    def shifted(self, offset: np.ndarray) -> "Segments":
        """The segments moved by per-segment 2-D offsets (mirror bands)."""
        return Segments(self.face, self.a + offset, self.b + offset, self.wa, self.wb)

    def with_width(self, width: np.ndarray) -> "Segments":
        return Segments(self.face, self.a, self.b, width, width)

    def concat(self, other: "Segments") -> "Segments":
        return Segments(*(np.concatenate([getattr(self, k), getattr(other, k)])
                          for k in ("face", "a", "b", "wa", "wb")))

    def split(self, max_len: float) -> "Segments":
        """Pieces no longer than ``max_len`` (bounds the micro-cells each piece can touch)."""
        length = np.linalg.norm(self.b - self.a, axis=1)
        n = np.maximum(np.ceil(length / max_len).astype(np.int64), 1)
        seg = np.repeat(np.arange(len(self)), n)
        start = np.repeat(np.cumsum(n) - n, n)
        t0 = (np.arange(len(seg)) - start) / n[seg]
        t1 = t0 + 1.0 / n[seg]
        a, b, wa, wb = self.a[seg], self.b[seg], self.wa[seg], self.wb[seg]
        return Segments(self.face[seg], a + t0[:, None] * (b - a), a + t1[:, None] * (b - a),
                        wa + t0 * (wb - wa), wa + t1 * (wb - wa))


def _point_segment_distance(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    t = np.clip(np.sum((p - a) * ab, 1) / np.maximum(np.sum(ab * ab, 1), 1e-300), 0.0, 1.0)
    return np.linalg.norm(p - a - t[:, None] * ab, axis=1)


def unfold_across_edges(cells, seg: Segments, reach: np.ndarray) -> Segments:
    """Copies of the pieces whose band reaches a facet edge, unfolded into the facet across it.

    A crack wider than its distance to a facet edge also covers the neighbour facet's micro-cells
    (the thesis drops that share, Figure 5.14; with smooth bands the cut shows).  The neighbour's
    frame is reached by the rigid map (a rotation, a reflection when the two frames have opposite
    handedness) that takes the shared edge onto itself and puts the facets on opposite sides:
    the thesis's unfolding of a facet pair (3DSCA edge communication).
    """
    from procgen.domains.trimesh_domain import edge_table

    f = cells.faces
    _, fe, ef, _ = edge_table(f, cells.valid)
    c2 = cells.corners2d
    idx = np.repeat(np.arange(len(seg)), 3)
    fa = seg.face[idx]
    k = np.tile(np.arange(3), len(seg))
    e = fe[fa, k]
    fb = np.where(ef[e, 0] == fa, ef[e, 1], ef[e, 0])
    pa, qa = c2[fa, k], c2[fa, (k + 1) % 3]
    a, b = seg.a[idx], seg.b[idx]
    near = np.minimum.reduce([_point_segment_distance(a, pa, qa), _point_segment_distance(b, pa, qa),
                              _point_segment_distance(pa, a, b), _point_segment_distance(qa, a, b)])
    use = (fb >= 0) & (near <= reach[idx])
    idx, fa, fb, k, pa, qa = idx[use], fa[use], fb[use], k[use], pa[use], qa[use]
    vp, vq = f[fa, k], f[fa, (k + 1) % 3]
    rows = np.arange(len(fb))
    pb = c2[fb, np.argmax(f[fb] == vp[:, None], axis=1)]
    qb = c2[fb, np.argmax(f[fb] == vq[:, None], axis=1)]
    ang = np.arctan2(*(qb - pb)[:, ::-1].T) - np.arctan2(*(qa - pa)[:, ::-1].T)
    cos, sin = np.cos(ang), np.sin(ang)

    def rotate(x: np.ndarray) -> np.ndarray:
        d = x - pa
        return pb + np.column_stack([cos * d[:, 0] - sin * d[:, 1], sin * d[:, 0] + cos * d[:, 1]])

    third_a = rotate(c2[fa, (k + 2) % 3])
    third_b = c2[fb][rows, 3 - np.argmax(f[fb] == vp[:, None], axis=1) - np.argmax(f[fb] == vq[:, None], axis=1)]
    same_side = geo_orient(pb, qb, third_a) * geo_orient(pb, qb, third_b) > 0
    u = (qb - pb) / np.maximum(np.linalg.norm(qb - pb, axis=1, keepdims=True), 1e-300)

    def unfold(x: np.ndarray) -> np.ndarray:
        y = rotate(x)
        d = y - pb
        mirrored = pb + 2.0 * np.sum(d * u, 1)[:, None] * u - d
        return np.where(same_side[:, None], mirrored, y)

    return Segments(fb, unfold(seg.a[idx]), unfold(seg.b[idx]), seg.wa[idx], seg.wb[idx])


def _interval(lo: np.ndarray, hi: np.ndarray, coef: np.ndarray, rhs_lo: np.ndarray,
              rhs_hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """[lo, hi] intersected with {x : rhs_lo <= coef x <= rhs_hi} (all x or none when coef = 0)."""
    with np.errstate(divide="ignore", invalid="ignore"):
        x1, x2 = rhs_lo / coef, rhs_hi / coef
    zero = coef == 0.0
    inside = (rhs_lo <= 0.0) & (rhs_hi >= 0.0)
    a = np.where(zero, np.where(inside, -np.inf, np.inf), np.minimum(x1, x2))
    b = np.where(zero, np.where(inside, np.inf, -np.inf), np.maximum(x1, x2))
    return np.maximum(lo, a), np.minimum(hi, b)


def _row_spans(seg: Segments, radius: np.ndarray, cells, k: int,
               cs: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(piece, micro row, first micro column, columns) of the micro-cells within reach.

    Per piece and micro-cell row, the columns whose centres lie within ``radius`` of the piece:
    the capsule is convex, so its trace on the row's centre line is one interval, the hull of
    the traces of its two end discs and of its rectangle (widened by a micro-cell each side
    against rounding).  Only these pairs are scanned, not the piece's bounding box.
    """
    top = np.column_stack([cells.nx[seg.face], cells.ny[seg.face]]) * k - 1
    ylo = np.clip(np.floor((np.minimum(seg.a[:, 1], seg.b[:, 1]) - radius) / cs), 0, top[:, 1])
    yhi = np.clip(np.floor((np.maximum(seg.a[:, 1], seg.b[:, 1]) + radius) / cs), 0, top[:, 1])
    rows = np.where(top[:, 1] >= 0, yhi - ylo + 1, 0).astype(np.int64)
    idx = np.repeat(np.arange(len(seg)), rows)
    my = ylo.astype(np.int64)[idx] + np.arange(len(idx)) - np.repeat(np.cumsum(rows) - rows, rows)
    y = (my + 0.5) * cs
    a, b, r = seg.a[idx], seg.b[idx], radius[idx]
    lo, hi = np.full(len(idx), np.inf), np.full(len(idx), -np.inf)
    for end in (a, b):                                        # the end discs
        h2 = r * r - (y - end[:, 1]) ** 2
        h = np.sqrt(np.maximum(h2, 0.0))
        lo = np.where(h2 > 0, np.minimum(lo, end[:, 0] - h), lo)
        hi = np.where(h2 > 0, np.maximum(hi, end[:, 0] + h), hi)
    ab = b - a
    ln = np.linalg.norm(ab, axis=1)
    u = ab / ln[:, None]
    dy = y - a[:, 1]
    # rectangle: 0 <= (p - a).u <= |ab| and |(p - a).n| <= r, with n = (-u_y, u_x)
    rlo, rhi = _interval(np.full(len(idx), -np.inf), np.full(len(idx), np.inf), u[:, 0],
                         -dy * u[:, 1], ln - dy * u[:, 1])
    rlo, rhi = _interval(rlo, rhi, -u[:, 1], -r - dy * u[:, 0], r - dy * u[:, 0])
    rlo, rhi = rlo + a[:, 0], rhi + a[:, 0]
    lo = np.where(rlo <= rhi, np.minimum(lo, rlo), lo)
    hi = np.where(rlo <= rhi, np.maximum(hi, rhi), hi)
    ok = lo <= hi
    x0 = np.clip(np.floor(np.where(ok, lo, 0.0) / cs - 0.5) - 1, 0, top[idx, 0]).astype(np.int64)
    x1 = np.clip(np.ceil(np.where(ok, hi, 0.0) / cs - 0.5) + 1, 0, top[idx, 0]).astype(np.int64)
    cols = np.where(ok & (top[idx, 0] >= 0), x1 - x0 + 1, 0)
    return idx, my, x0, cols


def _pairs(spans: tuple[np.ndarray, ...]) -> tuple[np.ndarray, ...]:
    """(piece, micro x, micro y) of every micro-cell of the row spans."""
    piece, my, x0, cols = spans
    idx = np.repeat(np.arange(len(piece)), cols)
    local = np.arange(len(idx)) - np.repeat(np.cumsum(cols) - cols, cols)
    return piece[idx], x0[idx] + local, my[idx]


def micro_coverage(cells, seg: Segments, k: int, *, profile: str = "constant",
                   saturation: float = 0.5, faces: np.ndarray | None = None,
                   accelerate: bool | None = None) -> np.ndarray:
    """(n_cells, k, k) float32 coverage of every micro-cell [cell, x, y] by the segments.

    The subdivided ("cracked") cells are those the crack band overlaps: the cells on the path
    and, where a crack is wider than its distance to a cell border, the neighbour it reaches
    (other cells stay 0).  A band reaching over a facet edge continues on the neighbour facet
    (:func:`unfold_across_edges`); micro-cells outside their triangle are computed but never
    shown (Figure 5.14's pink micro-cells).  ``faces`` (m,) bool: facets that may be drawn on
    (the crack mirror's front-lit facets); default all.  ``accelerate``: the numba scan of
    procgen_cracks.render_kernels (same bytes), see procgen.accel.
    """
    _check_profile(profile)
    out = np.zeros(cells.n_cells * k * k, np.float32)
    keep = (np.linalg.norm(seg.b - seg.a, axis=1) > 0) & (np.maximum(seg.wa, seg.wb) > 0)
    pieces = seg.select(keep).split(cells.size)
    if len(pieces) == 0:
        return out.reshape(cells.n_cells, k, k)
    cs = cells.size / k
    reach = 0.5 * np.maximum(pieces.wa, pieces.wb) + cs
    spill = unfold_across_edges(cells, pieces, reach)
    pieces = pieces.concat(spill)
    if faces is not None:
        pieces = pieces.select(np.asarray(faces, bool)[pieces.face])
    if len(pieces) == 0:
        return out.reshape(cells.n_cells, k, k)
    radius = 0.5 * np.maximum(pieces.wa, pieces.wb) + cs * np.sqrt(0.5)
    spans = _row_spans(pieces, radius, cells, k, cs)
    kern = kernels("procgen_cracks.render_kernels", accelerate, int(spans[3].sum()), MIN_MICRO_PAIRS)
    if kern is not None:
        lay = cells.layout
        kern.accumulate(out, pieces.face, pieces.a, pieces.b, pieces.wa, pieces.wb, *spans, k, cs,
                        PROFILES.index(profile), float(saturation), lay.nx, lay.ny,
                        lay.grid_offset, lay.lookup)
        return out.reshape(cells.n_cells, k, k)
    cum = np.cumsum(spans[3])
    cuts = np.searchsorted(cum, np.arange(_PAIR_CHUNK, cum[-1], _PAIR_CHUNK)) if len(cum) else []
    edges = np.unique(np.concatenate([[0], cuts, [len(cum)]]).astype(np.int64))
    for start, stop in zip(edges[:-1], edges[1:]):          # chunks of rows: bounded memory
        _accumulate(out, cells, pieces, tuple(v[start:stop] for v in spans), k, cs, profile,
                    saturation)
    return out.reshape(cells.n_cells, k, k)


def _accumulate(out: np.ndarray, cells, seg: Segments, spans: tuple[np.ndarray, ...], k: int,
                cs: float, profile: str, saturation: float) -> None:
    """Raise ``out`` to each micro-cell's largest coverage by the pieces whose spans cover it."""
    idx, mx, my = _pairs(spans)
    p = (np.column_stack([mx, my]) + 0.5) * cs
    a, b = seg.a[idx], seg.b[idx]
    ab = b - a
    ln2 = np.sum(ab * ab, axis=1)
    t = np.clip(np.sum((p - a) * ab, axis=1) / ln2, 0.0, 1.0)
    dist = np.linalg.norm(p - (a + t[:, None] * ab), axis=1)
    width = seg.wa[idx] + t * (seg.wb[idx] - seg.wa[idx])
    near = dist < 0.5 * width + cs * np.sqrt(0.5)          # the band can reach the micro-cell
    idx, mx, my, ab, ln2, t, dist, width = (v[near] for v in (idx, mx, my, ab, ln2, t, dist, width))
    cell = cells.layout.cell_at(seg.face[idx], mx // k, my // k)
    ok = cell >= 0
    cell, mx, my, ab, ln2, t, dist, width = (v[ok] for v in (cell, mx, my, ab, ln2, t, dist, width))
    ln = np.sqrt(ln2)
    c, s = np.abs(ab[:, 0]) / ln, np.abs(ab[:, 1]) / ln
    flat = (cell * k + mx % k) * k + my % k
    ub = coverage_bound(dist, c, s, width, cs, profile, saturation)
    # Overlapping pieces meet over the same micro-cells; only the largest coverage is kept, so
    # a pair whose bound is below the micro-cell's current value cannot change it.  The pairs
    # beside a piece (projection inside it) go first and raise those values; the pairs off a
    # piece's ends (its round caps, mostly covered better by the next piece) are then pruned.
    beside = (t > 0.0) & (t < 1.0)
    for pass_rows in (np.nonzero(beside)[0], np.nonzero(~beside)[0]):
        for start in range(0, len(pass_rows), _EVAL_CHUNK):       # cache-sized batches
            rows = pass_rows[start:start + _EVAL_CHUNK]
            rows = rows[ub[rows] >= out[flat[rows]]]
            cov = band_coverage(dist[rows], c[rows], s[rows], width[rows], cs, profile, saturation)
            np.maximum.at(out, flat[rows], cov.astype(np.float32))


def facet_segments(cells, points: np.ndarray, offsets: np.ndarray, face: np.ndarray,
                   width: np.ndarray, lines: np.ndarray | None = None) -> Segments:
    """Segments of crack polylines in their facets' 2-D frames (the contract's ``crack__face``).

    Segment i -> i+1 of a line lies in facet ``face[i]``; both ends are expressed in that frame.
    ``lines``: restrict to these line indices (e.g. the cracks of one layer).
    """
    n_pts = len(points)
    line_of = np.repeat(np.arange(len(offsets) - 1), np.diff(offsets))
    start = np.ones(n_pts, bool)
    start[offsets[1:] - 1] = False                     # the last point of a line starts nothing
    if lines is not None:
        start &= np.isin(line_of, lines)
    i = np.nonzero(start)[0]
    f = np.asarray(face, dtype=np.int64)[i]
    bad = (f < 0) | (f >= cells.n_faces)
    if bad.any():
        raise InputError(f"crack paths: crack__face {int(f[bad][0])} is not a facet of the cells "
                         f"(0..{cells.n_faces - 1})")
    fr = cells.layout.frames
    a = fr.to_2d(f, points[i])
    b = fr.to_2d(f, points[i + 1])
    w = np.asarray(width, dtype=float)
    return Segments(f, a, b, w[i], w[i + 1])

