"""A table of boxes and cylinders, the stand-in for the thesis's table model (Figs 3.14-3.17).

The thesis modelled its table in 3ds Max from a photograph, as separate closed primitives with
segment counts "balanced" against the cell size (Fig. 3.17: too few segments give slim triangles
the cell grid cannot follow).  Here every box face is a grid of near-square quads and every leg a
surface of revolution with as many rings as its height needs, so all triangles have a similar
edge length ``edge``.
"""
from __future__ import annotations

import numpy as np

from procgen.builtin.solids import revolve


def box(lo: np.ndarray, hi: np.ndarray, edge: float) -> tuple[np.ndarray, np.ndarray]:
    """Closed axis-aligned box, each face a grid of about ``edge``-sized quads (2 triangles each)."""
    lo, hi = np.asarray(lo, float), np.asarray(hi, float)
    counts = np.maximum(1, np.ceil((hi - lo) / edge).astype(int))
    verts, faces, base = [], [], 0
    for axis in range(3):
        a, b = [k for k in range(3) if k != axis]
        na, nb = counts[a], counts[b]
        ga, gb = np.meshgrid(np.linspace(lo[a], hi[a], na + 1), np.linspace(lo[b], hi[b], nb + 1),
                             indexing="ij")
        idx = np.arange((na + 1) * (nb + 1)).reshape(na + 1, nb + 1)
        q = np.stack([idx[:-1, :-1], idx[1:, :-1], idx[1:, 1:], idx[:-1, 1:]], -1).reshape(-1, 4)
        tri = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]])
        for side, value in ((0, lo[axis]), (1, hi[axis])):
            p = np.zeros((idx.size, 3))
            p[:, a], p[:, b], p[:, axis] = ga.ravel(), gb.ravel(), value
            # outward winding: (a, b, axis) is right-handed for axis order x, y, z cyclic
            outward = (side == 1) == ((b - a) % 3 == 1)
            t = tri if outward else tri[:, ::-1]
            verts.append(p)
            faces.append(t + base)
            base += len(p)
    return _weld(np.concatenate(verts), np.concatenate(faces))


def leg(center: np.ndarray, radius: float, z0: float, z1: float, edge: float
        ) -> tuple[np.ndarray, np.ndarray]:
    """Closed vertical cylinder from z0 to z1, rings every ~``edge`` along its height."""
    sections = max(8, int(np.ceil(2 * np.pi * radius / edge)))
    rings = max(1, int(np.ceil((z1 - z0) / edge)))
    caps = max(1, int(np.ceil(radius / edge)))
    prof = ([[r, 0.0] for r in np.linspace(0, radius, caps + 1)]
            + [[radius, h] for h in np.linspace(0, z1 - z0, rings + 1)[1:]]
            + [[r, z1 - z0] for r in np.linspace(radius, 0, caps + 1)[1:]])
    v, f = revolve(np.asarray(prof), sections)
    return v + np.array([center[0], center[1], z0]), f


def _weld(v: np.ndarray, f: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Merge coincident vertices (box faces meet along shared grid lines)."""
    key = np.round(v / (1e-9 + np.abs(v).max()) * 1e9).astype(np.int64)
    _, first, inv = np.unique(key, axis=0, return_index=True, return_inverse=True)
    return v[first], inv.reshape(-1)[f]


def table(length: float = 1.2, width: float = 0.8, height: float = 0.75, top: float = 0.05,
          leg_radius: float = 0.035, apron: float = 0.1, edge: float = 0.025
          ) -> tuple[np.ndarray, np.ndarray]:
    """Top, four legs and four aprons as separate closed components (z up, floor at z = 0)."""
    parts = [box((-length / 2, -width / 2, height - top), (length / 2, width / 2, height), edge)]
    inset = 2.5 * leg_radius
    xs, ys = length / 2 - inset, width / 2 - inset
    for sx in (-1, 1):
        for sy in (-1, 1):
            parts.append(leg((sx * xs, sy * ys), leg_radius, 0.0, height - top, edge))
    t = 0.4 * leg_radius
    z0, z1 = height - top - apron, height - top
    parts += [box((-xs, s * ys - t, z0), (xs, s * ys + t, z1), edge) for s in (-1, 1)]
    parts += [box((s * xs - t, -ys, z0), (s * xs + t, ys, z1), edge) for s in (-1, 1)]
    verts, faces, base = [], [], 0
    for v, f in parts:
        verts.append(v)
        faces.append(f + base)
        base += len(v)
    return np.concatenate(verts), np.concatenate(faces)
