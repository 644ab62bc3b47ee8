"""Fractal noise for heightmaps and layer thickness, shared by every plugin.

Spectral fBm and midpoint displacement fill rasters; ``value_noise_3d`` gives fBm at arbitrary
3-D points, seamless across the triangles of a mesh (a per-triangle 2-D field would show seams).
All take a Hurst exponent H in (0, 1): small H gives rough, large H smooth surfaces (fractal
dimension 3 - H), and return zero-mean, (roughly) unit-std values so callers choose amplitude.
"""
from __future__ import annotations

import numpy as np

from . import portable
from .errors import InputError


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
    amp = portable.power(f, -(hurst + 1.0))   # not np.power: the same bits on every CPU
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


def value_noise_3d(points: np.ndarray, rng: np.random.Generator, *, scale: float,
                   octaves: int = 5, hurst: float = 0.7, table: int = 256) -> np.ndarray:
    """Fractal (fBm) value noise at 3-D points, zero mean, roughly unit std.

    ``scale`` is the feature size of the first octave (length units); each octave halves it and
    multiplies the amplitude by 2^-hurst.  Random lattice values come from ``rng`` only.
    """
    if scale <= 0 or not np.isfinite(scale):
        raise InputError(f"noise scale must be > 0, got {scale}")
    pts = np.asarray(points, dtype=float)
    perm = rng.permutation(table)
    perm = np.concatenate([perm, perm])
    vals = rng.uniform(-1.0, 1.0, table)
    out = np.zeros(len(pts))
    amp, freq, norm = 1.0, 1.0 / scale, 0.0
    for octave in range(octaves):                     # few octaves, each vectorised over points
        q = pts * freq + 17.31 * octave
        i0 = np.floor(q).astype(np.int64)
        t = q - i0
        w = t * t * (3 - 2 * t)                      # smoothstep weights
        acc = np.zeros(len(pts))
        for corner in range(8):
            o = np.array([(corner >> 2) & 1, (corner >> 1) & 1, corner & 1])
            idx = (i0 + o) % table
            h = perm[perm[perm[idx[:, 0]] + idx[:, 1]] + idx[:, 2]]
            wt = np.prod(np.where(o == 1, w, 1 - w), axis=1)
            acc += wt * vals[h]
        out += amp * acc
        norm += amp * amp
        amp *= 2.0 ** -hurst
        freq *= 2.0
    out /= np.sqrt(norm) * 0.45                      # value noise std is about 0.45 per octave
    return out
