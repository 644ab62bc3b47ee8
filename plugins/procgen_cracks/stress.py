"""The stress spectrum of a layer and its relaxation (3DSCA thesis 5.2.3.a-b, Figures 5.6-5.9).

Drying or cooling puts a layer under tension that depends on its geometry: each cell holds the
tension along the 4 lattice axes 0, pi/4, pi/2, 3pi/4 of its facet frame (central symmetry makes
the 8 Moore directions 4).  It comes from the layer's thickness (its slope and curvature along
each axis) or is imposed by the user; the material's elasticity then spreads it over eL loops
(sharing eP of the excess with the weaker neighbours), and a crack head reads it between cell
centres by bilinear interpolation.
"""
from __future__ import annotations

import numpy as np

from procgen.ca.subcell import (AXIS_ANGLES, AXIS_MINUS_SLOT, AXIS_PLUS_SLOT, AXIS_STEP, STENCIL,
                                bilinear_stencil, interpolate)


def coplanar_slots(slots: np.ndarray, crossed: np.ndarray, cell_face: np.ndarray,
                   face_normals: np.ndarray, tol: float = 1e-6) -> np.ndarray:
    """(n, 8) True where a Moore slot links two different *coplanar* facets.

    Thesis 5.2.3.a, Figure 5.7: coplanar facets have their layer surfaces forced to match, so
    a thickness difference taken across their shared edge is an artefact.
    """
    nb = np.where(slots >= 0, slots, 0)
    f0 = cell_face[:, None]
    f1 = cell_face[nb]
    dot = np.einsum("nd,nsd->ns", face_normals[cell_face], face_normals[f1])
    return crossed & (slots >= 0) & (f1 != f0) & (dot > 1.0 - tol)


def thickness_spectrum(h: np.ndarray, slots: np.ndarray, size: float, *, gradient: float,
                       curvature: float, blocked: np.ndarray | None = None,
                       per_cell: bool = False) -> np.ndarray:
    """(n, 4) tension per axis from one layer's thickness ``h`` (n,).

    Thesis 5.2.3.a: each directional intensity is "proportional to the difference of opposite
    cell layer thickness and to the layer curvature in this direction" (the printed formula is
    lost; this is our reconstruction).  Two readings:

    * ``per_cell = False`` (a slope): I_k = gradient * |h(+k) - h(-k)| / (2 |o_k|)
      + curvature * |h(+k) - 2 h + h(-k)| / |o_k|^2, with o_k the lattice step along axis k:
      the same thickness field gives the same intensities at any cell size;
    * ``per_cell = True`` (the thesis's own words, differences between cells):
      I_k = gradient * |h(+k) - h(-k)| / 2 + curvature * |h(+k) - 2 h + h(-k)|, the tension a
      cell holds.  Against a resistance mR that is itself per cell ("a maximum tension for each
      unit surface - in our case each cell", 5.2.4.b), a finer lattice over the same thickness
      then holds less tension per cell: the difference term in proportion to the cell size,
      the second difference (curvature) to its square.  Plate 5.9's two resolutions depend on
      this; the mix of the two terms, and so ``curvature``'s effect, depends on the cell size.

    A missing neighbour counts as the cell itself.  Axes whose stencil crosses a ``blocked``
    slot (coplanar facet edges) are set to 0.
    """
    out = np.zeros((len(h), 4))
    for k in range(4):                                   # the 4 axes, each vectorised
        sp, sm = slots[:, AXIS_PLUS_SLOT[k]], slots[:, AXIS_MINUS_SLOT[k]]
        hp = np.where(sp >= 0, h[np.maximum(sp, 0)], h)
        hm = np.where(sm >= 0, h[np.maximum(sm, 0)], h)
        step = 1.0 if per_cell else AXIS_STEP[k] * size
        out[:, k] = gradient * np.abs(hp - hm) / (2 * step) + curvature * np.abs(hp - 2 * h + hm) / step ** 2
        if blocked is not None:
            out[blocked[:, AXIS_PLUS_SLOT[k]] | blocked[:, AXIS_MINUS_SLOT[k]], k] = 0.0
    return out


def imposed_spectrum(n: int, percent: list[float], rng: np.random.Generator | None = None,
                     jitter: float = 0.0) -> np.ndarray:
    """(n, 4) uniform user field: ``percent`` per axis (plate 5.5: 10 / 0 / 90 / 0), in 0..1.

    ``jitter`` multiplies every value by (1 + jitter * u), u uniform in [-1, 1], so that births
    on a uniform field are not all tied.
    """
    base = np.tile(np.asarray(percent, float) / 100.0, (n, 1))
    if jitter > 0 and rng is not None:
        base *= 1.0 + jitter * rng.uniform(-1.0, 1.0, size=base.shape)
    return base


def frame_weights(mat: np.ndarray) -> np.ndarray:
    """(m, 4, 4) W such that ``W @ spec_B`` is a spectrum of frame B read along frame A's axes.

    ``mat`` (m, 2, 2) maps frame-A vectors into frame B (a rotation, or a reflection where the
    two facets' frames have opposite handedness).  Each spectrum lives in its own facet's 2-D
    frame (thesis 5.2.3.a: the 4 axes of the facet's grid), so a spectrum read or shared across
    a facet edge must be turned into the reader's frame first, or axis k of one facet is mixed
    with axis k of its neighbour, a different direction on the surface.  Between the 4 axes
    (period pi) the value is interpolated linearly, as the spectrum is between cells (Figure
    5.9): each row of W sums to 1 and so does each column, so a shared amount is conserved.
    """
    axes = np.column_stack([np.cos(AXIS_ANGLES), np.sin(AXIS_ANGLES)])         # (4, 2)
    v = np.einsum("mij,kj->mki", np.asarray(mat, float), axes)
    pos = np.mod(np.arctan2(v[..., 1], v[..., 0]), np.pi) / (np.pi / 4)       # (m, 4) in [0, 4)
    lo = np.floor(pos).astype(np.int64)
    frac = pos - lo
    w = np.zeros(v.shape[:2] + (4,))
    m_i, k_i = np.meshgrid(np.arange(len(v)), np.arange(4), indexing="ij")
    np.add.at(w, (m_i, k_i, lo % 4), 1.0 - frac)
    np.add.at(w, (m_i, k_i, (lo + 1) % 4), frac)
    return w


def facet_maps(frames, normals: np.ndarray, fa: np.ndarray, fb: np.ndarray) -> np.ndarray:
    """(m, 2, 2) maps of 2-D vectors from facet fa's frame into facet fb's, by the rotation about
    their common edge that lays fa onto fb (unfolding; either orientation of fb's normal gives
    the same axes up to sign, which a spectrum, of period pi, does not see)."""
    na, nb = normals[fa], normals[fb]
    nb = np.where((np.einsum("md,md->m", na, nb) < 0)[:, None], -nb, nb)
    k = np.cross(na, nb)
    c = np.einsum("md,md->m", na, nb)
    s2 = np.einsum("md,md->m", k, k)

    def rot(v: np.ndarray) -> np.ndarray:                   # Rodrigues: na -> nb about k
        with np.errstate(invalid="ignore", divide="ignore"):
            f = np.where(s2 > 1e-24, (1.0 - c) / np.where(s2 > 1e-24, s2, 1.0), 0.0)
        return v * c[:, None] + np.cross(k, v) + k * (np.einsum("md,md->m", k, v) * f)[:, None]

    ex, ey = rot(frames.ex[fa]), rot(frames.ey[fa])
    bx, by = frames.ex[fb], frames.ey[fb]
    return np.stack([np.stack([np.einsum("md,md->m", ex, bx), np.einsum("md,md->m", ey, bx)], -1),
                     np.stack([np.einsum("md,md->m", ex, by), np.einsum("md,md->m", ey, by)], -1)], 1)


def relax(spec: np.ndarray, rows: np.ndarray, cols: np.ndarray, share: float, loops: int,
          turn: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """Material elasticity (thesis 5.2.3.a "Stress Relaxation", Figure 5.8), per axis.

    Each loop, every cell C gives to each of its n neighbours N that are weaker on that axis
    ``share * (I_C - I_N) / n``: in total ``share * (I_C - mean of the weaker)``, the printed
    sigma, split by deficit rather than equally (equal shares can lift a neighbour above C and
    above the field's maximum).  All cells give at once (double buffer); a link's flow is
    scaled down where a cell's give-and-take coefficients would exceed 1, so every new value is
    a convex mix of old neighbouring values: the total per axis is conserved exactly, the
    maximum never rises and the minimum never falls.  ``rows``/``cols``: the directed
    neighbour links (CSR rows and indices).  ``turn`` = (links, W): links joining cells of
    two facets, and per link the :func:`frame_weights` reading the receiving cell's spectrum
    in the giving cell's frame; what such a link carries is turned back by W's transpose
    into the receiver's frame (conserved; the guarantee on the maximum then holds only
    within one facet's frame, as axes are interpolated).
    """
    out = np.array(spec, dtype=float, copy=True)
    if share <= 0 or loops <= 0 or len(rows) == 0:
        return out
    n = len(out)
    order = np.argsort(rows, kind="stable")                # links grouped by giving cell
    rows, cols = rows[order], cols[order]
    starts = np.searchsorted(rows, np.arange(n))
    has = np.bincount(rows, minlength=n) > 0
    first = np.minimum(starts, len(rows) - 1)

    def row_sum(x: np.ndarray) -> np.ndarray:
        return np.where(has, np.add.reduceat(x, first), 0.0)

    if turn is not None and len(turn[0]):
        inv = np.empty_like(order)
        inv[order] = np.arange(len(order))
        t_idx, t_w = inv[np.asarray(turn[0])], np.asarray(turn[1], float)
        n_ax = out.shape[1]
        for _ in range(loops):                            # eL sweeps, all axes at once
            other = out[cols]
            other[t_idx] = np.einsum("lkm,lm->lk", t_w, other[t_idx])   # in the giver's frame
            diff = out[rows] - other
            low = (diff > 0).astype(float)
            n_inf = np.stack([row_sum(low[:, k]) for k in range(n_ax)], 1)
            a = share * low / np.maximum(n_inf, 1.0)[rows]
            coef = np.stack([np.bincount(cols, weights=a[:, k], minlength=n) for k in range(n_ax)], 1) \
                + np.where(n_inf > 0, share, 0.0)
            lim = np.maximum(coef, 1.0)
            flow = a * diff / np.maximum(lim[rows], lim[cols])
            got = flow.copy()
            got[t_idx] = np.einsum("lkm,lk->lm", t_w, flow[t_idx])        # back in its frame
            out = out - np.stack([row_sum(flow[:, k]) for k in range(n_ax)], 1) \
                + np.stack([np.bincount(cols, weights=got[:, k], minlength=n) for k in range(n_ax)], 1)
        return out
    for _ in range(loops):                                # eL sweeps (the thesis's loop)
        for k in range(out.shape[1]):                     # 4 axes, each vectorised over links
            v = out[:, k]
            diff = v[rows] - v[cols]
            low = (diff > 0).astype(float)
            n_inf = row_sum(low)
            a = share * low / np.maximum(n_inf, 1.0)[rows]          # flow coefficient per link
            coef = np.bincount(cols, weights=a, minlength=n) + np.where(n_inf > 0, share, 0.0)
            lim = np.maximum(coef, 1.0)
            flow = a * diff / np.maximum(lim[rows], lim[cols])
            out[:, k] = v - row_sum(flow) + np.bincount(cols, weights=flow, minlength=n)
    return out


class FaceSampler:
    """Cells and bilinear values at sub-cell points (face, x, y) of surface cells' facet grids."""

    def __init__(self, layout) -> None:
        self.layout = layout
        self.size = float(layout.size)

    def cell_of(self, face: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """Cell containing each point (-1 outside its facet's active cells)."""
        ij = np.floor(xy / self.size).astype(np.int64)
        return self.layout.cell_at(face, ij[:, 0], ij[:, 1])

    def stencil(self, face: np.ndarray, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The 4 surrounding cells (m, 4; -1 missing) and their bilinear weights (m, 4)."""
        ij0, w = bilinear_stencil(xy, self.size)
        i = ij0[:, :1] + STENCIL[None, :, 0]
        j = ij0[:, 1:] + STENCIL[None, :, 1]
        cells = self.layout.cell_at(np.broadcast_to(face[:, None], i.shape), i, j)
        return cells, w

    def sample(self, values: np.ndarray, face: np.ndarray, xy: np.ndarray) -> np.ndarray:
        """Bilinear mix of per-cell ``values`` (n, ...) at the points (thesis Figure 5.9)."""
        cells, w = self.stencil(face, xy)
        return interpolate(values, cells, w)
