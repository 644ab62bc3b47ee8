"""The preview's z-buffer rasteriser (procgen.exchange.preview.face_id_buffer) against independent
references: a brute-force per-pixel, per-face barycentric test with depth; the Pillow polygon
painter it replaced (kept here), differing only on pixels at a triangle edge; and occlusion
(the nearer face wins, also where faces interpenetrate, where a painter's order fails)."""
from __future__ import annotations

import numpy as np
import pytest

from procgen.exchange.preview import Projection, camera_basis, face_id_buffer, project


def _brute(proj: Projection, faces: np.ndarray, keep: np.ndarray | None = None):
    """(ids, inside (faces, H, W), depth (faces, H, W)): every face tested at every pixel centre."""
    cx, cy = np.meshgrid(np.arange(proj.width) + 0.5, np.arange(proj.height) + 0.5)
    x, y, z = (a[faces][:, :, None, None] for a in (proj.px, proj.py, proj.depth))
    det = (x[:, 1] - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (y[:, 1] - y[:, 0])
    b1 = ((cx - x[:, 0]) * (y[:, 2] - y[:, 0]) - (x[:, 2] - x[:, 0]) * (cy - y[:, 0])) / det
    b2 = ((x[:, 1] - x[:, 0]) * (cy - y[:, 0]) - (cx - x[:, 0]) * (y[:, 1] - y[:, 0])) / det
    inside = (b1 >= 0) & (b2 >= 0) & (b1 + b2 <= 1)
    if keep is not None:
        inside &= keep[:, None, None]
    depth = z[:, 0] + b1 * (z[:, 1] - z[:, 0]) + b2 * (z[:, 2] - z[:, 0])
    d = np.where(inside, depth, -np.inf)
    return np.where(inside.any(axis=0), d.argmax(axis=0), -1), inside, depth


def _pil_painter(proj: Projection, faces: np.ndarray) -> np.ndarray:
    """The renderer's former face-id buffer: Pillow polygons drawn far to near by mean depth."""
    from PIL import Image, ImageDraw

    img = Image.new("I", (proj.width, proj.height), 0)
    draw = ImageDraw.Draw(img)
    order = np.argsort(proj.depth[faces].mean(axis=1), kind="stable")
    for t in order.tolist():
        draw.polygon(np.column_stack([proj.px[faces[t]], proj.py[faces[t]]]).ravel().tolist(), fill=t + 1)
    return np.asarray(img, dtype=np.int64) - 1


def _edge_distance(proj: Projection, faces: np.ndarray, face: np.ndarray, rows: np.ndarray,
                   cols: np.ndarray) -> np.ndarray:
    """Distance (pixels) from each pixel centre to the nearest edge of its given face."""
    p = np.column_stack([cols + 0.5, rows + 0.5])
    corners = np.stack([proj.px[faces[face]], proj.py[faces[face]]], axis=2)          # (n, 3, 2)
    best = np.full(len(p), np.inf)
    for a, b in ((0, 1), (1, 2), (2, 0)):
        e = corners[:, b] - corners[:, a]
        t = np.clip(np.sum((p - corners[:, a]) * e, axis=1) / np.maximum(np.sum(e * e, axis=1), 1e-300), 0, 1)
        best = np.minimum(best, np.linalg.norm(corners[:, a] + t[:, None] * e - p, axis=1))
    return best


def _random_soup(rng: np.random.Generator, n: int, size: float) -> tuple[Projection, np.ndarray]:
    """``n`` random triangles of about ``size`` pixels at random depths over a 64 x 48 image,
    overlapping and interpenetrating (depth varies across each triangle)."""
    centre = rng.uniform([-8, -8], [72, 56], (n, 1, 2))
    pts = (centre + rng.normal(0, size, (n, 3, 2))).reshape(-1, 2)
    depth = (rng.uniform(-5, 5, (n, 1)) + rng.normal(0, 2, (n, 3))).ravel()
    return Projection(pts[:, 0], pts[:, 1], depth, 64, 48), np.arange(3 * n).reshape(n, 3)


@pytest.mark.parametrize("size", [0.7, 4.0, 25.0])
def test_matches_brute_force_per_pixel_depth_test(size):
    """Every pixel: the face whose triangle holds the centre and is nearest there (random
    overlapping, interpenetrating, partly off-screen triangles, sub-pixel to image-sized).
    A pixel may differ only where the brute force's face and ours are equally valid: both
    contain the centre (within rounding) at the same depth."""
    rng = np.random.default_rng(int(size * 10))
    proj, faces = _random_soup(rng, 150, size)
    keep = rng.random(len(faces)) > 0.1
    ref, inside, depth = _brute(proj, faces, keep)
    ids = face_id_buffer(proj, faces, keep)
    assert ids.shape == (48, 64)
    assert (ref >= 0).sum() > 20
    diff = np.argwhere(ids != ref)
    assert len(diff) <= 2, diff                                     # ties only: on a shared line
    for r, c in diff:
        a, b = ref[r, c], ids[r, c]
        assert a >= 0 and b >= 0 and keep[b]
        assert abs(depth[a, r, c] - depth[b, r, c]) < 1e-6


def test_nearer_face_wins_and_holes_show_what_is_behind():
    """Two overlapping triangles: the nearer one is drawn whichever comes first in the list;
    left out (keep), the far one shows in its place.  Two interpenetrating triangles: each
    pixel shows the one in front there (a painter's order by mean depth shows one whole)."""
    px = np.array([5.0, 40, 5, 10, 45, 10])
    py = np.array([5.0, 5, 40, 10, 10, 45])
    for near_first in (True, False):
        depth = np.array([1.0, 1, 1, 2, 2, 2]) if not near_first else np.array([2.0, 2, 2, 1, 1, 1])
        proj = Projection(px, py, depth, 50, 50)
        faces = np.array([[0, 1, 2], [3, 4, 5]])
        near = 0 if near_first else 1
        ids = face_id_buffer(proj, faces)
        assert ids[20, 20] == near and ids[7, 7] == 0 and ids[40, 12] == 1
        keep = np.arange(2) != near
        assert face_id_buffer(proj, faces, keep)[20, 20] == 1 - near
    # a tilted face cutting through a flat one along x = 25
    proj = Projection(np.array([0.0, 50, 0, 0, 50, 0]), np.array([0.0, 0, 50, 0, 0, 50]),
                      np.array([0.0, 0, 0, -1, 1, -1]), 50, 50)
    faces = np.array([[0, 1, 2], [3, 4, 5]])
    ids = face_id_buffer(proj, faces)
    assert (ids[5, 2:20] == 0).all() and (ids[5, 30:44] == 1).all()
    assert ((ids[1:24, 1:24] == 0) | (ids[1:24, 1:24] == -1)).all()
    painter = _pil_painter(proj, faces)
    assert len(np.unique(painter[painter >= 0])) == 1                # the painter shows one face only


def test_same_picture_as_the_pillow_painter_up_to_edge_pixels():
    """A closed, convex mesh (a sphere, painter's order exact there) rendered by the former
    Pillow painter and by the rasteriser: the pictures differ only on pixels whose centre is
    within a pixel of an edge of the face either one put there, and on few of those."""
    import trimesh

    mesh = trimesh.creation.icosphere(subdivisions=3)
    v, f = np.asarray(mesh.vertices), np.asarray(mesh.faces, np.int64)
    proj = project(v, (160, 120), azimuth=35.0, elevation=25.0, up="z")
    ids, old = face_id_buffer(proj, f), _pil_painter(proj, f)
    assert (ids >= 0).sum() > 20_000
    diff = ids != old
    rows, cols = np.nonzero(diff & (ids >= 0) & (old >= 0))
    assert len(rows)
    d = np.minimum(_edge_distance(proj, f, ids[rows, cols], rows, cols),
                   _edge_distance(proj, f, old[rows, cols], rows, cols))
    assert d.max() <= 1.0
    silhouette = np.nonzero(diff & ((ids < 0) | (old < 0)))
    face = np.where(ids[silhouette] >= 0, ids[silhouette], old[silhouette])
    assert _edge_distance(proj, f, face, *silhouette).max() <= 1.0
    assert diff.mean() < 0.1
    # visible faces all face the eye (correct occlusion on a closed convex mesh)
    normals = np.asarray(mesh.face_normals)
    eye = camera_basis(35.0, 25.0, "z")[0]
    assert (normals[np.unique(ids[ids >= 0])] @ eye > -1e-9).all()


def test_a_tiled_plane_has_no_pinholes_and_big_faces_are_cut_at_the_image():
    """A regular triangulated grid (shared edges through pixel centres, and not): every centre
    inside the grid is covered; a triangle far larger than the image fills it all."""
    n = 12
    g = np.stack(np.meshgrid(np.arange(n + 1), np.arange(n + 1)), axis=-1).reshape(-1, 2).astype(float)
    q = (np.arange(n)[:, None] * (n + 1) + np.arange(n)[None, :]).ravel()
    faces = np.concatenate([np.column_stack([q, q + 1, q + n + 2]), np.column_stack([q, q + n + 2, q + n + 1])])
    for cell, offset in ((4.0, 0.0), (4.0, 0.5), (3.3, 0.25)):
        pts = g * cell + 2 + offset
        proj = Projection(pts[:, 0], pts[:, 1], np.zeros(len(pts)), 60, 60)
        ids = face_id_buffer(proj, faces)
        c = np.arange(60) + 0.5
        inner = ((c[:, None] > pts[:, 1].min()) & (c[:, None] < pts[:, 1].max())
                 & (c[None, :] > pts[:, 0].min()) & (c[None, :] < pts[:, 0].max()))
        assert (ids[inner] >= 0).all(), (cell, offset)
        lo, hi = pts.min(axis=0) - 1e-6, pts.max(axis=0) + 1e-6
        outer = ((c[:, None] < lo[1]) | (c[:, None] > hi[1]) | (c[None, :] < lo[0]) | (c[None, :] > hi[0]))
        assert (ids[outer] < 0).all() and (~inner & ~outer).any() == (offset == 0.5)
    big = Projection(np.array([-5000.0, 9000, -5000]), np.array([-5000.0, -5000, 9000]), np.zeros(3), 70, 30)
    assert (face_id_buffer(big, np.array([[0, 1, 2]])) == 0).all()
    assert (face_id_buffer(big, np.array([[0, 1, 2]]), np.array([False])) == -1).all()
    flat = Projection(np.array([1.0, 20, 40]), np.array([1.0, 20, 40]), np.zeros(3), 50, 50)
    assert (face_id_buffer(flat, np.array([[0, 1, 2]])) == -1).all()     # edge-on: covers nothing


@pytest.mark.parametrize("channels", [3, 4])
def test_array_texture_renders_as_the_pillow_image(channels):
    """A textured mesh whose material holds the atlas as an ArrayTexture (crack_png: no 16 Mpx
    trip through Pillow) renders to the same bytes as with the PIL image; alpha < 0.5 texels
    are holes either way, and an RGB texture is opaque."""
    import trimesh

    from procgen.domains import TriMesh
    from procgen.exchange.glb import mesh_for_export
    from procgen.exchange.preview import ArrayTexture, render_mesh_png

    m = TriMesh.from_trimesh(trimesh.creation.icosphere(subdivisions=2))
    uv = np.random.default_rng(4).random((m.n_faces, 3, 2))
    m.add_field("surface__uv", uv, at="face")
    tex = np.random.default_rng(5).random((32, 24, channels))
    if channels == 4:
        tex[..., 3] = (tex[..., 3] > 0.3).astype(float)
    m.add_field("surface__texture", tex, at="domain")
    pil = mesh_for_export(m, uv_field="surface__uv", texture_field="surface__texture")
    arr = mesh_for_export(m, uv_field="surface__uv", texture_field="surface__texture", image=ArrayTexture)
    assert isinstance(arr.visual.material.baseColorTexture, ArrayTexture)
    a, b = render_mesh_png(pil, (90, 70)), render_mesh_png(arr, (90, 70))
    assert a == b
    with pytest.raises(ValueError):
        ArrayTexture(np.zeros((4, 4, 3)))
