"""Exporters of a cellular network: oriented splats (OBJ, GLB, PNG), point clouds, planar SVG.

The paper draws every cell as a point sprite and never rebuilds a mesh (section 5.3).  The
file equivalent is one small hexagon per cell in its tangent plane (radius ``splat`` cs, faces
wound counter-clockwise about the normal) with the cell's colour on its vertices; TRANSPARENT
cells (corroded holes) are left out.  Colours come from any field: an (n, 3) RGB field, a
bool field (two colours), an integer field (one colour per value), a scalar (colour map),
``normal`` (rgb = (n + 1)/2, Figure 10(c)'s "rgb normals"), ``degree`` (links per cell, one
colour per count) or ``humidity`` (Figure 13(a)).
"""
from __future__ import annotations

import io
from typing import Any

import numpy as np

from procgen import Exporter, InputError, TriMesh
from procgen.exchange import UpAxis, glb_export, obj_export, render_mesh_png, to_rgb8
from procgen.exchange.provenance import comment_lines
from procgen.exchange.svg import finish, fmt_number, new_drawing

from .network import CellNetwork, tangent_frames
from .states import TRANSPARENT, states
from .watercolour import WATER, humidity_rgb

#: integer-field colours (label k -> PALETTE[k % len]); 0 and negatives -> light grey
PALETTE = np.array([[0.90, 0.62, 0.25], [0.35, 0.60, 0.85], [0.55, 0.78, 0.40], [0.85, 0.40, 0.45],
                    [0.62, 0.50, 0.80], [0.95, 0.85, 0.40], [0.40, 0.75, 0.72], [0.80, 0.55, 0.70],
                    [0.60, 0.45, 0.35], [0.70, 0.70, 0.30], [0.30, 0.45, 0.65], [0.90, 0.70, 0.60]])


def _check(domain: Any, fmt: str) -> CellNetwork:
    if not isinstance(domain, CellNetwork):
        raise InputError(f"{fmt}: expected a CellNetwork, got {domain.kind}")
    return domain


def cell_rgb(net: CellNetwork, color_by: str, p_sat: float = 0.5,
             on_color: tuple[float, float, float] = (0.15, 0.15, 0.15),
             off_color: tuple[float, float, float] = (0.93, 0.91, 0.86), cmap: str = "viridis") -> np.ndarray:
    """(n, 3) colours in [0, 1] of every cell from ``color_by`` (see the module docstring)."""
    if color_by == "normal":
        return (net.normals() + 1) / 2
    if color_by == "degree":
        return PALETTE[np.mod(net.degree, len(PALETTE))]
    if color_by == "humidity":
        if WATER not in net:
            raise InputError(f"cellnet export: color_by 'humidity' needs {WATER!r}")
        return humidity_rgb(np.asarray(net[WATER], float), p_sat)
    if color_by not in net:
        have = ", ".join(net.field_names()) or "none"
        raise InputError(f"cellnet export: no field {color_by!r} (fields: {have}; or normal, humidity)")
    a = np.asarray(net[color_by])
    if a.ndim == 2 and a.shape[1] == 3:
        rgb = np.clip(a.astype(float), 0, 1)
        if color_by == "surface__color" and "cell__colored" in net:
            rgb[~np.asarray(net["cell__colored"], bool)] = off_color
        return rgb
    if a.ndim != 1:
        raise InputError(f"cellnet export: field {color_by!r} has shape {a.shape}; need (n,) or (n, 3)")
    if a.dtype == bool:
        return np.where(a[:, None], np.asarray(on_color, float), np.asarray(off_color, float))
    if np.issubdtype(a.dtype, np.integer):
        rgb = PALETTE[np.mod(a, len(PALETTE))].copy()
        rgb[a <= 0] = off_color
        return rgb
    v = np.nan_to_num(a.astype(float), nan=0.0)
    return to_rgb8(v[:, None], cmap=cmap).reshape(-1, 3) / 255.0


#: directions in which the Voronoi region of a cell is measured (every 22.5 degrees)
COVER_DIRECTIONS = 16
#: splat reach over the measured region: the corners lie between the measured directions and
#: the surface curves away from the tangent plane (bunny: 3e-4 of surface samples lie beyond
#: their nearest cell's splat, most of them under a neighbour's)
COVER_MARGIN = 1.15


def cover_radius(net: CellNetwork) -> np.ndarray:
    """(n,) how far every cell's Voronoi region (among its linked neighbours, in its tangent
    plane) reaches, measured along 16 directions; directions with no neighbour ahead (a
    border) are left out.

    Along a unit direction e, the region ends at the nearest bisector ahead:
    min over neighbours d with e.d > 0 of |d|^2 / (2 e.d).  A splat reaching this far leaves
    no hole between the cells: the seams between the per-face lattices of a curved mesh
    (Figure 10's bunny) have cells up to ~1.4 cs apart where a flat lattice has cs.
    """
    indptr, indices, _ = net.csr
    rows = np.repeat(np.arange(net.n_cells), np.diff(indptr))
    out = np.zeros(net.n_cells)
    if len(rows) == 0:
        return out
    u, w = tangent_frames(net.normals())
    ang = np.arange(COVER_DIRECTIONS) * 2 * np.pi / COVER_DIRECTIONS
    ex, ey = np.cos(ang), np.sin(ang)
    has = np.diff(indptr) > 0
    starts = indptr[:-1][has]
    step = max(1, 2_000_000 // COVER_DIRECTIONS)
    for lo in range(0, len(starts), step):          # rows in chunks: bounded memory
        s0 = starts[lo:lo + step]
        e0, e1 = s0[0], (starts[lo + step] if lo + step < len(starts) else len(rows))
        r, j = rows[e0:e1], indices[e0:e1]
        d = net.positions[j] - net.positions[r]
        a, b = np.einsum("ij,ij->i", d, u[r]), np.einsum("ij,ij->i", d, w[r])
        ahead = a[:, None] * ex + b[:, None] * ey                      # (entries, K)
        reach = np.where(ahead > 1e-12 * net.cs, (a * a + b * b)[:, None] / (2 * np.maximum(ahead, 1e-300)),
                         np.inf)
        per_dir = np.minimum.reduceat(reach, s0 - e0, axis=0)          # (cells, K)
        per_dir[~np.isfinite(per_dir)] = 0.0
        out[np.nonzero(has)[0][lo:lo + step]] = per_dir.max(axis=1)
    return out


def splat_mesh(net: CellNetwork, rgb: np.ndarray, splat: float = 0.8,
               max_splat: float = 1.2) -> TriMesh:
    """One hexagon per present cell, CCW about its normal, coloured.

    Its inscribed radius reaches ``COVER_MARGIN`` times the cell's Voronoi region
    (:func:`cover_radius`), at least
    ``splat`` cs and at most ``max_splat`` cs, so curved and seamed networks show no speckles.
    """
    keep = states(net) != TRANSPARENT
    radius = np.clip(COVER_MARGIN * cover_radius(net) / np.cos(np.pi / 6), splat * net.cs,
                     max(splat, max_splat) * net.cs)[keep]
    p, n, c = net.positions[keep], net.normals()[keep], rgb[keep]
    u, w = tangent_frames(n)
    ang = (np.arange(6) + 0.5) * np.pi / 3          # flat side along u: tiles a triangle lattice
    r = radius[:, None, None]
    corners = p[:, None, :] + r * (np.cos(ang)[None, :, None] * u[:, None, :]
                                   + np.sin(ang)[None, :, None] * w[:, None, :])
    base = (np.arange(len(p)) * 6)[:, None]
    fan = np.array([[0, 1, 2], [0, 2, 3], [0, 3, 4], [0, 4, 5]])
    faces = (base[:, None, :] + fan[None]).reshape(-1, 3)
    mesh = TriMesh(corners.reshape(-1, 3), faces)
    mesh.add_field("vertex__color", np.repeat(c, 6, axis=0).astype(np.float32), at="vertex",
                   doc="cell colour")
    return mesh


def _splats(domain: Any, fmt: str, color_by: str, splat: float, p_sat: float) -> TriMesh:
    net = _check(domain, fmt)
    if not 0 < splat <= 5:
        raise InputError(f"{fmt}: splat must be in (0, 5] cs, got {splat}")
    return splat_mesh(net, cell_rgb(net, color_by, p_sat), splat)


def cellnet_obj(domain: Any, *, stem: str, provenance: dict | None = None,
                color_by: str = "surface__color", splat: float = 0.8, p_sat: float = 0.5) -> dict[str, bytes]:
    """OBJ with one coloured hexagon splat per cell (transparent cells left out)."""
    mesh = _splats(domain, "cellnet_obj", color_by, splat, p_sat)
    return obj_export(mesh, stem=stem, provenance=provenance, color_field="vertex__color")


def cellnet_glb(domain: Any, *, stem: str = "", provenance: dict | None = None,
                color_by: str = "surface__color", splat: float = 0.8, p_sat: float = 0.5,
                up: UpAxis = "z") -> bytes:
    """Binary glTF of the coloured splats; ``up`` is the model's up axis (as for ``cellnet_png``)."""
    mesh = _splats(domain, "cellnet_glb", color_by, splat, p_sat)
    return glb_export(mesh, stem=stem, provenance=provenance, color_field="vertex__color", up=up)


def cellnet_png(domain: Any, *, stem: str = "", provenance: dict | None = None,
                color_by: str = "surface__color", splat: float = 0.8, p_sat: float = 0.5,
                width: int = 640, height: int = 480, azimuth: float = 35.0, elevation: float = 25.0,
                up: UpAxis = "z", lit: bool = True) -> bytes:
    """The splats seen from a fixed camera (software renderer) as PNG."""
    import trimesh

    mesh = _splats(domain, "cellnet_png", color_by, splat, p_sat)
    rgb = np.asarray(mesh["vertex__color"], float)
    tm = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    return render_mesh_png(tm, (width, height), azimuth=azimuth, elevation=elevation, up=up,
                           face_colors=rgb[mesh.faces[:, 0]], lit=lit, smooth=False)


def cellnet_points(domain: Any, *, stem: str = "", provenance: dict | None = None,
                   color_by: str = "surface__color", p_sat: float = 0.5) -> bytes:
    """Point-cloud OBJ: ``v x y z r g b`` per present cell."""
    net = _check(domain, "cellnet_points")
    keep = states(net) != TRANSPARENT
    rows = np.column_stack([net.positions, cell_rgb(net, color_by, p_sat)])[keep]
    buf = io.StringIO()
    np.savetxt(buf, rows, fmt="v %.6f %.6f %.6f %.4f %.4f %.4f")
    return (comment_lines(provenance) + "o cells\n" + buf.getvalue()).encode()


def cellnet_svg(domain: Any, *, stem: str = "", provenance: dict | None = None,
                color_by: str = "surface__color", p_sat: float = 0.5, radius: float = 0.5,
                links: bool = False, link_color: str = "#555555", ring: bool = False,
                width: int = 800, background: str = "#ffffff") -> bytes:
    """Planar runs as SVG: one disc per present cell (radius in cs), optional link lines and a
    circle of the link radius around the cell nearest the centre (Figure 5)."""
    net = _check(domain, "cellnet_svg")
    p = net.positions
    if np.ptp(p[:, 2]) > 1e-6 * max(float(np.ptp(p[:, :2])), 1e-300):
        raise InputError("cellnet_svg: the network is not planar in z; use cellnet_png or cellnet_obj")
    keep = states(net) != TRANSPARENT
    rgb = (cell_rgb(net, color_by, p_sat) * 255).round().astype(int)
    xy = p[:, :2]
    pad = max(net.cs, net.radius if ring else 0)
    lo, hi = xy.min(axis=0) - pad, xy.max(axis=0) + pad
    dwg, group, _ = new_drawing((lo[0], hi[0], lo[1], hi[1]), width, background=background)
    if links and net.n_links:
        g = dwg.g(stroke=link_color, stroke_width=fmt_number(0.06 * net.cs))
        for i, j in net.links[keep[net.links[:, 0]] & keep[net.links[:, 1]]]:
            g.add(dwg.line(tuple(map(fmt_number, xy[i])), tuple(map(fmt_number, xy[j]))))
        group.add(g)
    r = fmt_number(radius * net.cs)
    for k in np.nonzero(keep)[0]:
        group.add(dwg.circle((fmt_number(xy[k, 0]), fmt_number(xy[k, 1])), r,
                             fill="rgb(%d,%d,%d)" % tuple(rgb[k])))
    if ring and net.linked:
        c = np.argmin(np.linalg.norm(xy - xy.mean(axis=0), axis=1))
        group.add(dwg.circle((fmt_number(xy[c, 0]), fmt_number(xy[c, 1])), fmt_number(net.radius),
                           fill="none", stroke="#d03030", stroke_width=fmt_number(0.08 * net.cs)))
    return finish(dwg, provenance, title=stem)


EXPORTERS = (
    Exporter("cellnet_obj", ("CellNetwork",), ".obj", cellnet_obj,
             "one coloured hexagon splat per cell (transparent cells left out), OBJ + vertex colours"),
    Exporter("cellnet_glb", ("CellNetwork",), ".glb", cellnet_glb, "the coloured splats as binary glTF"),
    Exporter("cellnet_png", ("CellNetwork",), ".png", cellnet_png,
             "the coloured splats from a fixed camera (software renderer)"),
    Exporter("cellnet_points", ("CellNetwork",), ".obj", cellnet_points,
             "point-cloud OBJ, v x y z r g b per cell"),
    Exporter("cellnet_svg", ("CellNetwork",), ".svg", cellnet_svg,
             "planar networks: a disc per cell, optional links and link-radius ring"),
)
