"""procgen.geometry (the one copy of each triangle formula), mesh.lathe and clean_mesh."""
from __future__ import annotations

import numpy as np
import pytest
import shapely
import trimesh
from hypothesis import given, settings, strategies as st

from procgen import InputError, Polylines, RecipeError, State
from procgen.builtin.meshes import clean_mesh
from procgen.builtin.solids import Lathe
from procgen.domains import TriMesh
from procgen.geometry import (barycentric, ccw_faces, ccw_ring, face_normals, orient2d, signed_area,
                              vertex_normals)
from procgen.recipes import check_recipe
from procgen.runner import run


def test_vertex_normals_match_a_face_by_face_reference_and_weld_across_seams():
    m = trimesh.creation.uv_sphere(count=[8, 12])
    v, f = np.asarray(m.vertices), np.asarray(m.faces)
    ref = np.zeros_like(v)
    for tri in f:                                   # the textbook loop, as an independent reference
        n = np.cross(v[tri[1]] - v[tri[0]], v[tri[2]] - v[tri[0]])
        ref[tri] += n
    used = np.linalg.norm(ref, axis=1) > 0
    np.testing.assert_allclose(vertex_normals(v, f)[used], ref[used] / np.linalg.norm(ref[used], axis=1)[:, None],
                               atol=1e-12)
    np.testing.assert_allclose(face_normals(v, f), m.face_normals, atol=1e-12)
    # split the faces along a seam: the copies shade differently unless welded
    seam = np.isclose(v[:, 1], 0) & (v[:, 0] > 1e-9)
    copy = np.nonzero(seam)[0]
    v2 = np.vstack([v, v[copy]])
    f2 = f.copy()
    east = v[f].mean(axis=1)[:, 1] > 0
    remap = np.arange(len(v))
    remap[copy] = len(v) + np.arange(len(copy))
    f2[east] = remap[f2[east]]
    plain, welded = vertex_normals(v2, f2), vertex_normals(v2, f2, weld=True)
    assert np.abs(plain[copy] - plain[len(v):]).max() > 0.1
    np.testing.assert_allclose(welded[copy], welded[len(v):], atol=1e-12)
    np.testing.assert_allclose(welded[copy], vertex_normals(v, f)[copy], atol=1e-12)


@settings(max_examples=50, deadline=None)
@given(st.integers(0, 2**31 - 1), st.sampled_from([2, 3]))
def test_barycentric_coordinates_rebuild_the_point(seed, dim):
    rng = np.random.default_rng(seed)
    corners = rng.normal(size=(200, 3, dim))
    w = rng.dirichlet(np.ones(3), size=200) * 1.6 - 0.2          # inside and outside
    p = np.einsum("nk,nkd->nd", w, corners)
    bc = barycentric(corners, p)
    ok = np.abs(orient2d(*(corners[:, k, :2] for k in range(3)))) > 1e-3 if dim == 2 else \
        np.linalg.norm(np.cross(corners[:, 1] - corners[:, 0], corners[:, 2] - corners[:, 0]), axis=1) > 1e-3
    np.testing.assert_allclose(bc[ok], w[ok], atol=1e-7)
    np.testing.assert_allclose(bc.sum(axis=1), 1.0, atol=1e-9)


def test_shoelace_and_orientation_agree_with_shapely():
    rng = np.random.default_rng(4)
    for _ in range(20):
        ring = np.asarray(shapely.Polygon(rng.random((12, 2))).convex_hull.exterior.coords)[:-1]
        for r in (ring, ring[::-1]):
            poly = shapely.Polygon(r)
            assert signed_area(r) == pytest.approx(poly.area * (1 if poly.exterior.is_ccw else -1), rel=1e-12)
            assert shapely.Polygon(ccw_ring(r)).exterior.is_ccw
    pts = rng.random((300, 2))
    from scipy.spatial import Delaunay
    faces = Delaunay(pts).simplices
    faces[::2] = faces[::2, ::-1]                                  # half of them clockwise
    fixed = ccw_faces(pts, faces)
    assert (orient2d(pts[fixed[:, 0]], pts[fixed[:, 1]], pts[fixed[:, 2]]) > 0).all()
    assert np.array_equal(np.sort(fixed, axis=1), np.sort(faces, axis=1))


def _lathe(host, **params):
    return run(check_recipe({"steps": [{"rule": "mesh.lathe", "params": params}]}, host, "t.toml"), host).state


def test_lathe_ring_and_open_profiles_and_polylines_input(host):
    # plate 2-9's ring: 4 profile points x 4 sections = 32 facets, closed, outward
    ring = [[0.7, 0.0], [1.0, -0.3], [1.3, 0.0], [1.0, 0.3]]
    m = _lathe(host, profile=ring, loop=True, sections=4).get("mesh")
    assert m.n_faces == 32 and m.to_trimesh().is_watertight and m.to_trimesh().volume > 0
    # Pappus: volume = 2 pi (centroid radius) (profile area) for a fine revolution
    fine = _lathe(host, profile=ring, loop=True, sections=512).get("mesh").to_trimesh()
    area = shapely.Polygon(ring).area
    assert fine.volume == pytest.approx(2 * np.pi * 1.0 * area, rel=1e-3)
    # an open profile gives an open tube whose seam is welded: two boundary loops, no more
    tube = _lathe(host, profile=[[1.0, 0.0], [1.2, 0.5], [1.0, 1.0]], sections=48).get("mesh")
    assert not tube.to_trimesh().is_watertight
    from procgen.builtin.meshes import boundary_loops
    assert len(boundary_loops(tube)) == 2
    # the same points given as a Polylines give the same mesh
    st = State(seed=1)
    st.add_domain("p", Polylines.from_list([np.array(ring)], closed=True))
    Lathe(lines="p", sections=4).step(st)
    np.testing.assert_array_equal(st.get("mesh").faces, m.faces)
    np.testing.assert_allclose(st.get("mesh").vertices, m.vertices)


@pytest.mark.parametrize("params,match", [
    ({}, "exactly one of profile"),
    ({"profile": [[0, 0], [1, 1]], "lines": "outline"}, "exactly one of profile"),
    ({"lines": "outline", "loop": True}, "loop goes with profile"),
    ({"profile": [[0, 0, 1], [1, 1, 0]]}, r"\[r, z\]"),
])
def test_lathe_bad_input_is_one_line(host, params, match):
    with pytest.raises(RecipeError, match=match) as exc:
        check_recipe({"steps": [{"rule": "mesh.lathe", "params": params}]}, host, "t.toml")
    assert "\n" not in str(exc.value)


def test_clean_mesh_drops_duplicates_degenerates_and_unused_vertices():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [1, 1, 0], [0.5, 0, 0], [1, 0, 1e-13], [9, 9, 9]], float)
    f = np.array([[0, 1, 2], [1, 3, 2], [2, 1, 0],     # a duplicate (reversed) face
                  [0, 4, 1],                          # collinear: zero area
                  [5, 3, 2]])                         # vertex 5 is vertex 1 within 1e-9: a duplicate
    m = clean_mesh(TriMesh(v, f))
    assert m.n_faces == 2 and m.n_vertices == 4
    assert (m.face_areas > 0).all() and m.face_areas.sum() == pytest.approx(1.0)
    with pytest.raises(InputError, match="degenerate"):
        clean_mesh(TriMesh(v, np.array([[0, 4, 1]])))
