"""Terrain material sets: the maps terrain tools write (normal, masks, splat) and a PBR GLB.

Why: an eroded, layered Grid is meant to go on into a game engine or a renderer, which takes a
terrain as a height map plus maps: a normal map, masks of where water flowed, eroded, deposited
and wetted, and a splat map of which material shows where (the maps Gaea, World Machine and
Houdini's heightfields export).  ``terrain_maps`` writes them as PNGs (8-bit masks, each with
its scale in a ``procgen_scale`` text chunk); ``terrain_glb`` a glTF 2.0 metallic-roughness mesh
of the terrain with its colour, ORM (``bake__roughness`` / ``bake__metallic`` of the stack) and
a normal map that carries the detail a coarser mesh (``mesh_step``) leaves out.

Every map is north-up (row 0 = the largest y), as image_png and heightmap_png16 write grids.
On a periodic (tileable) grid the normals take their differences across the edges, so the
normal map tiles with the height map.
"""
from __future__ import annotations

from typing import Any

import numpy as np

from procgen import Exporter, InputError
from procgen.domains import Grid, TriMesh
from procgen.exchange import glb_export, png_bytes, to_rgb8
from procgen.lighting import heightfield_normals

from .light import layer_weights
from .stack import load_table

#: mask name -> (field, how a layered field becomes one value per cell)
MASKS = {"flow": "water__path", "wetness": "water__saturation", "deposition": "sediment__deposit",
         "erosion": "sediment__baseline"}


def _grid(domain: Any, fmt: str, field: str) -> Grid:
    if not isinstance(domain, Grid):
        raise InputError(f"{fmt}: expected a Grid, got {domain.kind}")
    if field not in domain:
        raise InputError(f"{fmt}: the grid has no field {field!r}")
    return domain


def encode_normals(n: np.ndarray, directx: bool = False) -> np.ndarray:
    """(ny, nx, 3) unit normals (rows = increasing y) -> north-up uint8 normal-map image."""
    n = n.copy()
    if directx:
        n[..., 1] *= -1.0
    return to_rgb8(np.flipud(0.5 * (n + 1.0)))


def mask_values(grid: Grid, name: str) -> np.ndarray | None:
    """(ny, nx) value of one mask, or None when the grid lacks its field."""
    field = MASKS[name]
    if field not in grid:
        return None
    v = np.asarray(grid[field], np.float64)
    if name == "deposition":
        return v.sum(axis=-1) if v.ndim == 3 else v
    if name == "erosion":            # solid lost since the surface was built, per cell area
        if "layers__thickness" not in grid:
            return None
        now = np.asarray(grid["layers__thickness"], np.float64).sum(axis=-1) * grid.spacing ** 2
        return np.clip(v - now, 0.0, None) / grid.spacing ** 2
    return v


def splat_weights(grid: Grid) -> np.ndarray:
    """(ny, nx, 4) share of the visible colour of the first four layers (bottom first): R, G, B, A."""
    table = load_table(grid, "terrain_maps")
    t = np.asarray(grid["layers__thickness"], np.float64)
    w = layer_weights(t[..., ::-1], table.array("opacity")[::-1])[..., ::-1]
    out = np.zeros(t.shape[:2] + (4,))
    k = min(4, t.shape[-1])
    out[..., :k] = w[..., :k]
    return out


def terrain_maps(domain: Any, *, stem: str, provenance: dict | None = None,
                 height_field: str = "surface__height", z_scale: float = 1.0,
                 normal_convention: str = "opengl") -> dict[str, bytes]:
    """Normal map, splat map and the flow / wetness / deposition / erosion masks the grid has
    (a mask that is zero everywhere, e.g. flow on a grid no drop ran on, is left out)."""
    g = _grid(domain, "terrain_maps", height_field)
    if normal_convention not in ("opengl", "directx"):
        raise InputError(f"terrain_maps: normal_convention must be opengl or directx, got {normal_convention!r}")
    if not z_scale > 0:
        raise InputError(f"terrain_maps: z_scale must be > 0, got {z_scale}")
    n = heightfield_normals(z_scale * np.asarray(g[height_field], float), g.spacing, g.periodic)
    files = {f"{stem}_normal.png": png_bytes(encode_normals(n, normal_convention == "directx"), provenance)}
    if "layers__thickness" in g and "material__name" in g:
        names = [str(x) for x in g["material__name"]][:4]
        files[f"{stem}_splat.png"] = png_bytes(to_rgb8(np.flipud(splat_weights(g))), provenance,
                                               {"procgen_channels": ",".join(names)})
    for name in MASKS:
        v = mask_values(g, name)
        if v is None or not np.any(v):           # no water ran here: an all-black mask says nothing
            continue
        top = float(v.max()) if np.isfinite(v).all() and v.max() > 0 else 1.0
        q = np.round(np.clip(np.flipud(v) / top, 0, 1) * 255).astype(np.uint8)
        files[f"{stem}_{name}.png"] = png_bytes(q, provenance, {"procgen_scale": {"field": MASKS[name],
                                                                                  "value_at_255": top}})
    return files


def terrain_glb(domain: Any, *, stem: str = "", provenance: dict | None = None,
                height_field: str = "surface__height", color_field: str = "",
                z_scale: float = 1.0, mesh_step: int = 4) -> bytes:
    """GLB of the terrain: a mesh of every ``mesh_step``-th cell centre, glTF metallic-roughness
    with the colour field as base colour, the stack's baked roughness/metallic as ORM and a
    normal map of the full-resolution height relative to the coarse mesh's surface.

    ``color_field`` '' = the stack's unlit albedo ``bake__color`` when the grid has it (a
    renderer lights the material itself: a shaded colour would be lit twice), else
    ``surface__color``."""
    from scipy.ndimage import map_coordinates

    g = _grid(domain, "terrain_glb", height_field)
    if not color_field:
        color_field = "bake__color" if "bake__color" in g else "surface__color"
    _grid(g, "terrain_glb", color_field)
    if not 1 <= int(mesh_step) <= 64 or not z_scale > 0:
        raise InputError(f"terrain_glb: need mesh_step in 1..64 and z_scale > 0, got {mesh_step}, {z_scale}")
    h = np.asarray(g[height_field], np.float64) * z_scale
    ny, nx = h.shape
    if ny < 2 or nx < 2:
        raise InputError(f"terrain_glb: the grid needs at least 2 x 2 cells, got {nx} x {ny}")
    step = int(mesh_step)
    rows = np.unique(np.r_[np.arange(0, ny, step), ny - 1])
    cols = np.unique(np.r_[np.arange(0, nx, step), nx - 1])
    rr, cc = np.meshgrid(rows, cols, indexing="ij")
    verts = np.column_stack([g.x[cc.ravel()], g.y[rr.ravel()], h[rr, cc].ravel()])
    m, k = len(rows), len(cols)
    idx = np.arange(m * k).reshape(m, k)
    a, b, c, d = idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]
    faces = np.concatenate([np.stack([a, b, c], -1).reshape(-1, 3), np.stack([a, c, d], -1).reshape(-1, 3)])
    uv = np.column_stack([cc.ravel() / (nx - 1), rr.ravel() / (ny - 1)])   # v = 1: north (top row)
    # the coarse surface at every cell (bilinear between the mesh's samples): the frame of the map
    ri = np.interp(np.arange(ny), rows, np.arange(m))
    ci = np.interp(np.arange(nx), cols, np.arange(k))
    R, C = np.meshgrid(ri, ci, indexing="ij")
    coarse = map_coordinates(h[rr, cc], [R, C], order=1, mode="nearest")
    fine, base = heightfield_normals(h, g.spacing, g.periodic), heightfield_normals(coarse, g.spacing)
    gy, gx = np.gradient(coarse, g.spacing)
    t = np.stack([np.ones_like(gx), np.zeros_like(gx), gx], -1)
    t /= np.linalg.norm(t, axis=-1, keepdims=True)
    bt = np.cross(base, t)
    tangent = np.stack([np.sum(fine * t, -1), np.sum(fine * bt, -1), np.sum(fine * base, -1)], -1)
    tm = TriMesh(verts, faces)
    tm.add_field("terrain__uv", uv, at="vertex", doc="UV of each vertex")
    tm.add_field("terrain__color", np.flipud(np.clip(np.asarray(g[color_field], float)[..., :3], 0, 1)),
                 at="domain", doc="base colour image")
    tm.add_field("terrain__normal", encode_normals(tangent), at="domain", doc="tangent-space normal map")
    maps = {"normal_field": "terrain__normal"}
    if "bake__roughness" in g:
        orm = np.stack([np.ones((ny, nx)), np.asarray(g["bake__roughness"], float),
                        np.asarray(g["bake__metallic"], float)], -1)
        tm.add_field("terrain__orm", np.flipud(orm), at="domain", doc="occlusion, roughness, metallic")
        maps["orm_field"] = "terrain__orm"
    return glb_export(tm, provenance=provenance, uv_field="terrain__uv", texture_field="terrain__color", **maps)


EXPORTERS = [
    Exporter(name="terrain_maps", kinds=("Grid",), suffix=".png", func=terrain_maps,
             doc="terrain normal map, splat map of the layers, flow/wetness/deposition/erosion masks"),
    Exporter(name="terrain_glb", kinds=("Grid",), suffix=".glb", func=terrain_glb,
             doc="GLB of a terrain grid: glTF metallic-roughness with colour, ORM and normal maps"),
]
