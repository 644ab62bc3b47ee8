"""Fractal noise for heightmaps and layer thickness: spectral fBm and midpoint displacement.

Both take a Hurst exponent H in (0, 1): small H gives rough, large H smooth surfaces
(fractal dimension 3 - H). Both return zero-mean, unit-std arrays so callers choose amplitude.
"""
from __future__ import annotations

import numpy as np


def _normalise(a: np.ndarray) -> np.ndarray:
    a = a - a.mean()
    s = a.std()
    return a / s if s > 0 else a


def fbm_spectral(rng: np.random.Generator, shape: tuple[int, int], hurst: float = 0.7,
                 periodic: bool = False) -> np.ndarray:
    """fBm by spectral synthesis: Gaussian white noise shaped by power spectrum 1/f^(2H+2).

    Non-periodic output is cut from a doubled canvas so opposite edges do not match.
    """
    ny, nx = shape
    py, px = (ny, nx) if periodic else (2 * ny, 2 * nx)
    fy = np.fft.fftfreq(py)[:, None]
    fx = np.fft.rfftfreq(px)[None, :]
    f = np.sqrt(fx * fx + fy * fy)
    f[0, 0] = 1.0
    amp = f ** (-(hurst + 1.0))
    amp[0, 0] = 0.0
    spec = amp * (rng.standard_normal((py, px // 2 + 1)) + 1j * rng.standard_normal((py, px // 2 + 1)))
    field = np.fft.irfft2(spec, s=(py, px))
    return _normalise(field[:ny, :nx])


def midpoint_displacement(rng: np.random.Generator, shape: tuple[int, int], hurst: float = 0.7) -> np.ndarray:
    """Diamond-square midpoint displacement, vectorised one level at a time, cropped to shape.

    The displacement scale halves as 2^-H per level (Fournier, Fussell & Carpenter 1982).
    """
    ny, nx = shape
    n = 1
    while n + 1 < max(ny, nx):
        n *= 2
    size = n + 1
    h = np.zeros((size, size))
    h[:: n, :: n] = rng.standard_normal((2, 2))
    step, scale = n, 1.0
    while step > 1:
        half = step // 2
        scale *= 0.5 ** hurst
        # diamond: centres of squares
        c = (h[0:-1:step, 0:-1:step] + h[0:-1:step, step::step] + h[step::step, 0:-1:step] + h[step::step, step::step]) / 4
        h[half::step, half::step] = c + scale * rng.standard_normal(c.shape)
        # square: edge midpoints, averaging the available 3 or 4 neighbours
        for oy, ox in ((0, half), (half, 0)):
            ys = np.arange(oy, size, step)
            xs = np.arange(ox, size, step)
            yy, xx = np.meshgrid(ys, xs, indexing="ij")
            acc = np.zeros(yy.shape)
            cnt = np.zeros(yy.shape)
            for dy, dx in ((-half, 0), (half, 0), (0, -half), (0, half)):
                y2, x2 = yy + dy, xx + dx
                ok = (y2 >= 0) & (y2 < size) & (x2 >= 0) & (x2 < size)
                acc[ok] += h[y2[ok], x2[ok]]
                cnt[ok] += 1
            h[yy, xx] = acc / cnt + scale * rng.standard_normal(yy.shape)
        step = half
    return _normalise(h[:ny, :nx])


def smooth(a: np.ndarray, passes: int = 1) -> np.ndarray:
    """Box-blur ``passes`` times with edge replication (the thesis's smoothness coefficient)."""
    out = np.asarray(a, dtype=np.float64)
    for _ in range(passes):
        p = np.pad(out, 1, mode="edge")
        out = (p[:-2, :-2] + p[:-2, 1:-1] + p[:-2, 2:] + p[1:-1, :-2] + p[1:-1, 1:-1] + p[1:-1, 2:]
               + p[2:, :-2] + p[2:, 1:-1] + p[2:, 2:]) / 9.0
    return out
