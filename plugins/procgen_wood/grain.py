"""Procedural wood grain (thesis 3.1, Figs 3.1-3.11): hash value noise, 3x3 smoothing,
turbulence and the ring function |sin(2 pi P (f(x, y) + turbPower T / 256))|.

The hash of thesis Fig. 3.1 is misprinted (``n*15731`` for ``n*n*15731`` and the mask
``0xffffffff`` for ``0x7fffffff``, which gives values down to -3 against the thesis's own range
[-1, 1]); ``hash_noise`` uses the corrected constants, ``variant="printed"`` keeps the printed
form.  All arithmetic is 32-bit wrapping as in C: computed mod 2^64 in uint64, whose low 32 bits
are exact.  The printed Turbulence (Fig. 3.9) calls SmoothNoise with ints (``interp="truncate"``:
size x size blocks with seams); the default ``bilinear`` interpolates between lattice points.

Texel convention: u = image column (x), v = row (y); ``wood_texture`` returns row v at index v
(row 0 = t = 0, the bottom of the PNG).
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from procgen import InputError

HASH_VARIANTS = ("elias", "printed")
INTERPOLATIONS = ("truncate", "bilinear", "cosine")

#: f(x, y) of thesis Figs 3.4-3.8 and 4.12-4.14 (the half ellipse's a^2 = 9, b^2 = 1, Fig. 3.10)
RINGS: dict[str, Callable[[np.ndarray, np.ndarray], np.ndarray]] = {
    "circle": lambda x, y: x * x + y * y,
    "xy": lambda x, y: x * y,
    "y2": lambda x, y: y * y,
    "half_ellipse": lambda x, y: x * x / 9.0 + y * y,
    "x2_minus_y2": lambda x, y: x * x - y * y,
    "x2": lambda x, y: x * x,
    "cos_pi_x": lambda x, y: np.cos(3.14 * x),
}
PATTERNS = ("rings", "noise", "smooth_noise", "turbulence")

_M31 = np.uint64(0x7FFFFFFF)
_M32 = np.uint64(0xFFFFFFFF)


def hash_noise(x: np.ndarray, y: np.ndarray, variant: str = "elias") -> np.ndarray:
    """Integer-lattice value noise of thesis Fig. 3.1, in (-1, 1] (``elias``)."""
    if variant not in HASH_VARIANTS:
        raise InputError(f"hash noise variant must be one of {HASH_VARIANTS}, got {variant!r}")
    n = (np.asarray(x, np.int64) + np.int64(57) * np.asarray(y, np.int64)).astype(np.uint64)
    with np.errstate(over="ignore"):
        n = (n << np.uint64(13)) ^ n
        if variant == "elias":
            h = (n * (n * n * np.uint64(15731) + np.uint64(789221)) + np.uint64(1376312589)) & _M31
        else:
            h = (n * (n * np.uint64(15731) + np.uint64(789221)) + np.uint64(1376312589)) & _M32
    return 1.0 - h.astype(np.float64) / 1073741824.0


def smooth_noise(x: np.ndarray, y: np.ndarray, variant: str = "elias") -> np.ndarray:
    """Thesis Fig. 3.3: corners / 16 + sides / 8 + centre / 4 (weights sum to 1)."""
    x, y = np.asarray(x, np.int64), np.asarray(y, np.int64)
    out = np.zeros(np.broadcast(x, y).shape)
    for dx, dy, w in ((-1, -1, 16), (1, -1, 16), (-1, 1, 16), (1, 1, 16),
                      (-1, 0, 8), (1, 0, 8), (0, -1, 8), (0, 1, 8), (0, 0, 4)):
        out += hash_noise(x + dx, y + dy, variant) / w
    return out


def _interpolated(x: np.ndarray, y: np.ndarray, interp: str, variant: str) -> np.ndarray:
    """SmoothNoise at real coordinates: truncated to the lattice, or interpolated.

    SmoothNoise is evaluated once per lattice point of the bounding box and then gathered.
    """
    if interp == "truncate":
        x, y = np.trunc(x), np.trunc(y)
    x0, y0 = np.floor(x), np.floor(y)
    i, j = x0.astype(np.int64), y0.astype(np.int64)
    il, jl = int(i.min(initial=0)), int(j.min(initial=0))
    gi, gj = np.meshgrid(np.arange(il, int(i.max(initial=0)) + 2), np.arange(jl, int(j.max(initial=0)) + 2))
    lat = smooth_noise(gi, gj, variant)
    i, j = i - il, j - jl
    if interp == "truncate":
        return lat[j, i]
    fx, fy = x - x0, y - y0
    if interp == "cosine":
        fx, fy = (1 - np.cos(np.pi * fx)) / 2, (1 - np.cos(np.pi * fy)) / 2
    return ((lat[j, i] * (1 - fx) + lat[j, i + 1] * fx) * (1 - fy)
            + (lat[j + 1, i] * (1 - fx) + lat[j + 1, i + 1] * fx) * fy)


def turbulence(x: np.ndarray, y: np.ndarray, size: int, interp: str = "bilinear",
               variant: str = "elias") -> np.ndarray:
    """Thesis Fig. 3.9: 128 * sum_s SmoothNoise(x / s, y / s) * s / size, s = size, size/2 .. 1."""
    if interp not in INTERPOLATIONS:
        raise InputError(f"turbulence interpolation must be one of {INTERPOLATIONS}, got {interp!r}")
    x, y = np.asarray(x, np.float64), np.asarray(y, np.float64)
    value = np.zeros(np.broadcast(x, y).shape)
    s = int(size)
    while s >= 1:
        value += _interpolated(x / s, y / s, interp, variant) * s
        s //= 2
    return 128.0 * value / size


def ring_function(name: str) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    if name not in RINGS:
        raise InputError(f"ring f(x, y) must be one of {tuple(RINGS)}, got {name!r}")
    return RINGS[name]


def wood_texture(width: int = 256, height: int = 256, *, ring: str = "half_ellipse",
                 xy_period: float = 20.0, turb_power: float = 0.2, turb_size: int = 128,
                 interp: str = "bilinear", variant: str = "elias", pattern: str = "rings",
                 base_rgb: tuple[float, float, float] = (190, 120, 70),
                 amp_rgb: tuple[float, float, float] = (15, 15, 10)) -> np.ndarray:
    """createTexture of thesis Fig. 3.10 as a (height, width, 3) uint8 image, row index = v.

    ``pattern`` other than ``rings`` shows a building block through the same colour ramp
    (Fig. 3.2 shows the raw noise): s = (noise + 1) / 2, or |turbulence| / 255.
    """
    if pattern not in PATTERNS:
        raise InputError(f"wood pattern must be one of {PATTERNS}, got {pattern!r}")
    v, u = np.mgrid[0:height, 0:width]
    if pattern == "noise":
        s = (hash_noise(u, v, variant) + 1) / 2
    elif pattern == "smooth_noise":
        s = (smooth_noise(u, v, variant) + 1) / 2
    elif pattern == "turbulence":
        s = np.abs(turbulence(u, v, turb_size, interp, variant)) / 255.0
    else:
        x, y = u / height, (v - width / 2) / width
        dist = ring_function(ring)(x, y)
        if turb_power:
            dist = dist + turb_power * turbulence(u, v, turb_size, interp, variant) / 256.0
        s = np.abs(np.sin(2 * xy_period * dist * np.pi))
    rgb = np.asarray(base_rgb, float) + np.asarray(amp_rgb, float) * np.clip(s, 0, 1)[..., None]
    return np.clip(np.trunc(rgb), 0, 255).astype(np.uint8)
