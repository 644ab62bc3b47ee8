"""Domains: size-checked fields, immutable topology, derived adjacency against trimesh."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from procgen import Grid, InputError, PointSet, Polylines, TriMesh

from _paths import SHARED_MESHES


def test_field_size_is_checked():
    g = Grid((4, 5))
    g.add_field("surface__height", np.zeros((4, 5)), at="cell")
    g.add_field("layer__thickness", np.zeros((4, 5, 3)), at="cell")
    with pytest.raises(InputError, match="does not start with"):
        g.add_field("surface__wet", np.zeros((5, 4)), at="cell")
    with pytest.raises(InputError, match="thing__quantity"):
        g.add_field("height", np.zeros((4, 5)), at="cell")
    with pytest.raises(InputError, match="location"):
        g.add_field("surface__x", np.zeros((4, 5)), at="vertex")
    with pytest.raises(InputError, match="no field"):
        g["surface__nope"]


def test_topology_is_read_only():
    m = TriMesh([[0, 0], [1, 0], [0, 1]], [[0, 1, 2]])
    with pytest.raises(ValueError):
        m.vertices[0, 0] = 5
    with pytest.raises(ValueError):
        m.faces[0, 0] = 1


@pytest.mark.parametrize("bad", [
    dict(vertices=[[0, 0], [1, 0], [np.nan, 1]], faces=[[0, 1, 2]]),
    dict(vertices=[[0, 0], [1, 0], [0, 1]], faces=[[0, 1, 3]]),
    dict(vertices=[[0, 0], [1, 0], [0, 1]], faces=[[0.0, 1.0, 2.0]]),
    dict(vertices=[[0, 0], [1, 0], [0, 1]], faces=np.zeros((0, 3), int)),
])
def test_broken_mesh_is_refused(bad):
    with pytest.raises(InputError):
        TriMesh(**bad)


def test_derived_topology_matches_trimesh():
    tm = trimesh.load(SHARED_MESHES / "spot.obj", force="mesh", process=True)
    tm.merge_vertices(merge_tex=True, merge_norm=True)  # weld UV seams: spot is closed
    m = TriMesh.from_trimesh(tm)
    assert len(m.edges) == len(tm.edges_unique)
    assert len(m.face_adjacency) == len(tm.face_adjacency)
    ours = {tuple(sorted(p)) for p in m.face_adjacency.tolist()}
    theirs = {tuple(sorted(p)) for p in tm.face_adjacency.tolist()}
    assert ours == theirs
    np.testing.assert_allclose(m.face_areas, tm.area_faces, rtol=1e-9)
    indptr, nbrs = m.vertex_neighbors.indptr, m.vertex_neighbors.indices
    for v in (0, 17, 1000):
        assert set(nbrs[indptr[v]:indptr[v + 1]]) == set(tm.vertex_neighbors[v])
    # every face edge id points at the right vertex pair
    fe = m.face_edges
    pairs = np.sort(np.stack([m.faces, np.roll(m.faces, -1, axis=1)], axis=2), axis=2)
    assert np.array_equal(m.edges[fe], pairs)
    # closed mesh: no boundary edges, every edge has two faces
    assert not m.is_boundary_edge.any()
    assert (m.edge_faces >= 0).all()


def test_polylines_offsets_and_lengths():
    sq = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    pl = Polylines.from_list([sq, sq[:3]], closed=[True, False])
    assert pl.n_lines == 2
    np.testing.assert_allclose(pl.lengths(), [4.0, 2.0])
    assert pl.location_shape("point") == (7,)
    with pytest.raises(InputError):
        Polylines(sq, [0, 5])


def test_pointset_rejects_nan():
    with pytest.raises(InputError):
        PointSet([[0, np.nan]])
