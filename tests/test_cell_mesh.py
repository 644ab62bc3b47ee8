"""The exact cell-polygon mesh (procgen_surface.cell_mesh): holes of plate B.2, rounded facets of
plate B.3 (3DSCA thesis Appendix B §6-7).

Properties that break when the construction is wrong: a closed input meshes closed (no gap and
no T-junction along the triangles' shared edges), the holes' rims are exactly the rims of the
removed cells (the living and the removed cells' meshes share their boundary edge for edge),
the missing area is the removed cells' area, and the layer surfaces of flat and rounded facets
stand where the geometry says (gap 2 d sin(theta/2) at an edge of dihedral theta; the rounded
offset's volume near the Steiner formula of the exact offset of a convex solid).
"""
from __future__ import annotations

import io

import numpy as np
import pytest
import trimesh

from procgen import geometry as geo
from procgen_surface.cell_mesh import boundary_edges, boundary_loops, cell_mesh
from procgen_surface.cell_mesh_rule import max_crease_deg
from procgen_surface.domain import SurfaceCells


@pytest.fixture(scope="module")
def ball() -> tuple[trimesh.Trimesh, SurfaceCells]:
    m = trimesh.creation.icosphere(subdivisions=1)
    return m, SurfaceCells.from_mesh(m.vertices, m.faces, target_cells=6000)


def _area(v: np.ndarray, f: np.ndarray) -> float:
    return 0.5 * float(np.linalg.norm(geo.triangle_cross(v, f), axis=1).sum())


def _edge_set(cm) -> set[tuple]:
    """Boundary edges as unordered pairs of rounded 3-D points (comparable across meshes)."""
    b = boundary_edges(cm.faces)
    p = np.round(cm.base[b], 9)
    return {tuple(sorted((tuple(a), tuple(c)))) for a, c in p}


def test_closed_input_meshes_closed_and_tiles_the_surface_exactly(ball):
    m, sc = ball
    cm = cell_mesh(sc)
    assert len(boundary_edges(cm.faces)) == 0            # no gap, no T-junction on shared edges
    out = trimesh.Trimesh(cm.base, cm.faces, process=False)
    assert out.is_winding_consistent
    assert _area(cm.base, cm.faces) == pytest.approx(m.area, rel=1e-9)
    assert out.volume == pytest.approx(m.volume, rel=1e-9)   # oriented as the input triangles
    # every triangle lies inside its own cell's square
    xy = cm.corner_xy
    lo = sc.ij[cm.face_cell][:, None, :] * sc.size
    assert np.all(xy >= lo - 1e-9 * sc.size) and np.all(xy <= lo + sc.size * (1 + 1e-9))


def _discs(sc: SurfaceCells, centres: np.ndarray, radius: float) -> np.ndarray:
    d = np.linalg.norm(sc.center3d[:, None, :] - centres[None], axis=2)
    return np.any(d < radius, axis=1)


def test_holes_are_exactly_the_removed_cells(ball):
    _, sc = ball
    centres = np.array([[0, 0, 1.0], [1.0, 0, 0], [0, -1.0, 0]])
    dead = _discs(sc, centres, 0.3)
    holed = cell_mesh(sc, alive=~dead)
    removed = cell_mesh(sc, alive=dead)
    assert boundary_loops(holed.faces) == 3
    rims = _edge_set(holed)
    assert len(rims) == len(boundary_edges(holed.faces)) > 0
    assert rims == _edge_set(removed)                    # the rims run exactly around the cells
    full = _area(cell_mesh(sc).base, cell_mesh(sc).faces)
    missing = full - _area(holed.base, holed.faces)
    assert missing == pytest.approx(sc.area[dead].sum(), rel=1e-9)
    assert set(np.unique(holed.face_cell)) == set(np.flatnonzero(~dead))


def test_a_single_removed_cell_is_a_hole_of_its_own_shape(ball):
    _, sc = ball
    one = int(np.flatnonzero(sc.comp_in & (sc.area > 0.99 * sc.size ** 2))[0])
    alive = np.ones(sc.n_cells, bool)
    alive[one] = False
    holed = cell_mesh(sc, alive=alive)
    b = boundary_edges(holed.faces)
    assert boundary_loops(holed.faces) == 1
    assert np.linalg.norm(holed.base[b[:, 0]] - holed.base[b[:, 1]], axis=1).sum() == \
        pytest.approx(4 * sc.size, rel=1e-9)             # a whole square cell: perimeter 4 s


def _dihedrals(m: trimesh.Trimesh) -> np.ndarray:
    return m.face_adjacency_angles


def test_flat_facets_part_by_the_geometric_gap_and_rounded_ones_stay_joined(ball):
    m, sc = ball
    d = 0.1
    h = np.full(sc.n_cells, d)
    flat = cell_mesh(sc, h, rounded=False)
    rounded = cell_mesh(sc, h, rounded=True)
    assert len(boundary_edges(rounded.faces)) == 0
    assert len(boundary_edges(flat.faces)) > 0
    # each facet's layer is its own patch: one rim per input facet, as long as its perimeter
    assert boundary_loops(flat.faces) == len(m.faces)
    b = boundary_edges(flat.faces)
    perimeter = np.linalg.norm(m.vertices[m.faces] - m.vertices[np.roll(m.faces, -1, axis=1)], axis=2).sum()
    assert np.linalg.norm(flat.base[b[:, 0]] - flat.base[b[:, 1]], axis=1).sum() == pytest.approx(perimeter, rel=1e-9)
    # at a shared corner the two facets' layers stand 2 d sin(theta / 2) apart (the red region)
    vface = np.zeros(len(flat.vertices), np.int64)
    vface[flat.faces.ravel()] = np.repeat(flat.face_src, 3)
    where = {(tuple(np.round(p, 9)), f): i for i, (p, f) in enumerate(zip(flat.base, vface))}
    adj, edge = m.face_adjacency, m.face_adjacency_edges
    gaps = []
    for (fa, fb), v in zip(adj, edge[:, 0]):          # one check per input edge (setup-size loop)
        key = tuple(np.round(m.vertices[v], 9))
        gaps.append(np.linalg.norm(flat.vertices[where[key, fa]] - flat.vertices[where[key, fb]]))
    assert np.allclose(gaps, 2 * d * np.sin(m.face_adjacency_angles / 2), rtol=1e-9)


def test_rounded_layer_surface_creases_less_with_thickness_and_keeps_the_offset_volume(ball):
    m, sc = ball
    theta = np.degrees(_dihedrals(m).max())
    creases = []
    for d in (0.0, 0.1, 0.2):
        r = cell_mesh(sc, np.full(sc.n_cells, d), rounded=True)
        creases.append(max_crease_deg(r.vertices, r.faces))
    assert creases[0] == pytest.approx(theta, abs=0.05)
    assert creases[0] > creases[1] > creases[2]
    # Steiner: the exact offset of a convex solid by d has volume V + A d + M d^2 + 4/3 pi d^3
    # (M = 1/2 sum edge length x exterior angle); the rounded surface follows it closely
    d = 0.2
    r = cell_mesh(sc, np.full(sc.n_cells, d), rounded=True)
    vol = trimesh.Trimesh(r.vertices, r.faces, process=False).volume
    e = m.face_adjacency_edges
    mean_width = 0.5 * np.sum(np.linalg.norm(m.vertices[e[:, 0]] - m.vertices[e[:, 1]], axis=1)
                              * m.face_adjacency_angles)
    steiner = m.volume + m.area * d + mean_width * d ** 2 + 4 / 3 * np.pi * d ** 3
    assert vol == pytest.approx(steiner, rel=0.02)
    flat_offset = m.volume + m.area * d               # facets pushed out, edges not filled
    assert vol > flat_offset


def test_rounded_normals_vary_continuously_across_facet_edges(ball):
    """The normal a vertex moved along turns by at most the input's vertex-normal turn per unit
    length (the largest angle between two vertex normals of a facet over its smallest altitude):
    a Lipschitz bound that a jump at a facet edge (face normals) would break."""
    m, sc = ball
    r = cell_mesh(sc, np.full(sc.n_cells, 0.1), rounded=True)
    e = np.concatenate([r.faces[:, [0, 1]], r.faces[:, [1, 2]], r.faces[:, [2, 0]]])
    turn = np.arccos(np.clip(np.sum(r.normals[e[:, 0]] * r.normals[e[:, 1]], axis=1), -1, 1))
    length = np.linalg.norm(r.base[e[:, 0]] - r.base[e[:, 1]], axis=1)
    vn, f = m.vertex_normals, m.faces
    corner_turn = np.arccos(np.clip(np.sum(vn[f] * vn[f[:, [1, 2, 0]]], axis=2), -1, 1)).max()
    altitude = (2 * m.area_faces / m.edges_unique_length.max()).min()
    ok = length > 1e-6 * sc.size
    assert np.all(turn[ok] <= corner_turn / altitude * length[ok] * (1 + 1e-6))
    assert turn.max() < np.radians(np.degrees(m.face_adjacency_angles.max()) / 4)


def test_phong_shape_rounds_the_facets_themselves(ball):
    m, sc = ball
    theta = np.degrees(_dihedrals(m).max())
    r = cell_mesh(sc, rounded=True, shape=0.5)
    rad = np.linalg.norm(r.vertices, axis=1)          # the icosphere's vertices are on the unit sphere
    plain = np.linalg.norm(cell_mesh(sc).vertices, axis=1)
    assert 1 - rad.min() < 0.2 * (1 - plain.min())     # within a fifth of the flat facets' sag
    assert max_crease_deg(r.vertices, r.faces) < theta / 2
    assert len(boundary_edges(r.faces)) == 0


def test_rule_holes_survive_the_glb_round_trip(host, tmp_path):
    from procgen.exchange import glb_export
    from procgen.recipes import check_recipe
    from procgen.runner import run

    steps = [
        {"rule": "mesh.primitive", "params": {"shape": "plane", "subdivisions": 2}},
        {"id": "cells", "rule": "surface.cells", "params": {"target_cells": 3000}},
        {"rule": "layers.stack", "params": {"layers": [
            {"preset": "copper", "thickness": 0.01}, {"preset": "patina", "thickness": 0.0}]}},
        {"rule": "layers.corrode", "iterations": 60,
         "params": {"k1": 0.0005, "seed_rate": 0.0, "initial_seeds": 3}},
        {"rule": "layers.shade", "params": {"lit": False}},
        {"rule": "surface.cell_mesh", "params": {"mesh": "holed"}},
    ]
    res = run(check_recipe({"steps": steps}, host), host, seed=4, progress=False, out_dir=tmp_path)
    rep = res.state.reports
    assert rep["cells.corrosion.holes"] > 0
    assert rep["holed.removed_cells"] == rep["cells.corrosion.holes"]
    assert rep["holed.missing_area"] == pytest.approx(rep["holed.removed_area"], rel=1e-9)
    tm = res.state.get("holed")
    glb = glb_export(tm, uv_field="surface__uv", texture_field="surface__texture")
    scene = trimesh.load(io.BytesIO(glb), file_type="glb")
    g = next(iter(scene.geometry.values()))
    g = trimesh.Trimesh(g.vertices, g.faces, process=False)
    g.merge_vertices()                                     # atlas seams split vertices in glTF
    assert len(trimesh.grouping.group_rows(g.edges_sorted, require_count=1)) == rep["holed.boundary_edges"]
    assert g.area == pytest.approx(1.0 - rep["holed.removed_area"], rel=0.02)   # displaced: a little more
