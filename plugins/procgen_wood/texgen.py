"""Texture coordinates and sampling (thesis 4.3.4): OpenGL's automatic texture generation.

``object_linear``: s = p_s . (x, y, z, 1), t = p_t . (x, y, z, 1) (GL_OBJECT_LINEAR).  The
thesis gives only the s plane ((1,0,0,0) for Fig. 4.12, (0,1,0,0) for Fig. 4.13); t defaults to
the next axis cyclically, as OpenGL pairs its default planes.  ``sphere_map`` (GL_SPHERE_MAP,
Fig. 4.14) baked for a fixed orthographic view along -z reduces to s = n_x / 2 + 1/2,
t = n_y / 2 + 1/2, a view-independent lookup by the normal.  Sampling wraps (GL_REPEAT) and
filters bilinearly between texel centres.
"""
from __future__ import annotations

import numpy as np

from procgen import InputError

MODES = ("object_linear", "sphere_map")


def cyclic_plane(plane_s: np.ndarray) -> np.ndarray:
    """The t plane paired with an s plane: its axis moved one place on (x -> y -> z -> x), no offset."""
    p = np.asarray(plane_s, float)
    return np.concatenate([np.roll(p[:3], 1), [0.0]])


def texture_coordinates(points: np.ndarray, normals: np.ndarray, *, mode: str = "object_linear",
                        plane_s: np.ndarray = (1, 0, 0, 0), plane_t: np.ndarray | None = None,
                        scale: float = 1.0) -> np.ndarray:
    """(n, 2) texture coordinates (s, t) of points with unit normals; 1 = one texture repeat."""
    if mode not in MODES:
        raise InputError(f"texgen mode must be one of {MODES}, got {mode!r}")
    if mode == "sphere_map":
        n = np.asarray(normals, float)
        return np.column_stack([n[:, 0] / 2 + 0.5, n[:, 1] / 2 + 0.5])
    ps = np.asarray(plane_s, float)
    pt = cyclic_plane(ps) if plane_t is None else np.asarray(plane_t, float)
    h = np.column_stack([np.asarray(points, float), np.ones(len(points))])
    return scale * np.column_stack([h @ ps, h @ pt])


def sample_bilinear(image: np.ndarray, st: np.ndarray) -> np.ndarray:
    """Colours (n, c) of an (h, w, c) image at (s, t) with repeat wrapping; row index = t."""
    h, w = image.shape[:2]
    x = np.mod(st[:, 0], 1.0) * w - 0.5
    y = np.mod(st[:, 1], 1.0) * h - 0.5
    x0, y0 = np.floor(x), np.floor(y)
    fx, fy = (x - x0)[:, None], (y - y0)[:, None]
    i0, j0 = x0.astype(np.int64) % w, y0.astype(np.int64) % h
    i1, j1 = (i0 + 1) % w, (j0 + 1) % h
    img = np.asarray(image, float)
    return ((img[j0, i0] * (1 - fx) + img[j0, i1] * fx) * (1 - fy)
            + (img[j1, i0] * (1 - fx) + img[j1, i1] * fx) * fy)
