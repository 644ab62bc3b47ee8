"""Headless mesh preview: a fixed-camera orthographic render to PNG bytes (no GPU, no display).

Painter's algorithm (triangles sorted far to near, drawn with Pillow at 2x then downsampled):
cheap, dependable, and good enough for the small, dense triangles of exported 3DSCA meshes.
Colours come from ``face_colors``, else the mesh's texture (sampled at each face's centroid UV),
vertex or face colours; faces whose alpha is below 0.5 (holes) are not drawn.
"""
from __future__ import annotations

import io
from dataclasses import dataclass
from typing import Annotated, Any

import numpy as np

from ..geometry import barycentric, triangle_cross, vertex_normals
from ..params import ParamInfo
from .registry import UpAxis

UP_AXES = {"x": np.array([1.0, 0, 0]), "y": np.array([0, 1.0, 0]), "z": np.array([0, 0, 1.0])}


def camera_basis(azimuth: float, elevation: float, up: str = "z") -> tuple[np.ndarray, ...]:
    """(towards-eye, right, screen-up) unit vectors of the fixed preview camera."""
    u = UP_AXES[up]
    a, b = [k for k in "xyz" if k != up][:2]
    ea, eb = UP_AXES[a], UP_AXES[b]
    az, el = np.radians(azimuth), np.radians(elevation)
    eye = np.cos(el) * (np.cos(az) * ea + np.sin(az) * eb) + np.sin(el) * u
    if up == "y":                               # keep right-handed views for y-up models
        eye = np.cos(el) * (np.sin(az) * ea + np.cos(az) * eb) + np.sin(el) * u
    right = np.cross(u, eye)
    right /= np.linalg.norm(right)
    sup = np.cross(eye, right)
    return eye, right, sup


def mesh_face_colors(mesh: Any) -> np.ndarray:
    """(m, 4) RGBA floats per face from whatever visual the trimesh carries."""
    vis = mesh.visual
    m = len(mesh.faces)
    if getattr(vis, "kind", None) == "texture" and getattr(vis, "uv", None) is not None:
        img = getattr(vis.material, "baseColorTexture", None) or getattr(vis.material, "image", None)
        if img is not None:
            arr = np.asarray(img.convert("RGBA"), dtype=float) / 255.0
            uv = np.asarray(vis.uv)[mesh.faces].mean(axis=1)
            h, w = arr.shape[:2]
            x = np.clip((uv[:, 0] % 1.0) * w, 0, w - 1).astype(int)
            y = np.clip((1.0 - uv[:, 1] % 1.0) * h, 0, h - 1).astype(int)
            return arr[y, x]
    if getattr(vis, "kind", None) in ("vertex", "face"):
        fc = np.asarray(vis.face_colors, dtype=float) / 255.0
        if fc.shape == (m, 4):
            return fc
    return np.tile([0.75, 0.75, 0.75, 1.0], (m, 1))


@dataclass(frozen=True)
class Projection:
    """Screen coordinates (supersampled pixels) and depth of mesh vertices."""

    px: np.ndarray
    py: np.ndarray
    depth: np.ndarray
    width: int
    height: int


def project(vertices: np.ndarray, size: tuple[int, int], *, azimuth: float, elevation: float,
            up: str, margin: float = 0.06, supersample: int = 2,
            frame: np.ndarray | None = None) -> Projection:
    """Screen coordinates of ``vertices``, framed to fit ``frame`` (default: the vertices)."""
    eye, right, sup = camera_basis(azimuth, elevation, up)
    W, H = int(size[0]) * supersample, int(size[1]) * supersample
    x, y, z = vertices @ right, vertices @ sup, vertices @ eye
    fx, fy = (x, y) if frame is None else (frame @ right, frame @ sup)
    cx, cy = (fx.max() + fx.min()) / 2, (fy.max() + fy.min()) / 2
    span = max(fx.max() - fx.min(), (fy.max() - fy.min()) * W / H, 1e-12)
    scale = W * (1 - 2 * margin) / span
    return Projection((x - cx) * scale + W / 2, H / 2 - (y - cy) * scale, z, W, H)


def face_id_buffer(proj: Projection, faces: np.ndarray, keep: np.ndarray | None = None) -> np.ndarray:
    """(H, W) int: index of the visible face per pixel (-1 = background), painter's order."""
    from PIL import Image, ImageDraw

    img = Image.new("I", (proj.width, proj.height), 0)
    if len(faces):
        draw = ImageDraw.Draw(img)
        order = np.argsort(proj.depth[faces].mean(axis=1), kind="stable")
        if keep is not None:
            order = order[keep[order]]
        tri = np.stack([proj.px[faces[order]], proj.py[faces[order]]], axis=2).reshape(-1, 6).tolist()
        for t, pts in zip((order + 1).tolist(), tri):       # one draw call per face (C fill)
            draw.polygon(pts, fill=t)
    return np.asarray(img, dtype=np.int64) - 1


def pixel_barycentric(proj: Projection, faces: np.ndarray, ids: np.ndarray) -> tuple[np.ndarray, ...]:
    """(pixel rows, cols, face, barycentric (k, 3)) of every covered pixel (pixel centres)."""
    rows, cols = np.nonzero(ids >= 0)
    f = ids[rows, cols]
    p = np.column_stack([cols + 0.5, rows + 0.5])
    corners = np.stack([proj.px[faces[f]], proj.py[faces[f]]], axis=2)      # (k, 3, 2)
    bc = np.clip(barycentric(corners, p), 0, 1)
    bc /= bc.sum(axis=1, keepdims=True)
    return rows, cols, f, bc


def composite(rgb: np.ndarray, ids: np.ndarray, background: tuple[int, int, int]) -> np.ndarray:
    """(H, W, 3) float image: per-pixel colours where ``ids >= 0``, the background elsewhere."""
    out = np.empty(ids.shape + (3,))
    out[:] = np.asarray(background, float) / 255.0
    out[ids >= 0] = rgb
    return out


def encode_png(rgb: np.ndarray, ids: np.ndarray, size: tuple[int, int],
               background: tuple[int, int, int], provenance: dict | None = None) -> bytes:
    """Composite per-pixel colours over the background, downsample, encode."""
    return encode_image(composite(rgb, ids, background), size, provenance)


def encode_image(out: np.ndarray, size: tuple[int, int], provenance: dict | None = None) -> bytes:
    """Encode an (H, W, 3) float image in [0, 1] as PNG (provenance in a text chunk, the one
    encoder :func:`procgen.exchange.image.png_bytes`), downsampled to ``size``."""
    from PIL import Image

    from .image import png_bytes

    img = Image.fromarray(np.clip(np.round(out * 255), 0, 255).astype(np.uint8), "RGB")
    if img.size != tuple(size):
        img = img.resize(tuple(int(s) for s in size), Image.LANCZOS)
    return png_bytes(np.asarray(img), provenance)


def _texture_lookup(mesh: Any) -> tuple[np.ndarray, np.ndarray] | None:
    """(RGBA image floats, per-vertex UV) of a textured trimesh, or None."""
    vis = mesh.visual
    if getattr(vis, "kind", None) != "texture" or getattr(vis, "uv", None) is None:
        return None
    img = getattr(vis.material, "baseColorTexture", None) or getattr(vis.material, "image", None)
    if img is None:
        return None
    return np.asarray(img.convert("RGBA"), dtype=float) / 255.0, np.asarray(vis.uv, dtype=float)


def render_mesh_png(mesh: Any, size: tuple[int, int] = (640, 480), *, azimuth: float = 35.0,
                    elevation: float = 25.0, up: str = "z", face_colors: np.ndarray | None = None,
                    lit: bool = True, smooth: bool = True,
                    light: tuple[float, float, float] | None = None,
                    background: tuple[int, int, int] = (255, 255, 255), margin: float = 0.06,
                    supersample: int = 2, provenance: dict | None = None) -> bytes:
    """PNG bytes of ``mesh`` (a trimesh.Trimesh) seen from a fixed orthographic camera.

    Colours: ``face_colors`` if given, else the texture sampled per pixel at the interpolated
    UV, else vertex/face colours, else grey; texels/faces with alpha < 0.5 are holes.
    ``lit``: two-sided Lambert (ambient 0.35) from ``light`` (default: upper left, behind the
    camera), with per-pixel interpolated vertex normals when ``smooth``.  Pass ``lit=False``
    for colours that are already shaded.
    """
    v = np.asarray(mesh.vertices, dtype=float)
    f = np.asarray(mesh.faces, dtype=np.int64)
    ss = max(1, int(supersample))
    if len(f) == 0:
        ids = -np.ones((int(size[1]) * ss, int(size[0]) * ss), np.int64)
        return encode_png(np.zeros((0, 3)), ids, size, background, provenance)
    eye, right, sup = camera_basis(azimuth, elevation, up)
    proj = project(v, size, azimuth=azimuth, elevation=elevation, up=up, margin=margin,
                   supersample=ss)
    fcol = mesh_face_colors(mesh) if face_colors is None else np.asarray(face_colors, dtype=float)
    if fcol.shape[1] == 3:
        fcol = np.column_stack([fcol, np.ones(len(fcol))])
    ids = face_id_buffer(proj, f, fcol[:, 3] >= 0.5)
    rows, cols, tri, bc = pixel_barycentric(proj, f, ids)
    tex = _texture_lookup(mesh) if face_colors is None else None
    if tex is not None:
        img, uv = tex
        puv = np.einsum("nk,nkd->nd", bc, uv[f[tri]])
        h, w = img.shape[:2]
        x = np.clip((puv[:, 0] % 1.0) * w, 0, w - 1).astype(int)
        y = np.clip((1.0 - puv[:, 1] % 1.0) * h, 0, h - 1).astype(int)
        pix = img[y, x]
    else:
        pix = fcol[tri]
    hole = pix[:, 3] < 0.5
    rgb = pix[:, :3]
    if lit:
        if smooth:                          # welded: UV seams shade smoothly
            vn = vertex_normals(v, f, weld=True)
            n = np.einsum("nk,nkd->nd", bc, vn[f[tri]])
        else:
            n = triangle_cross(v, f)[tri]
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        ld = (0.45 * right + 0.6 * sup + 0.66 * eye) if light is None else np.asarray(light, float)
        ld = ld / np.linalg.norm(ld)
        rgb = rgb * (0.35 + 0.65 * np.abs(n @ ld))[:, None]
    ids[rows[hole], cols[hole]] = -1
    return encode_png(np.clip(rgb[~hole], 0, 1), ids, size, background, provenance)


#: an image side in pixels: an exporter option checked at ``procgen check`` (0 draws nothing)
Pixels = Annotated[int, ParamInfo(ge=1, units="px")]


def preview_png(domain: Any, *, stem: str = "", provenance: dict | None = None,
                color_field: str | None = None, uv_field: str | None = None,
                texture_field: str | None = None, width: Pixels = 640, height: Pixels = 480,
                azimuth: float = 35.0, elevation: float = 25.0, up: UpAxis = "z", lit: bool = True,
                edges: bool = False, normals: float = 0.0) -> bytes:
    """Exporter: a TriMesh seen from a fixed camera as PNG (gallery thumbnails of any mesh).

    Uses the same colour sources as the OBJ/GLB exporters (vertex colours, or UV + texture).
    ``edges`` draws the visible triangle edges, ``normals`` > 0 the visible vertex normals as
    white strokes of that length (a fraction of the mesh's size): the input triangles "with
    their normal vertex vectors in white" of the 3DSCA thesis's plates 3.1(a) and 4.1(a).
    """
    from ..domains import TriMesh
    from ..errors import InputError
    from .glb import mesh_for_export

    if not isinstance(domain, TriMesh):
        raise InputError(f"preview_png: expected a TriMesh, got {domain.kind}")
    if normals < 0 or not np.isfinite(normals):
        raise InputError(f"preview_png: normals must be a length >= 0, got {normals!r}")
    mesh = mesh_for_export(domain, color_field=color_field, uv_field=uv_field, texture_field=texture_field)
    png = render_mesh_png(mesh, (width, height), azimuth=azimuth, elevation=elevation, up=up, lit=lit,
                          smooth=not (edges or normals), provenance=provenance)
    if not (edges or normals):
        return png
    return _overlay_lines(png, np.asarray(domain.vertices, float), np.asarray(domain.faces, np.int64),
                          (width, height), azimuth=azimuth, elevation=elevation, up=up, edges=edges,
                          normals=normals, provenance=provenance)


def _overlay_lines(png: bytes, v: np.ndarray, f: np.ndarray, size: tuple[int, int], *, azimuth: float,
                   elevation: float, up: str, edges: bool, normals: float,
                   provenance: dict | None = None) -> bytes:
    """Draw the visible edges (dark) and vertex normals (white) over a rendered mesh PNG.

    A vertex is visible when the face drawn at its pixel is not nearer the eye there than the
    vertex (1 % of the mesh's extent of slack); an edge when both its ends are.
    """
    from PIL import Image, ImageDraw

    eye = camera_basis(azimuth, elevation, up)[0]
    proj = project(v, size, azimuth=azimuth, elevation=elevation, up=up, supersample=1)
    ids = face_id_buffer(proj, f)
    x = np.clip(proj.px.astype(int), 0, proj.width - 1)
    y = np.clip(proj.py.astype(int), 0, proj.height - 1)
    front = np.maximum(ids[y, x], 0)
    corners = np.stack([proj.px[f[front]], proj.py[f[front]]], axis=2)              # (n, 3, 2)
    bc = barycentric(corners, np.column_stack([proj.px, proj.py]))
    depth_front = np.where(ids[y, x] >= 0, np.sum(bc * proj.depth[f[front]], axis=1), -np.inf)
    slack = 0.01 * float(np.ptp(v, axis=0).max())
    visible = depth_front <= proj.depth + slack
    img = Image.open(io.BytesIO(png)).convert("RGB")
    draw = ImageDraw.Draw(img)
    if edges:
        e = np.unique(np.sort(np.concatenate([f[:, [0, 1]], f[:, [1, 2]], f[:, [2, 0]]]), axis=1), axis=0)
        e = e[visible[e[:, 0]] & visible[e[:, 1]]]
        for a, b in e.tolist():                      # one stroke per edge (a few thousand at most)
            draw.line([(proj.px[a], proj.py[a]), (proj.px[b], proj.py[b])], fill=(40, 40, 40), width=1)
    if normals:
        vn = vertex_normals(v, f)
        tip = project(np.vstack([v, v + normals * float(np.ptp(v, axis=0).max()) * vn]), size,
                      azimuth=azimuth, elevation=elevation, up=up, supersample=1, frame=v)
        n = len(v)
        show = visible & (vn @ eye > -0.2)
        for i in np.nonzero(show)[0].tolist():
            draw.line([(tip.px[i], tip.py[i]), (tip.px[n + i], tip.py[n + i])], fill=(255, 255, 255), width=2)
    from .image import png_bytes

    return png_bytes(np.asarray(img), provenance)
