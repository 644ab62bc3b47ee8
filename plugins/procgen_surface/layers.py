"""Multi-layer thickness per cell: nominal + fractal noise, smoothed, stacked along the normal.

Thesis 2.1 / Appendix A: each layer has a nominal thickness, a thickness noise ("classical
fractal functions") and a smoothness.  On a mesh the noise must agree across triangle edges, so
it is a 3-D fractal value noise sampled at the cell centres (seamless by construction), and the
smoothing is Jacobi averaging over the cell graph (the surface analogue of the 2.5D blur).
"""
from __future__ import annotations

import numpy as np

from procgen.errors import InputError
from procgen.noise import value_noise_3d  # noqa: F401  (re-exported for this plugin)

from procgen.ca.graph import CellGraph


def smooth_on_graph(values: np.ndarray, graph: CellGraph, iterations: int) -> np.ndarray:
    """Jacobi smoothing: x <- (x + mean of neighbours) / 2, ``iterations`` times."""
    x = np.asarray(values, dtype=float).copy()
    for _ in range(int(iterations)):                 # iterations of a sparse product, not cells
        x = 0.5 * (x + graph.mean(x))
    return x


def layer_stack(points: np.ndarray, graph: CellGraph, rng: np.random.Generator, *,
                nominal: list[float], noise: list[float], smoothing: list[int],
                scale: float, hurst: float = 0.7) -> np.ndarray:
    """(n, L) thickness per cell and layer (bottom first), all >= 0."""
    L = len(nominal)
    if not (len(noise) == len(smoothing) == L):
        raise InputError(f"layers: nominal ({L}), noise ({len(noise)}) and smoothing "
                         f"({len(smoothing)}) need one value per layer")
    out = np.zeros((len(points), L))
    for layer in range(L):                           # a handful of layers
        t = np.full(len(points), float(nominal[layer]))
        if noise[layer] > 0:
            nz = value_noise_3d(points, rng, scale=scale, hurst=hurst)
            nz = smooth_on_graph(nz, graph, smoothing[layer])
            t = t * (1.0 + noise[layer] * nz)
        out[:, layer] = np.clip(t, 0.0, None)
    return out


def stacked_heights(thickness: np.ndarray) -> np.ndarray:
    """Top surface of each layer above the base surface: cumulative sums (non-decreasing)."""
    return np.cumsum(np.clip(thickness, 0.0, None), axis=1)
