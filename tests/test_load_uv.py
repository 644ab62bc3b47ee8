"""A textured OBJ's own UVs: kept by mesh.load per face corner (seams included) and used to
sample an image on mesh faces (mesh.image_field) and on surface cells (surface.image_field)."""
from __future__ import annotations

import numpy as np
import pytest
from PIL import Image

from procgen.errors import InputError
from procgen.recipes import check_recipe
from procgen.runner import run

ROWS, COLS = 48, 64


def _texture(path) -> None:
    """A 16-bit grey image whose pixel (row, col) holds 1000 col + 50 row: linear, so a bilinear
    lookup is exact and every sample has a closed form."""
    rr, cc = np.mgrid[0:ROWS, 0:COLS]
    Image.fromarray((1000 * cc + 50 * rr).astype(np.uint16)).save(path)


def _expected(uv: np.ndarray) -> np.ndarray:
    col = uv[..., 0] * COLS - 0.5
    row = (1.0 - uv[..., 1]) * ROWS - 0.5            # v = 1 is the image's top row
    return (1000 * col + 50 * row) / 65535


def _chart(xy: np.ndarray, right: np.ndarray) -> np.ndarray:
    """UV of a point of the 2 x 1 sheet: the left square maps to u in [0.05, 0.45], the right one
    to u in [0.55, 0.95] (two charts: the edge x = 1 is a seam with two UVs per vertex)."""
    u = np.where(right, 0.55 + 0.4 * (xy[..., 0] - 1.0), 0.05 + 0.4 * xy[..., 0])
    return np.stack([u, 0.05 + 0.9 * xy[..., 1]], axis=-1)


def _sheet_obj(path, n: int = 4) -> None:
    """A flat 2 x 1 sheet of 2 n x n quads split into triangles, written with a UV seam at x = 1."""
    xs, ys = np.linspace(0, 2, 2 * n + 1), np.linspace(0, 1, n + 1)
    vid = {}
    lines, vts = [], []
    for j, y in enumerate(ys):
        for i, x in enumerate(xs):
            vid[i, j] = len(vid) + 1
            lines.append(f"v {x:.9g} {y:.9g} 0")

    def vt(i: int, j: int, right: bool) -> int:
        vts.append(_chart(np.array([xs[i], ys[j]]), np.array(right)))
        return len(vts)

    faces = []
    for j in range(n):
        for i in range(2 * n):
            right = i >= n
            c = [(i, j), (i + 1, j), (i + 1, j + 1), (i, j + 1)]
            t = [vt(a, b, right) for a, b in c]
            faces.append(" ".join(f"{vid[a, b]}/{k}" for (a, b), k in zip(c, t)))   # a quad: triangulated
    lines += [f"vt {u:.12g} {v:.12g}" for u, v in vts] + [f"f {f}" for f in faces]
    path.write_text("\n".join(lines) + "\n")


def _run(host, tmp_path, steps):
    recipe = check_recipe({"steps": steps}, host, str(tmp_path / "r.toml"), tmp_path)
    return run(recipe, host, progress=False).state


def test_mesh_load_keeps_corner_uvs_across_a_seam_and_samples_the_texture(host, tmp_path):
    _sheet_obj(tmp_path / "sheet.obj")
    _texture(tmp_path / "tex.png")
    st = _run(host, tmp_path, [{"rule": "mesh.load", "params": {"path": "sheet.obj"}},
                               {"rule": "mesh.image_field", "params": {"file": "tex.png", "field": "paint__value"}}])
    m = st.domains["mesh"]
    assert m.n_vertices == 9 * 5                      # the seam is welded: one surface ...
    assert m.n_faces == 2 * 32
    corners = m.vertices[m.faces][..., :2]
    right = corners[..., 0].mean(axis=1) > 1.0
    uv = m["mesh__uv"]
    # ... with both sides' UVs kept per corner (seam vertices have u = 0.45 on the left, 0.55 on the right)
    np.testing.assert_allclose(uv, _chart(corners, right[:, None]), atol=1e-9)
    on_seam = np.isclose(corners[..., 0], 1.0)
    assert set(np.round(uv[on_seam][:, 0], 9)) == {0.45, 0.55}
    np.testing.assert_allclose(m["paint__value"], _expected(uv.mean(axis=1)), atol=1e-9)


def test_surface_image_field_interpolates_corner_uvs_at_each_cell_centre(host, tmp_path):
    _sheet_obj(tmp_path / "sheet.obj")
    _texture(tmp_path / "tex.png")
    st = _run(host, tmp_path, [{"rule": "mesh.load", "params": {"path": "sheet.obj"}},
                               {"rule": "surface.cells", "params": {"cell_size": 0.03}},
                               {"rule": "surface.image_field", "params": {"file": "tex.png", "field": "paint__value"}}])
    sc = st.domains["cells"]
    value = sc["paint__value"]
    face_right = sc.vertices[sc.faces][:, :, 0].mean(axis=1) > 1.0
    want = _expected(_chart(sc.center3d[:, :2], face_right[sc.face]))
    inside = sc.comp_in
    assert inside.sum() > 1500
    np.testing.assert_allclose(value[inside], want[inside], atol=1e-9)   # centre in its triangle: exact
    # a PART-IN centre lies up to half a cell outside its triangle: clamped, so off by at most
    # the texture's change over half a cell diagonal, and never the other chart's value
    slope = np.hypot(1000 * COLS * 0.4, 50 * ROWS * 0.9) / 65535
    assert np.all(np.abs(value - want) <= slope * 0.03 * np.sqrt(2) / 2 + 1e-9)


def test_surface_image_field_without_uvs_is_one_line(host, tmp_path):
    _texture(tmp_path / "tex.png")
    with pytest.raises(InputError, match="no UV field 'mesh__uv'"):
        _run(host, tmp_path, [{"rule": "mesh.primitive", "params": {"shape": "icosphere", "subdivisions": 1}},
                              {"rule": "surface.cells", "params": {"target_cells": 500}},
                              {"rule": "surface.image_field", "params": {"file": "tex.png"}}])
