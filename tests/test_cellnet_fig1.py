"""Figure 1 of seed 002 ("Generating Surface Textures based on Cellular Networks", GMAI 2006) and
the paper's own numbers the cellnet gallery shows: the 3-D logo and its parts, eight effects on
one network, the cell count at the paper's scale, the link radii and neighbour counts of
section 3.2 / 4.3 (Figure 5), and the bunny with one triangle missing (Figure 10)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from procgen import InputError, check_recipe, run
from procgen.gallery import load_gallery
from procgen.recipes import load_recipe

from procgen_cellnet.parts import face_parts, reading_order
from procgen_cellnet.seeding import DEGREE, link_radius
from procgen_cellnet.states import TRANSPARENT

from _cellnet import random_young_state, young_field

LOGO_STEPS = 3          # lines.load, mesh.extrude, cellnet.parts: the first steps of every fig-1 recipe


def _run(host, name, overrides=()):
    return run(load_recipe(f"cellnet/{name}", host, list(overrides)), host, seed=1, progress=False)


@pytest.fixture(scope="module")
def logo(host):
    return _run(host, "fig-1-logo").state.domains["logo"]


# -- Figure 1(a)-(d): the logo as a solid of eight parts ------------------------------------------
def test_logo_is_eight_closed_letters_numbered_in_reading_order(logo):
    import trimesh

    obj = np.asarray(logo["face__object"])
    mat = np.asarray(logo["face__material"])
    # eight glyphs (G M A I over 2 0 0 6), each its own part, independently of our component search
    tm = trimesh.Trimesh(logo.vertices, logo.faces, process=False)
    pieces = tm.split(only_watertight=False)
    assert len(pieces) == 8 and sorted(np.unique(obj)) == list(range(8))
    assert all(p.is_watertight and p.volume > 0 for p in pieces)   # extruded solids, not slabs of faces
    assert np.array_equal(mat, obj + 1)                              # default material k + 1
    rgb = np.asarray(logo["vertex__color"])[logo.faces[:, 0]]          # one view colour per part
    per_part = [np.unique(rgb[obj == k], axis=0) for k in range(8)]
    assert all(len(c) == 1 for c in per_part) and len(np.unique(np.vstack(per_part), axis=0)) == 8
    # reading order: parts 0-3 are the upper row left to right, 4-7 the lower row
    centre = np.array([logo.vertices[logo.faces[obj == k]].reshape(-1, 3).mean(axis=0) for k in range(8)])
    assert centre[:4, 1].min() > centre[4:, 1].max()
    assert np.all(np.diff(centre[:4, 0]) > 0) and np.all(np.diff(centre[4:, 0]) > 0)
    # extruded along z: every part spans the full depth, caps at 0 and the depth
    z = logo.vertices[:, 2]
    assert z.min() == 0.0 and z.max() == pytest.approx(8.0)
    # A, 0, 0, 6 have one hole each: their genus is 1 (Euler characteristic 0), the rest 2
    euler = sorted(int(p.euler_number) for p in pieces)
    assert euler == [0, 0, 0, 0, 2, 2, 2, 2]


def test_reading_order_keeps_a_row_whose_letters_sit_at_different_heights():
    # row 1: three glyphs, the middle one lower (an A below a G's overshoot); row 2 below
    lo = np.array([[0, 10, 0], [5, 9.2, 0], [10, 10, 0], [0, 0, 0], [6, 0.5, 0]], float)
    hi = lo + np.array([4, 8, 1], float)
    centre = (lo + hi) / 2
    perm = np.array([3, 0, 4, 2, 1])                 # any input order
    rank = reading_order(lo[perm], hi[perm], centre[perm])
    assert np.array_equal(rank, np.array([3, 0, 4, 2, 1]))


def test_face_parts_joins_faces_through_shared_vertices_only():
    faces = np.array([[0, 1, 2], [2, 3, 0], [4, 5, 6], [7, 8, 9], [9, 8, 4]])
    part, k = face_parts(faces, 12)                  # vertices 10, 11 unused: not parts
    assert k == 2 and part[0] == part[1] and part[2] == part[3] == part[4] and part[0] != part[2]


def test_materials_are_one_per_part(host):
    with pytest.raises(InputError, match="8 parts but 3 materials"):
        _run(host, "fig-1-logo", ["steps.parts.params.materials=[1, 2, 3]"])


# -- Figure 1(e)-(f): the network on the solid ------------------------------------------------------
def test_cell_count_follows_the_target_so_the_thesis_scale_gives_the_papers_count(host):
    """The gallery runs Figure 1 at the paper's 1.5 million cells by target_cells alone: the count
    seeded on the logo (caps, walls, holes, seams) must track the target within a few percent."""
    for target in (4000, 12000):
        net = _run(host, "fig-1-network", [f"steps.seed.params.target_cells={target}"]).state.domains["cells"]
        assert abs(net.n_cells / target - 1) < 0.05, (target, net.n_cells)
        # one cell per lattice node: no two cells closer than the merge distance cs / 4
        from scipy.spatial import cKDTree
        assert not cKDTree(net.positions).query_pairs(0.25 * net.cs - 1e-9)
        # every cell sits on the logo's surface and carries its glyph's material
        mat = np.asarray(net["cell__material"])
        assert sorted(np.unique(mat)) == list(range(1, 9))
        normals = np.asarray(net["cell__normal"])
        up = np.abs(normals[:, 2]) > 0.99
        assert np.all(np.isclose(net.positions[up, 2], 0) | np.isclose(net.positions[up, 2], 8.0))


def test_gallery_compares_figure_1_with_the_papers_million_and_a_half_cells(host):
    entries = {e.slug: e for e in load_gallery(host, only=["cellnet/fig-1*"])}
    for slug in ("cellnet-fig-1", "cellnet-fig-1-network"):
        e = entries[slug]
        assert e.thesis["cells.n_cells"] == 1_500_000                      # section 5.1
        assert e.thesis_scale == {"steps.seed.params.target_cells": 1_500_000}
        assert "{thesis.cells.n_cells}" in e.differs and "{cells.n_cells}" in e.differs
    figures = {entries[s].figure for s in ("cellnet-fig-1-logo", "cellnet-fig-1-network", "cellnet-fig-1")}
    assert figures == {"Figure 1 (a)-(d)", "Figure 1 (e)-(f)", "Figure 1 (g)-(n)"}


# -- Figure 1(g)-(n): eight effects, one network, one glyph each ------------------------------------
def test_eight_effects_run_together_each_on_its_own_glyph(host):
    recipe = load_recipe("cellnet/fig-1", host, ["steps.seed.params.target_cells=8000",
                                                  "steps.regions.params.seeds=120"])
    st = run(recipe, host, seed=1, progress=False).state
    net = st.domains["cells"]
    mat = np.asarray(net["cell__material"])
    (effects,) = [s for s in recipe.steps if s.id == "effects"]
    records = [r for r in st.records if r.step == effects.index]
    # the paper's eight effects (g)-(n), one synchronous run until nothing changed
    behaviours = recipe.data["steps"][effects.index]["params"]["behaviours"]
    assert len(behaviours) == 8 and len(records) > 60
    assert not records[-1].changed and len(records) < effects.iterations     # stopped: stable
    covered = sorted({m for ms in behaviours.values() for m in ms})
    assert covered == list(range(1, 9))
    state = np.asarray(net["cell__state"])
    # (k) impacts: holes, and only on the impacts glyph
    holes = state == TRANSPARENT
    assert holes.any() and np.all(mat[holes] == 5)
    # cracks only where a crack behaviour runs: concrete, marble, patchwork, mud
    crack = np.asarray(net["crack__mask"])
    assert crack.any() and set(np.unique(mat[crack])) <= {1, 2, 3, 4}
    # (j) mud and (l) lichen: both states present after the maze rule / activator-inhibitor
    for m, field in ((4, "mud__alive"), (6, "lichen__alive")):
        alive = np.asarray(net[field])[mat == m]
        assert 0.05 < alive.mean() < 0.95, (field, alive.mean())
    # (m), (n) watercolour: dried, pigment left; the dark ink makes (n) darker than (m)
    water = np.asarray(net["water__volume"])
    assert np.all(water[(mat == 7) | (mat == 8)] == 0)
    col = np.asarray(net["surface__color"], float)
    lum = col.mean(axis=1)
    assert np.percentile(lum[mat == 8], 1) < np.percentile(lum[mat == 7], 1) - 0.2
    assert (np.abs(col[mat == 7] - 1).max(axis=1) > 0.1).mean() > 0.1       # tinted, not white
    # the GLB splats leave the holes out: 4 triangles per present cell
    import trimesh
    from procgen_cellnet.exporters import cellnet_glb
    import io
    scene = trimesh.load(io.BytesIO(cellnet_glb(net)), file_type="glb", process=False)
    (tm,) = scene.geometry.values()
    assert len(tm.faces) == 4 * int((~holes).sum())


# -- paper numbers the other figures show -------------------------------------------------------------
def test_figure_5_link_radii_and_neighbour_counts_are_the_papers():
    """Section 4.3: r_i = sqrt(2) cs - eps (square, direct), 2 cs - eps (with diagonals),
    sqrt(3) cs - eps (triangle, hexagon); section 3.2: 4 or 8, 6 and 3 neighbours."""
    cs, eps = 1.3, 0.01
    want = {"square4": math.sqrt(2), "square8": 2.0, "triangle": math.sqrt(3), "hexagon": math.sqrt(3)}
    for grid, r in want.items():
        assert link_radius(grid, cs, eps) == pytest.approx((r - eps) * cs)
    assert {g: DEGREE[g] for g in want} == {"square4": 4, "square8": 8, "triangle": 6, "hexagon": 3}


def test_figure_10_bunny_keeps_one_triangle_without_cells(host):
    """Figure 10(a): one input triangle is missing; the network has no cell on it and still
    links across the gap."""
    steps = [{"rule": "mesh.load", "params": {"path": "bunny-4k.obj", "normalize": True}},
             {"rule": "cellnet.seed", "params": {"target_cells": 40000, "skip_faces": [1000]}},
             {"rule": "cellnet.link"}]
    st = run(check_recipe({"steps": steps}, host, "t.toml"), host, seed=1, progress=False).state
    mesh, net = st.domains["mesh"], st.domains["cells"]
    a, b, c = mesh.vertices[mesh.faces[1000]]
    n = np.cross(b - a, c - a)
    area2 = np.linalg.norm(n)
    n /= area2
    p = net.positions
    on_plane = np.abs((p - a) @ n) < 1e-6 * net.cs
    # barycentric inside test for the cells in the triangle's plane
    w = np.stack([np.cross(c - b, p - b) @ n, np.cross(a - c, p - c) @ n, np.cross(b - a, p - a) @ n], 1) / area2
    inside = on_plane & np.all(w > 1e-9, axis=1)
    assert not inside.any()
    # the same seeding without the skip puts cells there (the triangle is big enough to hold some)
    steps[1]["params"].pop("skip_faces")
    full = run(check_recipe({"steps": steps}, host, "t.toml"), host, seed=1, progress=False).state.domains["cells"]
    q = full.positions
    w = np.stack([np.cross(c - b, q - b) @ n, np.cross(a - c, q - c) @ n, np.cross(b - a, q - a) @ n], 1) / area2
    assert (np.all(w > 1e-9, axis=1) & (np.abs((q - a) @ n) < 1e-6 * full.cs)).sum() >= 1


def test_figure_6_grids_on_the_cube_have_about_the_same_cell_count(host):
    """Section 4.3 on Figure 6: "for each case the cells number Nc is approximately the same"."""
    st = _run(host, "fig-6").state
    counts = np.array([st.domains[g].n_cells for g in ("square8", "triangle", "hexagon", "random")])
    assert np.all(np.abs(counts / counts.mean() - 1) < 0.05), counts
    # without the per-grid spacing the triangle and honeycomb counts stray by +15 % and -23 %
    from procgen_cellnet.seeding import DENSITY
    assert DENSITY["triangle"] == pytest.approx(2 / math.sqrt(3)) and \
        DENSITY["hexagon"] == pytest.approx(4 / (3 * math.sqrt(3)))


def test_figure_13_paints_three_layers_that_all_dry(host):
    """Figure 13 (section 5.2): three watercolour painting layers, the third shown after drying."""
    recipe = load_recipe("cellnet/fig-13", host, ["steps.primitive.params.size=50.0"])
    seen: set[int] = set()

    def watch(state, rec):
        if rec.rule == "cellnet.paint":
            layer = np.asarray(state.domains["cells"]["paint__layer"])
            seen.update(int(k) for k in np.unique(layer[layer > 0]))

    st = run(recipe, host, seed=1, progress=False, on_step=watch).state
    net = st.domains["cells"]
    assert seen == {1, 2, 3}
    assert np.all(np.asarray(net["water__volume"]) == 0)                  # dry at the end
    # each layer's pigment settled where its brush went down: blue, red, yellow
    col = np.asarray(net["surface__color"], float)
    at = {tuple(c): int(np.argmin(np.linalg.norm(net.positions - c, axis=1)))
          for c in ((-18.0, -10.0, 0.0), (16.0, 12.0, 0.0), (5.0, -22.0, 0.0))}
    blue, red, yellow = (col[i] for i in at.values())
    assert blue[2] > blue[0] + 0.2 and red[0] > red[2] + 0.2 and min(yellow[:2]) > yellow[2] + 0.2
    flows = [s for s in recipe.steps if s.rule.name == "cellnet.watercolor"]
    assert len(flows) == 3
    for s in flows:                                                        # each layer dried before the next
        rec = [r for r in st.records if r.step == s.index]
        assert not rec[-1].changed and len(rec) < s.iterations


def test_young_on_one_material_keeps_only_its_rings_and_follows_the_equation(host):
    """Figure 1(l): the lichen rule on one glyph's cells holds the rings of those cells only (a
    million-cell logo would need gigabytes otherwise) and still sums over every neighbour."""
    from procgen_cellnet.activation import ActivatorInhibitor
    from procgen_cellnet.states import receives

    sq = lambda x0: [[[x0, 0.0, 0.0], [x0 + 12.0, 0.0, 0.0], [x0 + 12.0, 12.0, 0.0], [x0, 12.0, 0.0]]]
    steps = [{"rule": "cellnet.polygons", "params": {"polygons": [sq(0.0), sq(12.0)], "materials": [1, 2]}},
             {"rule": "cellnet.seed", "params": {"grid": "triangle", "cs": 1.0}}, {"rule": "cellnet.link"}]
    net = run(check_recipe({"steps": steps}, host, "t.toml"), host, seed=1, progress=False).state.domains["cells"]
    n = net.n_cells
    state, gs, alive = random_young_state(net, 3)
    h, j1, j2, r1, r2 = 0.2, 1.0, -0.2, 2.3, 6.0
    rule = ActivatorInhibitor.from_params({"h": h, "j1": j1, "j2": j2, "r1": r1, "r2": r2, "materials": [2]}, "t")
    rule.setup(state)
    mat = np.asarray(net["cell__material"])
    assert rule._rings[0].shape == ((mat == 2).sum(), n)                 # rows of the glyph only
    rule.step(state)
    got = np.asarray(net["ca__alive"])
    want = np.where(receives(gs) & (mat == 2), young_field(net, gs, alive, h, j1, j2, r1, r2) > 0, alive)
    assert np.array_equal(got, want) and (got != alive).any()
    # cells of the other material near the seam count in the sums: the rings cross it
    seam = (mat == 2) & (net.positions[:, 0] < 12.0 + r1)
    assert seam.any() and np.asarray(rule._rings[0][np.searchsorted(np.nonzero(mat == 2)[0], np.nonzero(seam)[0])]
                                      [:, mat == 1].sum()) > 0


def test_a_material_id_beyond_int16_is_refused_at_check(host):
    from procgen.errors import RecipeError

    steps = [{"rule": "mesh.primitive", "params": {"shape": "cube"}},
             {"rule": "cellnet.parts", "params": {"materials": [70000]}}]
    with pytest.raises(RecipeError, match=r"steps\[1\] \(cellnet.parts\).*70000 is outside 0..32767"):
        check_recipe({"steps": steps}, host, "t.toml")
