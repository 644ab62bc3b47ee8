"""Meshes the tests build themselves, standing in for models the repository cannot ship.

* :func:`quad_obj` -- a Suzanne-like OBJ: mostly quads plus triangle fans, with texture
  coordinates and normals, so the UV seam splits vertices the way exported models do.
* :func:`sharp_block` -- a CAD-like closed part with sharp feature edges of several dihedral
  angles (a chamfered cube), standing in for Hoppe's fandisk.

The open case is the shipped teapot (procgen/data/meshes/teapot.obj).
"""
from __future__ import annotations

from pathlib import Path

import numpy as np


def quad_obj(path: Path, rings: int = 10, sections: int = 24) -> tuple[Path, int, int]:
    """Write a latitude-longitude sphere as OBJ quads (triangle fans at the poles).

    Returns (path, number of quads, number of triangles). The seam column is written twice (u = 0
    and u = 1), and every pole fan has its own pole vertex per section, as UV-mapped exports have.
    """
    lines = ["# procedural quad sphere (tests/_meshes.py)"]
    theta = np.linspace(0, np.pi, rings + 1)               # pole to pole
    phi = np.linspace(0, 2 * np.pi, sections + 1)          # seam column repeated
    for t in theta:
        for p in phi:
            lines.append(f"v {np.sin(t) * np.cos(p):.9f} {np.sin(t) * np.sin(p):.9f} {np.cos(t):.9f}")
    for i in range(rings + 1):
        for j in range(sections + 1):
            lines.append(f"vt {j / sections:.6f} {1 - i / rings:.6f}")
    for t in theta:
        for p in phi:
            lines.append(f"vn {np.sin(t) * np.cos(p):.6f} {np.sin(t) * np.sin(p):.6f} {np.cos(t):.6f}")

    def vid(i: int, j: int) -> int:
        return i * (sections + 1) + j + 1                   # OBJ is 1-based

    quads = tris = 0
    for i in range(rings):
        for j in range(sections):
            a, b, c, d = vid(i, j), vid(i + 1, j), vid(i + 1, j + 1), vid(i, j + 1)
            if i == 0:
                corners = [a, b, c]                         # north fan: a is a pole copy
                tris += 1
            elif i == rings - 1:
                corners = [a, b, d]                         # south fan: b, c are pole copies
                tris += 1
            else:
                corners = [a, b, c, d]
                quads += 1
            lines.append("f " + " ".join(f"{k}/{k}/{k}" for k in corners))
    path.write_text("\n".join(lines) + "\n")
    return path, quads, tris


def sharp_block(subdivisions: int = 2) -> tuple[np.ndarray, np.ndarray]:
    """A unit cube with one corner chamfered off: closed, feature edges of 90 and 125 degrees.

    Faces are subdivided ``subdivisions`` times (midpoints), so every flat facet has interior
    vertices and the feature edges are long chains of mesh edges.
    """
    import trimesh

    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], float)
    cut = 0.4
    keep = corners[~np.all(corners == 1, axis=1)]
    chamfer = np.array([[1 - cut, 1, 1], [1, 1 - cut, 1], [1, 1, 1 - cut]])
    hull = trimesh.convex.convex_hull(np.vstack([keep, chamfer]))
    v, f = np.asarray(hull.vertices), np.asarray(hull.faces)
    for _ in range(subdivisions):
        v, f = trimesh.remesh.subdivide(v, f)
    return np.asarray(v, float), np.asarray(f, np.int64)
