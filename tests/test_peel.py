"""Peeling by groups (3DSCA thesis ch. 5.3; acceptance properties of the issue's peeling list)."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from procgen import Grid, InputError, State
from procgen.ca.graph import grid_graph
from procgen.testing import drive_rule
from procgen_cracks.peel import Peel, deaden, plan_peeling, sharp_links
from procgen_layers.materials import parse_materials
from procgen_layers.stack import put_thickness, store_table
from procgen_surface.domain import SurfaceCells


def grid_state(cracked: np.ndarray, paint: float = 0.4) -> State:
    """A Grid with copper under paint and a crack mask on the paint (the contract's input)."""
    ny, nx = cracked.shape
    g = Grid(shape=(ny, nx), spacing=1.0)
    table = parse_materials(["copper", {"preset": "patina", "name": "paint"}])
    thick = np.column_stack([np.ones(ny * nx), np.full(ny * nx, paint)])
    put_thickness(g, thick, table)
    store_table(g, table)
    width = np.zeros((ny, nx, 2))
    width[..., 1] = cracked * 0.5
    g.add_field("crack__width", width, at="cell", units="length")
    st = State(seed=1)
    st.add_domain("cells", g)
    return st


def run_peel(st: State, **params) -> tuple[Peel, int]:
    rule = Peel(**params)
    return rule, drive_rule(rule, st)


def rooms(ny=40, nx=60, every_y=10, every_x=15) -> np.ndarray:
    c = np.zeros((ny, nx), bool)
    c[::every_y, :] = True
    c[:, ::every_x] = True
    return c


def test_levels_are_the_distance_from_the_cracks_and_groups_the_rooms():
    cracked = rooms()
    st = grid_state(cracked)
    rule, _ = run_peel(st, peel_share=0.0)
    g = st.get("cells")
    level, group = g["peel__level"], g["peel__group"]
    ref = ndimage.distance_transform_cdt(~cracked, metric="taxicab")   # convex rooms: hops = taxicab
    assert np.array_equal(level, ref)
    # every non-cracked cell in exactly one group, cracked cells in none
    assert np.all(group[~cracked] >= 0) and np.all(group[cracked] == -1)
    lab, n = ndimage.label(~cracked, structure=ndimage.generate_binary_structure(2, 1))
    assert group.max() + 1 == n
    pairs = np.unique(np.stack([group[~cracked], lab[~cracked]]), axis=1)
    assert pairs.shape[1] == n                                        # one-to-one with the rooms
    # the level propagation took one pass per ring: the reported passes are the deepest level
    assert rule._plan.passes == level.max()


def test_groups_never_cross_cracks_and_a_diagonal_crack_does_not_leak():
    ny, nx = 30, 30
    cracked = np.eye(ny, nx, dtype=bool) | np.eye(ny, nx, k=7, dtype=bool)   # 8-connected lines
    st = grid_state(cracked)
    run_peel(st, peel_share=0.0)
    group = st.get("cells")["peel__group"].ravel()
    g4 = grid_graph(ny, nx).neighbourhood("von_neumann")
    a, b = group[g4.rows], group[g4.indices]
    both = (a >= 0) & (b >= 0)
    assert np.all(a[both] == b[both])            # side neighbours off the cracks share a group
    assert group.max() + 1 == 3                  # two diagonal cracks: three groups
    # flooding over 8 neighbours leaks through the one-cell diagonal line (thesis ambiguity)
    st8 = grid_state(cracked)
    run_peel(st8, peel_share=0.0, neighbourhood="moore")
    assert st8.get("cells")["peel__group"].max() + 1 == 1


def figure_5_24() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Group A (14 x 14, no inner crack) and group B (14 x 28, twice A, two inner cracks)."""
    c = np.zeros((16, 47), bool)
    c[0, :] = c[-1, :] = True
    c[:, 0] = c[:, 15] = c[:, -1] = True
    c[1:10, 24] = True                          # inner cracks of B, hanging from its border
    c[6:15, 36] = True
    a = np.zeros_like(c)
    a[1:15, 1:15] = True
    b = np.zeros_like(c)
    b[1:15, 16:46] = True
    return c, a & ~c, b & ~c


def test_figure_5_24_order_b_with_inner_cracks_peels_before_a():
    cracked, a, b = figure_5_24()
    assert b.sum() > 1.8 * a.sum()             # A has about half B's area ...
    st = grid_state(cracked)
    run_peel(st)
    g = st.get("cells")
    t, lev = g["peel__time"], g["peel__level"]
    assert lev[a].max() == 7 and lev[b].max() < 7   # ... but is deeper (Figure 5.24: 7 vs 5-6)
    assert len(np.unique(t[a])) == 1 and len(np.unique(t[b])) == 1
    assert t[b][0] < t[a][0]                   # "A should peel after B"


def test_each_group_removed_once_with_its_cracked_border_and_the_layer_ends_empty():
    rng = np.random.default_rng(4)
    cracked = rooms(48, 64, 12, 16)
    cracked[rng.integers(1, 47, 6), :] = True       # extra cracks make groups of several depths
    st = grid_state(cracked)
    g = st.get("cells")
    copper0 = g["layers__thickness"][..., 0].copy()
    history = []
    rule = Peel()
    st.iteration = -1
    rule.setup(st)
    it = 0
    while True:
        st.iteration = it
        before = g["layers__thickness"][..., 1].copy()
        if not rule.step(st):
            break
        history.append(before - g["layers__thickness"][..., 1])
        it += 1
    t = g["peel__time"]
    group = g["peel__group"]
    removed = np.stack(history) > 0
    assert np.all(removed.sum(axis=0) == 1)              # every cell peels exactly once
    for k in np.unique(group[group >= 0]):
        cells = group == k
        assert len(np.unique(t[cells])) == 1             # a group goes at once
    # cracked cells go with the earliest group beside them
    gg = grid_graph(*cracked.shape).neighbourhood("von_neumann")
    tf, cf, gf = t.ravel(), cracked.ravel(), group.ravel()
    e = cf[gg.rows] & (gf[gg.indices] >= 0)
    first = np.full(cracked.size, 10**9)
    np.minimum.at(first, gg.rows[e], tf[gg.indices[e]])
    has = cf & (first < 10**9)
    assert np.array_equal(tf[has], first[has])
    assert np.all(g["layers__thickness"][..., 1] == 0)   # the layer is empty at the end
    assert np.array_equal(g["layers__thickness"][..., 0], copper0)   # the copper is untouched
    assert np.all(g["peel__lift"] == 0)                   # nothing left to lift
    # shallow groups first: group depth never decreases with peel time
    lev = g["peel__level"]
    depth_by_time = [lev[(t == s) & (group >= 0)].max() for s in np.unique(t[group >= 0])]
    assert depth_by_time == sorted(depth_by_time)


def test_residue_keeps_a_share_of_the_layer_on_the_cracks():
    cracked = rooms(20, 30, 10, 15)
    st = grid_state(cracked, paint=0.4)
    run_peel(st, residue=0.25)
    paint = st.get("cells")["layers__thickness"][..., 1]
    assert np.allclose(paint[cracked], 0.1) and np.all(paint[~cracked] == 0)


def test_peel_share_stops_mid_peel_and_lift_follows_the_deaden_function():
    cracked = rooms(40, 60, 10, 15)
    cracked[:20, 30:] = False
    cracked[:20, 30:][::4, :] = True            # shallow strips beside deep rooms: two depths
    st = grid_state(cracked)
    rule, iters = run_peel(st, peel_share=0.5, lift_height=0.2)
    g = st.get("cells")
    p = rule._plan
    assert iters == p.passes + int(np.ceil(0.5 * p.n_steps))
    on = (g["peel__time"] < 0) & (g["peel__level"] > 0)
    assert 0 < on.sum() < (~cracked).sum()
    lift = g["peel__lift"]
    age = p.passes - g["peel__level"] + 1
    assert np.allclose(lift[on], 0.2 * age[on] / (1 + age[on]))
    assert np.all(lift[~on] == 0)


def test_deaden_is_zero_at_zero_increasing_and_below_t():
    pc = np.arange(0, 200)
    for kind in ("rational", "root"):
        t = deaden(pc, 2.0, kind)
        assert t[0] == 0 and np.all(np.diff(t) > 0) and np.all(t < 2.0)


def folded_square(angle_deg: float) -> SurfaceCells:
    """Two unit squares sharing the edge x = 1, the second bent up by angle_deg."""
    a = np.radians(angle_deg)
    v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0],
                  [1 + np.cos(a), 0, np.sin(a)], [1 + np.cos(a), 1, np.sin(a)]], float)
    f = np.array([[0, 1, 2], [0, 2, 3], [1, 4, 5], [1, 5, 2]])
    return SurfaceCells.from_mesh(v, f, cell_size=0.05)


@pytest.mark.parametrize("angle,gamma,groups", [(0.0, 30.0, 1), (60.0, 30.0, 2), (60.0, 90.0, 1),
                                                (90.0, 30.0, 2)])
def test_a_sharp_edge_splits_a_group_and_coplanar_facets_do_not(angle, gamma, groups):
    sc = folded_square(angle)
    graph = sc.cell_graph("von_neumann")
    keep = ~sharp_links(sc, graph, gamma)
    n = sc.n_cells
    plan = plan_peeling(graph, np.zeros(n, bool), np.ones(n, bool), keep)
    assert plan.group.max() + 1 == groups
    if groups == 2:                   # one group per side of the fold, levels from the edge
        side = sc.face >= 2
        assert len(np.unique(plan.group[side])) == 1 and len(np.unique(plan.group[~side])) == 1
        x = sc.center3d[~side, 0]
        lev = plan.level[~side]
        assert np.all(x[lev == 1] > 1.0 - 2 * sc.size)           # border = the fold only
        hops = (1.0 - x) / sc.size                 # straight-line cells from the fold
        # 4-neighbour hops across the triangles' differently turned grids: between the
        # straight count and sqrt(2) times it
        assert np.all((lev >= hops - 0.5) & (lev <= np.sqrt(2) * hops + 2.5))
    else:                             # the triangle edges (also the coplanar diagonal) split nothing
        assert np.all(plan.group == 0)


def test_bad_layer_and_missing_cracks_are_one_line_errors():
    st = grid_state(rooms(10, 10, 5, 5))
    with pytest.raises(InputError, match="no layer 'glaze'"):
        Peel(layer="glaze").setup(st)
    st.get("cells")._fields.pop("crack__width")
    with pytest.raises(InputError, match="no crack__width"):
        Peel().setup(st)


def test_imposed_borders_are_closed_for_four_neighbour_flooding():
    from procgen_cracks.imposed import region_borders
    rng = np.random.default_rng(9)
    labels = ndimage.zoom(rng.integers(0, 12, (6, 8)), 6, order=0).ravel()
    g4 = grid_graph(36, 48).neighbourhood("von_neumann")
    cracked = region_borders(g4, labels)
    a, b = g4.rows, g4.indices
    free = ~cracked[a] & ~cracked[b]
    assert np.all(labels[a][free] == labels[b][free])      # no uncracked pair across a border
    assert cracked.sum() < 0.3 * cracked.size                # one-sided: a line, not a band


def test_same_seed_same_peeling_on_a_mesh():
    from procgen import check_recipe, get_plugin_manager, run
    host = get_plugin_manager()
    data = {"recipe": {"name": "t", "seed": 3}, "steps": [
        {"rule": "mesh.primitive", "params": {"shape": "cube", "subdivisions": 1}},
        {"rule": "surface.cells", "params": {"target_cells": 1500}},
        {"rule": "layers.stack", "params": {"layers": ["copper", {"preset": "patina", "thickness": 0.5}]}},
        {"rule": "cracks.imposed", "params": {"seeds": 10, "gaps": 0.15}},
        {"rule": "cracks.peel", "until": "stable", "max_iterations": 200, "params": {"lift_height": 0.1}}]}
    runs = [run(check_recipe(data, host), host, progress=False).state.get("cells") for _ in range(2)]
    for name in ("peel__group", "peel__level", "peel__time", "peel__lift", "layers__thickness"):
        assert np.array_equal(runs[0][name], runs[1][name]), name
    sc = runs[0]
    assert sc["peel__group"].max() >= 5                       # the cube's faces and cracks cut groups
    assert np.all(sc["layers__thickness"][:, 1] == 0)          # fully peeled ...
    assert np.all(sc["peel__time"] >= 0)                       # ... every cell exactly at one time
