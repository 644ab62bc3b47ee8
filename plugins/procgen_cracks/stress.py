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

from procgen.ca.subcell import (AXIS_MINUS_SLOT, AXIS_PLUS_SLOT, AXIS_STEP, STENCIL,
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
                       curvature: float, blocked: np.ndarray | None = None) -> np.ndarray:
    """(n, 4) tension per axis from one layer's thickness ``h`` (n,).

    I_k = gradient * |h(+k) - h(-k)| / (2 |o_k|) + curvature * |h(+k) - 2 h + h(-k)| / |o_k|^2,
    with o_k the lattice step along axis k (thesis 5.2.3.a: "proportional to the thickness
    difference between the two opposite neighbours and to the curvature"; the printed formula is
    lost, this is our reconstruction).  A missing neighbour counts as the cell itself.  Axes whose
    stencil crosses a ``blocked`` slot (coplanar facet edges) are set to 0.
    """
    out = np.zeros((len(h), 4))
    for k in range(4):                                   # the 4 axes, each vectorised
        sp, sm = slots[:, AXIS_PLUS_SLOT[k]], slots[:, AXIS_MINUS_SLOT[k]]
        hp = np.where(sp >= 0, h[np.maximum(sp, 0)], h)
        hm = np.where(sm >= 0, h[np.maximum(sm, 0)], h)
        step = AXIS_STEP[k] * size
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


def relax(spec: np.ndarray, rows: np.ndarray, cols: np.ndarray, share: float, loops: int) -> np.ndarray:
    """Material elasticity (thesis 5.2.3.a "Stress Relaxation", Figure 5.8), per axis.

    Each loop, every cell C gives to each of its n neighbours N that are weaker on that axis
    ``share * (I_C - I_N) / n``: in total ``share * (I_C - mean of the weaker)``, the printed
    sigma, split by deficit rather than equally (equal shares can lift a neighbour above C and
    above the field's maximum).  All cells give at once (double buffer); a link's flow is
    scaled down where a cell's give-and-take coefficients would exceed 1, so every new value is
    a convex mix of old neighbouring values: the total per axis is conserved exactly, the
    maximum never rises and the minimum never falls.  ``rows``/``cols``: the directed
    neighbour links (CSR rows and indices).
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
