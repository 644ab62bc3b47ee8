"""Headless mesh preview: a fixed-camera orthographic render to PNG bytes (no GPU, no display).

Painter's algorithm (triangles sorted far to near, drawn with Pillow at 2x then downsampled):
cheap, dependable, and good enough for the small, dense triangles of exported 3DSCA meshes.
Colours come from ``face_colors``, else the mesh's texture (sampled at each face's centroid UV),
vertex or face colours; faces whose alpha is below 0.5 (holes) are not drawn.
"""
from __future__ import annotations

import io
from typing import Any

import numpy as np

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


def render_mesh_png(mesh: Any, size: tuple[int, int] = (640, 480), *, azimuth: float = 35.0,
                    elevation: float = 25.0, up: str = "z", face_colors: np.ndarray | None = None,
                    lit: bool = True, light: tuple[float, float, float] | None = None,
                    background: tuple[int, int, int] = (255, 255, 255), margin: float = 0.06,
                    supersample: int = 2) -> bytes:
    """PNG bytes of ``mesh`` (a trimesh.Trimesh) seen from a fixed orthographic camera.

    ``lit``: multiply colours by a two-sided Lambert term (ambient 0.35) from ``light``
    (default: from the upper left behind the camera).  Pass ``lit=False`` with colours that are
    already shaded (e.g. per-cell Phong through layers).
    """
    from PIL import Image, ImageDraw

    w, h = int(size[0]), int(size[1])
    v = np.asarray(mesh.vertices, dtype=float)
    f = np.asarray(mesh.faces, dtype=np.int64)
    eye, right, sup = camera_basis(azimuth, elevation, up)
    col = mesh_face_colors(mesh) if face_colors is None else np.asarray(face_colors, dtype=float)
    if col.shape[1] == 3:
        col = np.column_stack([col, np.ones(len(col))])
    if lit and len(f):
        n = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
        n /= np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-300)
        ld = (0.45 * right + 0.6 * sup + 0.66 * eye) if light is None else np.asarray(light, float)
        ld = ld / np.linalg.norm(ld)
        shade = 0.35 + 0.65 * np.abs(n @ ld)
        col = np.column_stack([col[:, :3] * shade[:, None], col[:, 3]])
    ss = max(1, int(supersample))
    W, H = w * ss, h * ss
    img = Image.new("RGB", (W, H), tuple(int(c) for c in background))
    if len(f):
        x, y, z = v @ right, v @ sup, v @ eye
        cx, cy = (x.max() + x.min()) / 2, (y.max() + y.min()) / 2
        span = max(x.max() - x.min(), (y.max() - y.min()) * W / H, 1e-12)
        scale = W * (1 - 2 * margin) / span
        px = (x - cx) * scale + W / 2
        py = H / 2 - (y - cy) * scale
        draw = ImageDraw.Draw(img)
        keep = col[:, 3] >= 0.5
        order = np.argsort(z[f].mean(axis=1), kind="stable")
        order = order[keep[order]]
        rgb = np.clip(np.round(col[:, :3] * 255), 0, 255).astype(np.uint8)
        tri = np.stack([px[f], py[f]], axis=2)                   # (m, 3, 2)
        for t in order:                                          # drawing loop (preview only)
            c = tuple(int(k) for k in rgb[t])
            draw.polygon([tuple(p) for p in tri[t]], fill=c, outline=c)
    if ss > 1:
        img = img.resize((w, h), Image.LANCZOS)
    buf = io.BytesIO()
    img.save(buf, format="PNG")
    return buf.getvalue()
