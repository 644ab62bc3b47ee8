"""3DSCA construction: cells per triangle, clipping, neighbours, edge error (digest 16.1)."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import trimesh
from hypothesis import given, settings, strategies as st
from scipy import integrate
from shapely.geometry import Polygon, box

from procgen import InputError
from procgen_surface.domain import SurfaceCells
from procgen_surface.geometry import build_cells, choose_cell_size, face_frames
from procgen_surface.neighbours import (MOORE, analytic_mean_edge_error, build_neighbours,
                                        edge_topology, orientation_errors)

from _meshes import quad_obj, sharp_block
from _paths import MESHES


def icosphere(level: int = 2) -> tuple[np.ndarray, np.ndarray]:
    m = trimesh.creation.icosphere(subdivisions=level)
    return np.asarray(m.vertices), np.asarray(m.faces)


def load_mesh(path: Path | str) -> tuple[np.ndarray, np.ndarray]:
    """A mesh file (a shipped name or a path) as ``mesh.load`` gives it (UV seams welded)."""
    from procgen.builtin.meshes import clean_mesh, load_mesh_file
    m = clean_mesh(load_mesh_file(MESHES / path))
    return np.asarray(m.vertices), np.asarray(m.faces)


def face_areas(v: np.ndarray, f: np.ndarray) -> np.ndarray:
    return 0.5 * np.linalg.norm(np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]]), axis=1)


def test_frames_follow_the_thesis_convention():
    v, f = icosphere(1)
    fr = face_frames(v, f, "thesis")
    c2 = fr.corners2d
    # A at the origin, B on +y, C at x > 0; the frame is an isometry of the triangle
    assert np.all(c2[..., 0] >= -1e-12)
    assert np.all(np.sum(np.all(np.abs(c2) < 1e-12, axis=2), axis=1) == 1)
    d3 = np.linalg.norm(v[f][:, [1, 2, 0]] - v[f], axis=2)
    d2 = np.linalg.norm(c2[:, [1, 2, 0]] - c2, axis=2)
    np.testing.assert_allclose(d2, d3, rtol=1e-12)
    back = fr.to_3d(np.repeat(np.arange(len(f)), 3), c2.reshape(-1, 2)).reshape(-1, 3, 3)
    np.testing.assert_allclose(back, v[f], atol=1e-12)


@pytest.mark.parametrize("frame", ["thesis", "longest"])
def test_clipped_areas_add_up_to_each_triangle(frame):
    v, f = icosphere(2)
    lay = build_cells(v, f, 0.03, frame=frame)
    per_face = np.bincount(lay.face, lay.area, minlength=len(f))
    np.testing.assert_allclose(per_face, face_areas(v, f), rtol=1e-9)


def test_clipping_agrees_with_shapely_and_out_cells_overlap_nothing():
    v, f = icosphere(1)
    s = 0.05
    lay = build_cells(v, f, s)
    for face in range(0, len(f), 7):
        tri = Polygon(lay.frames.corners2d[face])
        for i in range(lay.nx[face]):
            for j in range(lay.ny[face]):
                ref = tri.intersection(box(i * s, j * s, (i + 1) * s, (j + 1) * s)).area
                cid = lay.cell_at(np.array([face]), np.array([i]), np.array([j]))[0]
                if cid < 0:
                    assert ref < 1e-9 * s * s
                else:
                    assert abs(lay.area[cid] - ref) < 1e-12
                    centre_in = tri.buffer(1e-12).contains(
                        Polygon.from_bounds(*(lay.center2d[cid] - 1e-13), *(lay.center2d[cid] + 1e-13)))
                    assert bool(lay.comp_in[cid]) == centre_in


def test_cell_count_is_area_over_s2_plus_a_boundary_term():
    v, f = icosphere(2)
    area = face_areas(v, f)
    perim = np.linalg.norm(v[f][:, [1, 2, 0]] - v[f], axis=2).sum()
    for s in (0.04, 0.02, 0.01):
        n = build_cells(v, f, s).n_cells
        assert area.sum() / s ** 2 < n < area.sum() / s ** 2 + 1.5 * perim / s + 4 * len(f)


def test_cell_size_modes():
    v, f = icosphere(2)
    s_k = choose_cell_size(v, f, k=4)
    sides = np.linalg.norm(v[f][:, [1, 2, 0]] - v[f], axis=2)
    heights = 2 * face_areas(v, f)[:, None] / sides
    assert s_k == pytest.approx(min(sides.min(), heights.min()) / 4)
    sc = SurfaceCells.from_mesh(v, f, target_cells=20000)
    assert 0.95 * 20000 < sc.n_cells < 1.05 * 20000
    with pytest.raises(InputError, match="exactly one"):
        choose_cell_size(v, f, cell_size=0.1, k=3)


def test_unfold_gives_all_eight_slots_on_a_closed_mesh_and_links_are_local():
    v, f = icosphere(2)
    lay = build_cells(v, f, 0.025)
    g, _ = build_neighbours(lay, v, f, "unfold")
    deg = np.diff(g.indptr)
    assert np.all(deg == 8)
    rows = np.repeat(np.arange(lay.n_cells), deg)
    assert not np.any(rows == g.indices)
    # in-grid links are symmetric
    ing = ~g.cross
    fwd = set(zip(rows[ing].tolist(), g.indices[ing].tolist()))
    assert all((b, a) in fwd for a, b in fwd)
    # across an edge the neighbour sits within half a cell diagonal of the unfolded slot centre
    d3 = np.linalg.norm(lay.center3d[rows] - lay.center3d[g.indices], axis=1)
    offset = np.linalg.norm(MOORE[g.direction], axis=1) * lay.size
    assert np.all(d3[g.cross] <= offset[g.cross] + (np.sqrt(0.5) + 0.1) * lay.size)
    assert g.cross.mean() > 0.05


def test_thesis_pairs_touch_every_shared_edge_and_stay_within_a_cell():
    v, f = icosphere(2)
    lay = build_cells(v, f, 0.025)
    g, _ = build_neighbours(lay, v, f, "pairs")
    rows = np.repeat(np.arange(lay.n_cells), np.diff(g.indptr))
    d3 = np.linalg.norm(lay.center3d[rows] - lay.center3d[g.indices], axis=1)
    assert np.all(d3[g.cross] < 1.5 * lay.size)
    # every partial cell (it touches an edge; the sphere is closed) has a partner
    has_partner = np.zeros(lay.n_cells, bool)
    has_partner[rows[g.cross]] = True
    assert np.all(has_partner[~lay.comp_in])
    # digest 12.2: pairs add about 0.7 neighbours on average to the in-grid 6.5
    g0, _ = build_neighbours(lay, v, f, "none")
    assert np.diff(g.indptr).mean() > np.diff(g0.indptr).mean() + 0.3


@pytest.mark.parametrize("name", ["teapot.obj", "bunny-4k.obj"])
def test_open_mesh_boundary_cells_miss_slots(name):
    v, f = load_mesh(name)             # the teapot is open; the decimated scan has holes in the base
    sc = SurfaceCells.from_mesh(v, f, target_cells=40000)
    deg = np.diff(sc.indptr)
    topo = edge_topology(sc.faces, sc.valid)
    boundary_faces = np.unique(topo.edge_faces[topo.valence == 1, 0])
    on_boundary_face = np.isin(sc.face, boundary_faces)
    assert deg.min() < 8 and np.all(deg[~on_boundary_face] >= 5)
    per_face = np.bincount(sc.face, sc.area, minlength=len(f))
    ok = sc.valid
    np.testing.assert_allclose(per_face[ok], face_areas(v, f)[ok], rtol=1e-9)


def test_quads_and_thin_triangles(tmp_path):
    v, f = load_mesh(quad_obj(tmp_path / "quads.obj")[0])   # quads triangulated by trimesh, thin pole fans
    sc = SurfaceCells.from_mesh(v, f, target_cells=20000, frame="longest")
    np.testing.assert_allclose(np.bincount(sc.face, sc.area, minlength=len(f))[sc.valid],
                               face_areas(v, f)[sc.valid], rtol=1e-9)
    # a sliver (height 1/200 of its base, thinner than one cell) still gets full area coverage
    v2 = np.array([[0, 0, 0], [1, 0, 0], [0.5, 5e-3, 0], [0.5, -0.1, 0]], float)
    f2 = np.array([[0, 1, 2], [1, 0, 3]])
    lay = build_cells(v2, f2, 8e-3)
    np.testing.assert_allclose(np.bincount(lay.face, lay.area), face_areas(v2, f2), rtol=1e-9)


def test_sharp_feature_edges_keep_flat_facets_flat():
    """On a CAD-like part (chamfered cube) cells on a flat facet carry the facet normal; cells
    of triangles touching a feature edge tilt towards the neighbour facet but stay on their side."""
    from procgen.domains import TriMesh
    v, f = sharp_block()
    tm = TriMesh(v, f)
    assert not tm.is_boundary_edge.any()
    ef = tm.edge_faces                                  # closed: two faces per edge
    bent = np.einsum("ij,ij->i", tm.face_normals[ef[:, 0]], tm.face_normals[ef[:, 1]]) < 1 - 1e-9
    feature = np.zeros(len(v), bool)
    feature[tm.edges[bent].ravel()] = True
    sc = SurfaceCells.from_mesh(v, f, target_cells=8000)
    fn = tm.face_normals[sc.face]
    on_edge = feature[f[sc.face]].any(axis=1)
    np.testing.assert_allclose(sc.normal[~on_edge], fn[~on_edge], atol=1e-12)
    cos = np.sum(sc.normal * fn, axis=1)
    assert np.all(cos > 0.2) and cos[on_edge].min() < 0.95
    np.testing.assert_allclose(np.linalg.norm(sc.normal, axis=1), 1.0, atol=1e-12)
    np.testing.assert_allclose(np.bincount(sc.face, sc.area, minlength=len(f)), tm.face_areas, rtol=1e-9)


def test_orientation_error_formula_and_statistic():
    ref, _ = integrate.quad(lambda a: 1 - np.cos(a), 0, np.pi / 4)
    assert analytic_mean_edge_error() == pytest.approx(4 / np.pi * ref, rel=1e-12)
    assert analytic_mean_edge_error() == pytest.approx(0.0997, abs=1e-4)
    # flat random Delaunay mesh: unfolding is the identity, so alpha is the plain angle
    # between the two faces' x axes (an independent computation of the statistic)
    from scipy.spatial import Delaunay
    rng = np.random.default_rng(0)
    p = rng.random((3000, 2))
    tri = Delaunay(p).simplices
    v = np.column_stack([p, np.zeros(len(p))])
    lay = build_cells(v, tri, 0.004)
    topo = edge_topology(tri)
    err = orientation_errors(lay, tri, topo)
    ef = topo.edge_faces[(topo.edge_faces >= 0).all(1)]
    ex = lay.frames.ex
    ang = np.arctan2(ex[ef[:, 1], 1], ex[ef[:, 1], 0]) - np.arctan2(ex[ef[:, 0], 1], ex[ef[:, 0], 0])
    a = np.abs(ang) % (np.pi / 2)
    np.testing.assert_allclose(err, 1 - np.cos(np.minimum(a, np.pi / 2 - a)), atol=1e-9)
    # grids rotated uniformly at random give the thesis's mean (the mesh's own angles do not:
    # Delaunay edge directions are correlated, so its mean is reported, not asserted)
    theta = rng.uniform(0, 2 * np.pi, 200000) % (np.pi / 2)
    mc = np.mean(1 - np.cos(np.minimum(theta, np.pi / 2 - theta)))
    assert mc == pytest.approx(analytic_mean_edge_error(), abs=2e-3)
    assert 0 < err.mean() < 1 - np.cos(np.pi / 4)


def test_bad_input_is_refused_with_one_line_messages():
    v, f = icosphere(1)
    with pytest.raises(InputError, match="no faces"):
        SurfaceCells.from_mesh(v, np.zeros((0, 3), np.int64), cell_size=0.1)
    vn = v.copy()
    vn[3, 1] = np.nan
    with pytest.raises(InputError, match="NaN"):
        SurfaceCells.from_mesh(vn, f, cell_size=0.1)
    with pytest.raises(InputError, match="larger than the mesh"):
        SurfaceCells.from_mesh(v, f, cell_size=10.0)
    with pytest.raises(InputError, match=r"candidate cells .* GB") as exc:
        SurfaceCells.from_mesh(v, f, cell_size=1e-3, max_cells=10_000_000)
    assert "\n" not in str(exc.value)
    with pytest.raises(InputError, match="budget"):
        SurfaceCells.from_mesh(v, f, cell_size=2e-6, max_cells=10**15)
    # degenerate triangles are skipped and counted, not a crash
    v2 = np.vstack([v, v[f[0, 0]], v[f[0, 0]] + 1e-3])
    f2 = np.vstack([f, [[f[0, 0], len(v), len(v) + 1]], [[0, 1, 0]]])
    sc = SurfaceCells.from_mesh(v2, f2, cell_size=0.05)
    assert sc.n_degenerate == 2
    assert not np.isin(sc.face, [len(f), len(f) + 1]).any()


def test_domain_round_trips_through_state(tmp_path):
    from procgen import State
    v, f = icosphere(1)
    sc = SurfaceCells.from_mesh(v, f, cell_size=0.08)
    sc.add_field("demo__value", np.arange(sc.n_cells), at="cell")
    st = State(seed=3)
    st.add_domain("cells", sc)
    st.save(tmp_path / "s.npz")
    back = State.load(tmp_path / "s.npz").get("cells", SurfaceCells)
    np.testing.assert_array_equal(back.indices, sc.indices)
    np.testing.assert_array_equal(back["demo__value"], np.arange(sc.n_cells))
    assert back.size == sc.size


@settings(max_examples=40, deadline=None)
@given(st.lists(st.floats(-1.0, 1.0, allow_nan=False), min_size=9, max_size=9),
       st.sampled_from(["thesis", "longest"]), st.floats(0.02, 0.2))
def test_any_triangle_is_tiled_exactly(coords, frame, s):
    """Property: for any non-degenerate triangle and cell size, active cells tile it exactly,
    COMP-IN cells have their centre inside and every active square overlaps the triangle."""
    v = np.asarray(coords).reshape(3, 3)
    f = np.array([[0, 1, 2]])
    area = face_areas(v, f)[0]
    longest = np.linalg.norm(v[[1, 2, 0]] - v, axis=1).max()
    if area < 1e-3 * longest ** 2 or longest < 1e-3:
        return
    lay = build_cells(v, f, s * longest, frame=frame)
    assert lay.n_cells >= 1
    assert lay.area.sum() == pytest.approx(area, rel=1e-9)
    assert np.all(lay.area > 0) and np.all(lay.area <= (s * longest) ** 2 * (1 + 1e-9))
    from procgen.geometry import barycentric
    bc = barycentric(np.repeat(lay.frames.corners2d, lay.n_cells, axis=0), lay.center2d)
    inside = np.all(bc >= -1e-9, axis=1)
    assert np.array_equal(inside[np.all(np.abs(bc) > 1e-7, axis=1)],
                          lay.comp_in[np.all(np.abs(bc) > 1e-7, axis=1)])
    # centres map back onto the triangle's plane
    n = np.cross(v[1] - v[0], v[2] - v[0])
    assert np.allclose((lay.center3d - v[0]) @ n, 0, atol=1e-9 * longest ** 3)


def test_mesh_fields_carry_onto_cells_and_drive_corrosion(host):
    """A chain's data crosses families: a vertex field of the mesh becomes a cell field."""
    from procgen.recipes import check_recipe
    from procgen.runner import run

    steps = [{"rule": "grid.noise", "params": {"nx": 12, "ny": 10, "spacing": 0.1}},
             {"rule": "grid.to_mesh"},
             {"rule": "surface.cells", "params": {"mesh": "terrain_mesh", "target_cells": 3000}},
             {"rule": "layers.stack"},
             {"rule": "layers.corrode", "iterations": 3,
              "params": {"strong_from": "field", "strong_field": "surface__height", "strong_fraction": 0.25}}]
    st = run(check_recipe({"steps": steps}, host), host, seed=2).state
    sc = st.get("cells")
    # height is linear on each triangle, so barycentric interpolation is exact: it equals z of the centre
    np.testing.assert_allclose(sc["surface__height"], sc.center3d[:, 2], atol=1e-9)
    strong = sc["corrosion__strong"].astype(bool)
    assert abs(strong.mean() - 0.25) < 1e-3
    assert sc["surface__height"][strong].min() >= sc["surface__height"][~strong].max()   # the highest quarter
    bad = [dict(s) for s in steps]
    bad[-1] = {"rule": "layers.corrode", "params": {"strong_from": "field"}}
    import pytest

    from procgen import RecipeError
    with pytest.raises(RecipeError, match="strong_field"):
        check_recipe({"steps": bad}, host)


def test_absurd_cell_counts_are_refused_at_check_time(host):
    import pytest

    from procgen import RecipeError
    from procgen.recipes import check_recipe

    steps = [{"rule": "mesh.primitive"}, {"rule": "surface.cells", "params": {"target_cells": 2_000_000_000}}]
    with pytest.raises(RecipeError, match="exceeds max_cells"):
        check_recipe({"steps": steps}, host)
    steps[1]["params"]["max_cells"] = 3_000_000_000
    with pytest.raises(RecipeError, match="GiB, more than"):
        check_recipe({"steps": steps}, host)
