"""Built-in generic rules checked against independent references and geometric invariants."""
from __future__ import annotations

import numpy as np
import pytest
import shapely
from scipy.spatial import cKDTree

from procgen import InputError, RecipeError
from procgen.builtin.lines import chaikin
from procgen.builtin.meshes import boundary_loops, clean_mesh, load_mesh_file
from procgen.noise import fbm_spectral, midpoint_displacement
from procgen.recipes import check_recipe
from procgen.runner import run

from _meshes import quad_obj
from _paths import MESHES


def _run(host, steps, seed=1):
    return run(check_recipe({"steps": steps}, host, "t.toml"), host, seed=seed).state


def test_delaunay_is_ccw_and_empty_circle(host):
    st = _run(host, [{"rule": "points.poisson_disk", "params": {"radius": 0.05}}, {"rule": "mesh.delaunay"}])
    m = st.get("tessellation")
    v, f = m.vertices, m.faces
    a, b, c = v[f[:, 0]], v[f[:, 1]], v[f[:, 2]]
    cross = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0])
    assert (cross > 0).all()
    # empty circumcircle: no vertex strictly inside any triangle's circumcircle
    d = 2 * (a[:, 0] * (b[:, 1] - c[:, 1]) + b[:, 0] * (c[:, 1] - a[:, 1]) + c[:, 0] * (a[:, 1] - b[:, 1]))
    sa, sb, sc = (a ** 2).sum(1), (b ** 2).sum(1), (c ** 2).sum(1)
    ux = (sa * (b[:, 1] - c[:, 1]) + sb * (c[:, 1] - a[:, 1]) + sc * (a[:, 1] - b[:, 1])) / d
    uy = (sa * (c[:, 0] - b[:, 0]) + sb * (a[:, 0] - c[:, 0]) + sc * (b[:, 0] - a[:, 0])) / d
    r = np.hypot(a[:, 0] - ux, a[:, 1] - uy)
    ok = r < 0.5  # skip the thin hull slivers, whose circles are huge and numerically loose
    nearest, _ = cKDTree(v).query(np.column_stack([ux, uy])[ok])
    assert (nearest >= r[ok] * (1 - 1e-9)).all()
    # Euler: V - E + F = 1 for a triangulated disc
    assert m.n_vertices - len(m.edges) + m.n_faces == 1


def test_load_quads_are_triangulated(host, tmp_path):
    path, quads, tris = quad_obj(tmp_path / "quads.obj")
    st = _run(host, [{"rule": "mesh.load", "params": {"path": str(path)}}])
    raw = load_mesh_file(path)
    assert raw.n_faces == quads * 2 + tris      # every quad became two triangles
    m = st.get("mesh")                          # cleaned: welded, no degenerate/duplicate faces
    assert m.n_faces <= raw.n_faces and (m.face_areas > 0).all()
    assert len(np.unique(np.sort(m.faces, axis=1), axis=0)) == m.n_faces
    assert np.isclose(m.to_trimesh().area, raw.to_trimesh().area, rtol=1e-3)
    # the seam and pole copies are welded: the sphere is closed, genus 0
    assert raw.is_boundary_edge.any() and not m.is_boundary_edge.any()
    assert m.n_vertices - len(m.edges) + m.n_faces == 2


def test_load_open_mesh_keeps_boundary(host):
    m = clean_mesh(load_mesh_file(MESHES / "teapot.obj"))
    assert m.is_boundary_edge.any()
    assert len(boundary_loops(m)) >= 1


@pytest.mark.parametrize("content,match", [("", "no triangles"), ("v 0 0 0\nv 1 0 0\n", "no triangles"),
                                           ("this is not a mesh\n\x00\x01", "no triangles|cannot read")])
def test_broken_mesh_files_give_clear_errors(tmp_path, content, match):
    p = tmp_path / "broken.obj"
    p.write_text(content)
    with pytest.raises(InputError, match=match):
        load_mesh_file(p)


def test_missing_mesh_file_is_clear(host):
    """Refused at check, before any step runs (a RecipeError naming the step and the file)."""
    with pytest.raises(RecipeError, match=r"steps\[0\] \(mesh.load\).*no_such_mesh.obj' not found"):
        _run(host, [{"rule": "mesh.load", "params": {"path": "no_such_mesh.obj"}}])


@pytest.mark.parametrize("shape", ["icosphere", "cylinder", "torus", "cube", "tetrahedron"])
def test_closed_primitives_are_watertight(host, shape):
    m = _run(host, [{"rule": "mesh.primitive", "params": {"shape": shape, "subdivisions": 1}}]).get("mesh")
    tm = m.to_trimesh()
    assert tm.is_watertight and tm.volume > 0
    assert not m.is_boundary_edge.any()


def test_plane_primitive_is_open_and_flat(host):
    m = _run(host, [{"rule": "mesh.primitive", "params": {"shape": "plane", "subdivisions": 2}}]).get("mesh")
    assert np.allclose(m.vertices[:, 2], 0) and m.n_faces == 2 * 16
    assert len(boundary_loops(m)) == 1


def test_fbm_hurst_controls_roughness():
    rng = np.random.default_rng(0)
    for gen in (fbm_spectral, midpoint_displacement):
        rough = gen(np.random.default_rng(1), (128, 128), 0.2)
        smooth = gen(np.random.default_rng(1), (128, 128), 0.9)
        for a in (rough, smooth):
            assert abs(a.mean()) < 1e-9 and abs(a.std() - 1) < 1e-9
        # mean squared neighbour difference: rougher surfaces vary more between adjacent cells
        d = lambda a: np.mean(np.diff(a, axis=1) ** 2)
        assert d(rough) > 3 * d(smooth)
    del rng


def test_fbm_structure_function_slope():
    # E|h(x+l)-h(x)|^2 ~ l^(2H): check the fitted exponent for spectral synthesis
    h = fbm_spectral(np.random.default_rng(3), (512, 512), 0.7)
    lags = np.array([2, 4, 8, 16])
    s = [np.mean((h[:, lag:] - h[:, :-lag]) ** 2) for lag in lags]
    slope = np.polyfit(np.log(lags), np.log(s), 1)[0]
    assert 1.1 < slope < 1.7   # 2H = 1.4


def test_chaikin_keeps_closed_contour_simple_and_inside_hull():
    rng = np.random.default_rng(4)
    t = np.sort(rng.uniform(0, 2 * np.pi, 40))
    r = 1 + 0.3 * rng.random(40)
    ring = np.column_stack([r * np.cos(t), r * np.sin(t)])
    out = chaikin(ring, True, 4)
    assert len(out) == 40 * 16
    poly = shapely.Polygon(out)
    assert poly.is_valid and shapely.Polygon(ring).convex_hull.buffer(1e-9).contains(poly)
    line = np.array([[0, 0], [1, 1], [2, 0.0]])
    sm = chaikin(line, False, 2)
    assert np.allclose(sm[0], line[0]) and np.allclose(sm[-1], line[-1])


def test_grid_to_mesh_carries_fields(host):
    st = _run(host, [{"rule": "grid.noise", "params": {"nx": 20, "ny": 10}}, {"rule": "grid.to_mesh"}])
    g, m = st.get("terrain"), st.get("terrain_mesh")
    assert m.n_vertices == 200 and m.n_faces == 2 * 19 * 9
    np.testing.assert_array_equal(m.vertices[:, 2], g["surface__height"].ravel())
    np.testing.assert_array_equal(m["surface__height"], g["surface__height"].ravel())
    assert (m.face_normals[:, 2] > 0).all()   # faces point up


def test_poisson_rule_rejects_absurd_sizes(host):
    with pytest.raises(RecipeError):
        check_recipe({"steps": [{"rule": "points.poisson_disk", "params": {"radius": 1e-6}}]}, host)


def test_extrude_outline_gives_watertight_slab_of_right_volume(host):
    st = _run(host, [{"rule": "points.poisson_disk", "params": {"radius": 0.05}}, {"rule": "mesh.delaunay"},
                     {"rule": "mesh.boundary"}, {"rule": "lines.smooth", "params": {"lines": "outline", "out": "o"}},
                     {"rule": "mesh.extrude", "params": {"lines": "o", "spacing": 0.05, "depth": 0.2}}])
    tm = st.get("solid").to_trimesh()
    area = shapely.Polygon(st.get("o").line(0)).area
    assert tm.is_watertight and tm.is_winding_consistent
    assert np.isclose(tm.volume, 0.2 * area, rtol=0.02)     # positive: normals point outwards


def test_lathe_closed_profile_is_watertight_solid_of_revolution(host):
    from procgen import Polylines, State
    from procgen.builtin.solids import Lathe

    # a profile from the axis out and back to the axis: revolves into a closed "pill"
    t = np.linspace(-np.pi / 2, np.pi / 2, 21)
    prof = np.column_stack([np.cos(t), np.sin(t)])
    prof[0, 0] = prof[-1, 0] = 0.0
    st = State(seed=1)
    st.add_domain("profile", Polylines.from_list([prof]))
    Lathe(lines="profile", sections=96).step(st)
    tm = st.get("mesh").to_trimesh()
    assert tm.is_watertight
    assert np.isclose(tm.volume, 4 / 3 * np.pi, rtol=0.02)   # unit sphere, normals outwards
