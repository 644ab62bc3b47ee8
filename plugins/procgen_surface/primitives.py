"""Procedural meshes the thesis's plates use: a cup (surface of revolution) and a bar lattice."""
from __future__ import annotations

import numpy as np

from procgen.builtin.solids import revolve
from procgen.errors import InputError


def cup_profile(radius: float = 1.0, height: float = 1.1, wall: float = 0.06,
                foot: float = 0.55, rings: int = 12) -> np.ndarray:
    """(r, z) profile of a closed cup: foot, bellied outer wall, rounded rim, inner wall, floor."""
    if not (0 < wall < 0.5 * radius) or not (0 < foot < 1) or height <= 2 * wall:
        raise InputError("cup: need 0 < wall < radius/2, 0 < foot < 1 and height > 2*wall")
    t = np.linspace(0, 1, rings + 1)
    r_out = radius * (foot + (1 - foot) * np.sin(t * np.pi / 2) ** 0.7)
    z_out = height * t
    rim = np.linspace(0, np.pi, 5)[1:-1]
    rim_r = radius - wall / 2 + (wall / 2) * np.cos(rim)
    rim_z = height + (wall / 2) * np.sin(rim)
    t_in = np.linspace(1, 0, rings + 1)
    z_in = wall + (height - wall) * t_in
    r_in = np.interp(z_in, z_out, r_out) - wall
    return np.concatenate([
        [[0.0, 0.0]],
        np.column_stack([r_out, z_out]),
        np.column_stack([rim_r, rim_z]),
        np.column_stack([r_in, z_in]),
        [[0.0, wall]]])


def cup(radius: float = 1.0, height: float = 1.1, wall: float = 0.06, foot: float = 0.55,
        rings: int = 12, sections: int = 24) -> tuple[np.ndarray, np.ndarray]:
    return revolve(cup_profile(radius, height, wall, foot, rings), sections)


def lattice(cells: tuple[int, int, int] = (3, 3, 3), period: int = 4,
            size: float = 1.0) -> tuple[np.ndarray, np.ndarray]:
    """Boundary of a lattice of square bars (one voxel thick, ``period`` voxels apart).

    Built as the surface of a voxel union, so it is closed and manifold; each boundary voxel
    face becomes two triangles.  ``size`` is the length of the longest side.
    """
    if period < 2 or min(cells) < 1:
        raise InputError("lattice: need period >= 2 and at least one cell per axis")
    dims = [c * period + 1 for c in cells]
    ix, iy, iz = np.meshgrid(*[np.arange(d) for d in dims], indexing="ij")
    on = [(a % period == 0) for a in (ix, iy, iz)]
    occ = (on[0] & on[1]) | (on[1] & on[2]) | (on[0] & on[2])
    occ = np.pad(occ, 1)
    quads = []
    unit = np.eye(3, dtype=np.int64)
    for ax in range(3):                               # three axes, each vectorised
        d = np.diff(occ.astype(np.int8), axis=ax)     # +1: empty -> full, -1: full -> empty
        for sign in (1, -1):
            idx = np.argwhere(d == sign)
            base = idx.copy()
            base[:, ax] += 1                          # the face plane between the two voxels
            u, v = unit[(ax + 1) % 3], unit[(ax + 2) % 3]
            c = np.stack([base, base + u, base + u + v, base + v], axis=1)
            if sign == 1:                             # normal points to -ax (towards empty)
                c = c[:, ::-1]
            quads.append(c)
    q = np.concatenate(quads)
    verts, inv = np.unique(q.reshape(-1, 3), axis=0, return_inverse=True)
    q = inv.reshape(-1, 4)
    f = np.concatenate([q[:, [0, 1, 2]], q[:, [0, 2, 3]]]).astype(np.int64)
    v = (verts - 1).astype(float)
    v -= v.mean(axis=0)
    v *= size / (max(dims))
    return v, f
