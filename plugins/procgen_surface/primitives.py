"""Procedural meshes the thesis's plates use: a cup (surface of revolution) and a bar lattice."""
from __future__ import annotations

import numpy as np

from procgen.errors import InputError


def revolve(profile: np.ndarray, sections: int) -> tuple[np.ndarray, np.ndarray]:
    """Closed surface of revolution about z of a (k, 2) profile (r, z) that starts and ends on
    the axis (r = 0).  Returns (vertices, faces) with outward-facing triangles."""
    p = np.asarray(profile, dtype=float)
    if len(p) < 3 or p[0, 0] != 0 or p[-1, 0] != 0 or np.any(p[1:-1, 0] <= 0):
        raise InputError("revolve: profile must start and end on the axis (r = 0) and stay off it between")
    if sections < 3:
        raise InputError(f"revolve: need at least 3 sections, got {sections}")
    ring = p[1:-1]
    k = len(ring)
    a = 2 * np.pi * np.arange(sections) / sections
    verts = np.column_stack([
        (ring[:, 0][:, None] * np.cos(a)[None, :]).ravel(),
        (ring[:, 0][:, None] * np.sin(a)[None, :]).ravel(),
        np.repeat(ring[:, 1], sections)])
    bottom, top = len(verts), len(verts) + 1
    verts = np.vstack([verts, [0, 0, p[0, 1]], [0, 0, p[-1, 1]]])
    s = np.arange(sections)
    s1 = (s + 1) % sections
    faces = [np.column_stack([np.full(sections, bottom), s1, s])]
    for r in range(k - 1):
        a0, b0 = r * sections + s, r * sections + s1
        a1, b1 = (r + 1) * sections + s, (r + 1) * sections + s1
        faces += [np.column_stack([a0, b0, b1]), np.column_stack([a0, b1, a1])]
    last = (k - 1) * sections
    faces.append(np.column_stack([np.full(sections, top), last + s, last + s1]))
    f = np.vstack(faces).astype(np.int64)
    vol = np.sum(np.einsum("ij,ij->i", verts[f[:, 0]], np.cross(verts[f[:, 1]], verts[f[:, 2]])))
    if vol < 0:
        f = f[:, ::-1].copy()
    return verts, f


def revolve_loop(profile: np.ndarray, sections: int) -> tuple[np.ndarray, np.ndarray]:
    """Closed ring surface (genus 1) revolving a closed (k, 2) profile loop with r > 0."""
    p = np.asarray(profile, dtype=float)
    if len(p) < 3 or np.any(p[:, 0] <= 0):
        raise InputError("revolve: a loop profile needs at least 3 points, all with r > 0")
    if sections < 3:
        raise InputError(f"revolve: need at least 3 sections, got {sections}")
    k = len(p)
    a = 2 * np.pi * np.arange(sections) / sections
    verts = np.column_stack([(p[:, 0][:, None] * np.cos(a)).ravel(),
                             (p[:, 0][:, None] * np.sin(a)).ravel(), np.repeat(p[:, 1], sections)])
    r = np.arange(k)[:, None]
    s = np.arange(sections)[None, :]
    a0 = (r * sections + s).ravel()
    b0 = (r * sections + (s + 1) % sections).ravel()
    a1 = (((r + 1) % k) * sections + s).ravel()
    b1 = (((r + 1) % k) * sections + (s + 1) % sections).ravel()
    f = np.vstack([np.column_stack([a0, b0, b1]), np.column_stack([a0, b1, a1])]).astype(np.int64)
    vol = np.sum(np.einsum("ij,ij->i", verts[f[:, 0]], np.cross(verts[f[:, 1]], verts[f[:, 2]])))
    if vol < 0:
        f = f[:, ::-1].copy()
    return verts, f


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
