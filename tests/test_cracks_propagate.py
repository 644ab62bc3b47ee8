"""Crack modules and stress release (3DSCA thesis 5.2.4.b-c, plates 5.5 and 5.10; digest 16.6)."""
from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sp
from scipy.sparse.csgraph import connected_components

from procgen.ca.subcell import wrap_angle
from procgen.recipes import check_recipe, load_recipe
from procgen.runner import run

TETRA = ({"rule": "mesh.primitive", "params": {"shape": "tetrahedron"}},)


def _run(host, steps, seed=1):
    recipe = check_recipe({"steps": list(steps)}, host, "<test>")
    res = run(recipe, host, seed=seed, progress=False)
    return res.state, recipe


def _uniform(cells: int, percent=(10, 0, 90, 0)):
    return TETRA + (
        {"rule": "surface.cells", "params": {"target_cells": cells}},
        {"rule": "layers.stack", "params": {"layers": [
            {"preset": "stone", "thickness": 1.0}, {"preset": "glaze", "thickness": 0.5}]}},
        {"rule": "cracks.stress", "params": {"mode": "uniform", "percent": list(percent)}},
    )


def _face_points(state, face: int, where: np.ndarray) -> np.ndarray:
    sc = state.domains["cells"]
    return sc.layout.frames.corners2d[face].mean(axis=0) + where * sc.size


def _seeds(state, face: int, offsets) -> list[list[float]]:
    sc = state.domains["cells"]
    p2 = _face_points(state, face, np.asarray(offsets, float))
    return sc.layout.frames.to_3d(np.full(len(p2), face), p2).tolist()


def _lines_2d(state, face: int):
    """The crack polylines of one facet, in that facet's 2-D frame, with their line index."""
    sc, pl = state.domains["cells"], state.domains["cracks"]
    out = []
    for i in range(pl.n_lines):
        seg = pl.offsets[i]
        if pl["crack__face"][seg] == face:
            p = pl.line(i)
            out.append((i, sc.layout.frames.to_2d(np.full(len(p), face), p)))
    return out


def _near_edge(state, face: int, xy: np.ndarray, cells: float = 2.0) -> bool:
    from procgen_surface.geometry import edge_half_planes
    sc = state.domains["cells"]
    nrm, off = edge_half_planes(sc.layout.frames.corners2d[face:face + 1])
    return bool((nrm[0] @ xy - off[0]).min() < cells * sc.size)


@pytest.fixture(scope="module")
def plate_5_10(host):
    """The plate-5.10 recipe, small: ~5,000 cells (the gallery runs 60,000)."""
    recipe = load_recipe("meshes/plate-5-10", host, ["steps.cells.params.target_cells=5000"])
    res = run(recipe, host, seed=1, progress=False)
    rule = next(s.rule for s in recipe.steps if s.rule.name == "cracks.propagate")
    return res.state, rule


def test_plate_5_10_ends_at_most_one_percent_unstable(plate_5_10):
    state, rule = plate_5_10
    assert state.reports["cracks.unstable_start_fraction"] == pytest.approx(0.85, abs=0.01)
    assert state.reports["cracks.unstable_fraction"] <= 0.01
    assert rule.unstable_fraction() == state.reports["cracks.unstable_fraction"]
    assert rule._mods.n_live == 0                                  # every CM has ended
    # the Pot-Crack list left over is sorted and every member is unstable
    pot = rule.pot_crack()
    imax = rule._imax().ravel()
    assert np.all(np.diff(imax[pot]) <= 0) and np.all(imax[pot] > rule.resistance_value)


def test_steps_are_shorter_than_a_cell(plate_5_10):
    state, rule = plate_5_10
    assert 0 < state.reports["cracks.max_step_cells"] < 1.0


def _bilinear(sc, spec: np.ndarray, face: np.ndarray, xy: np.ndarray) -> np.ndarray:
    """Our own bilinear read of a per-cell (n, 4) field at facet points (thesis Figure 5.9):
    the 4 cells of the facet's grid around the point, missing ones dropped."""
    ij = np.floor(np.asarray(sc.center2d) / sc.size).astype(np.int64)
    where = {(int(f), int(i), int(j)): c for c, (f, i, j) in enumerate(zip(sc.face, ij[:, 0], ij[:, 1]))}
    out = np.zeros((len(face), 4))
    for q, (f, p) in enumerate(zip(face, xy)):
        u = p / sc.size - 0.5
        i0, j0 = np.floor(u).astype(int)
        fx, fy = u - (i0, j0)
        acc, tot = np.zeros(4), 0.0
        for di, dj, w in ((0, 0, (1 - fx) * (1 - fy)), (1, 0, fx * (1 - fy)), (0, 1, (1 - fx) * fy),
                          (1, 1, fx * fy)):
            c = where.get((int(f), i0 + di, j0 + dj))
            if c is not None:
                acc, tot = acc + w * spec[c], tot + w
        out[q] = acc / tot
    return out


def test_heading_turns_by_one_minus_inertia_of_the_angle_to_the_influence(host):
    """Thesis 5.2.4.b: at each step a CM turns by (1 - Iip) x the angle between its heading and
    the influence direction (across the strongest axis of the stress at the head), none where
    that stress is below mR.  Checked from the output alone: with release 0 the output field is
    the field the CMs read, with CSa tiny every turn is a stored vertex, and at each inner
    vertex we recompute the influence from our own bilinear read of the spectrum."""
    iip = 65.0
    state, _ = _run(host, TETRA + (
        {"rule": "surface.cells", "params": {"target_cells": 3000}},
        {"rule": "layers.stack", "params": {"noise_scale": 0.15, "layers": [
            {"preset": "stone", "thickness": 1.0},
            {"preset": "glaze", "thickness": 1.0, "noise": 0.6, "smoothness": 1.0}]}},
        {"rule": "cracks.stress", "params": {"share": 5.0, "loops": 3}},
        {"rule": "cracks.propagate", "iterations": 3, "params": {
            "unstable_start": 0.5, "release": 0.0, "lookahead": 0.0, "inertia": iip,
            "segment_angle": 1e-6, "segment_tolerance": 0.0, "fork_epsilon": 0.0,
            "max_module_steps": 60}}))
    sc, pl = state.domains["cells"], state.domains["cracks"]
    spec = np.asarray(sc["stress__spectrum"])[:, -1]
    mr = state.reports["cracks.resistance"]
    faces = np.asarray(pl["crack__face"])
    idx = np.concatenate([np.arange(a + 1, b - 1) for a, b in zip(pl.offsets[:-1], pl.offsets[1:])])
    p2 = sc.layout.frames.to_2d(faces[idx], pl.points[idx])
    prev = sc.layout.frames.to_2d(faces[idx], pl.points[idx - 1])
    nxt = sc.layout.frames.to_2d(faces[idx], pl.points[idx + 1])
    a_in = np.arctan2(*(p2 - prev).T[::-1])
    turn = wrap_angle(np.arctan2(*(nxt - p2).T[::-1]) - a_in)
    here = _bilinear(sc, spec, faces[idx], p2)
    top = np.sort(here, axis=1)
    clear = top[:, -1] - top[:, -2] > 1e-9                      # a unique strongest axis
    infl = np.argmax(here, axis=1) * np.pi / 4 + np.pi / 2
    d = wrap_angle(infl - a_in)
    d = np.where(d > np.pi / 2, d - np.pi, np.where(d <= -np.pi / 2, d + np.pi, d))
    above = top[:, -1] > mr
    assert clear.sum() > 200 and (clear & above & (np.abs(d) > 0.05)).sum() > 100
    want = np.where(above, (1 - iip / 100) * np.abs(d), 0.0)
    ok = clear & (np.abs(top[:, -1] - mr) > 1e-9)
    np.testing.assert_allclose(np.abs(turn[ok]), want[ok], atol=1e-7)
    # the side: towards the influence, but for near-perpendicular influence (either side as near)
    side = ok & above & (np.abs(np.abs(d) - np.pi / 2) > np.radians(15.5)) & (np.abs(d) > 1e-6)
    assert side.sum() > 50 and np.all(np.sign(turn[side]) == np.sign(d[side]))


def test_widths_stay_in_range_and_mark_the_cracked_cells(plate_5_10):
    state, rule = plate_5_10
    sc, pl = state.domains["cells"], state.domains["cracks"]
    w = np.asarray(sc["crack__width"])
    ids = np.asarray(sc["crack__id"])
    assert np.array_equal(w > 0, ids >= 0)
    assert w.max() <= rule.max_width and (w >= 0).all()
    pw = np.asarray(pl["crack__width"])
    assert (pw > 0).all() and (pw <= rule.max_width).all()
    # the width grows along every line (released stress only accumulates)
    for i in range(pl.n_lines):
        seg = pw[pl.offsets[i]:pl.offsets[i + 1]]
        assert np.all(np.diff(seg) >= -1e-15)


def _split_cracks(sc, layer: int = -1) -> tuple[int, int, int]:
    """(cracks, cracks not one 8-connected set of cells, cracks spanning several facets), with
    8-connected meaning Moore neighbours in the cross-edge cell graph, facet edges included."""
    ids = np.asarray(sc["crack__id"])[:, layer]
    g = sc.cell_graph("moore")
    n = sc.n_cells
    same = (ids[g.rows] >= 0) & (ids[g.rows] == ids[g.indices])
    adj = sp.csr_matrix((np.ones(int(same.sum())), (g.rows[same], g.indices[same])), shape=(n, n))
    _, comp = connected_components(adj, directed=False)
    cracked = np.nonzero(ids >= 0)[0]
    pairs = np.unique(np.column_stack([ids[cracked], comp[cracked]]), axis=0)
    n_cracks = len(np.unique(ids[cracked]))
    faces = np.unique(np.column_stack([ids[cracked], np.asarray(sc.face)[cracked]]), axis=0)
    multi = int((np.bincount(faces[:, 0]) > 1).sum())
    return n_cracks, len(pairs) - n_cracks, multi


def test_every_crack_is_8_connected_on_the_tetrahedron(plate_5_10):
    n_cracks, split, multi = _split_cracks(plate_5_10[0].domains["cells"])
    # mud's release reaches the slivers cut by the facet edges, so no cracks are born along
    # them: about 20 cracks at this size, ten of them crossing facet edges
    assert n_cracks >= 18 and multi > 5
    assert split == 0


_VASE = {"rule": "mesh.lathe", "params": {"sections": 12, "profile": [
    [0.0, 0.0], [0.3, 0.0], [0.45, 0.2], [0.5, 0.4], [0.35, 0.7], [0.22, 0.9], [0.3, 1.05]]}}


@pytest.mark.parametrize("mesh", [{"rule": "mesh.primitive", "params": {"shape": "cube"}}, _VASE],
                         ids=["cube", "vase"])
def test_every_crack_is_8_connected_across_facet_edges(host, mesh):
    """Cracks crossing the cube's 90-degree edges and the vase's many small facets (whose
    grids line up with no neighbour's) stay one set of Moore-connected cells each."""
    state, _ = _run(host, (mesh,
        {"rule": "surface.cells", "params": {"target_cells": 4000}},
        {"rule": "layers.stack", "params": {"noise_scale": 0.15, "layers": [
            {"preset": "stone", "thickness": 1.0},
            {"preset": "glaze", "thickness": 1.0, "noise": 0.5, "smoothness": 1.0}]}},
        {"rule": "cracks.stress", "params": {"share": 5.0, "loops": 5}},
        {"rule": "cracks.propagate", "params": {"unstable_start": 0.6, "stop_fraction": 0.01},
         "until": "stable", "max_iterations": 500}))
    n_cracks, split, multi = _split_cracks(state.domains["cells"])
    assert n_cracks > 10 and multi > 5
    assert split == 0


def test_polylines_follow_the_contract(plate_5_10):
    """Every segment lies within one facet, on it; lines carry layer and type."""
    state, _ = plate_5_10
    sc, pl = state.domains["cells"], state.domains["cracks"]
    face = np.asarray(pl["crack__face"])
    line_of = np.repeat(np.arange(pl.n_lines), np.diff(pl.offsets))
    assert all(len(set(face[line_of == i])) == 1 for i in range(0, pl.n_lines, 7))
    p2 = sc.layout.frames.to_2d(face, pl.points)
    back = sc.layout.frames.to_3d(face, p2)
    assert np.abs(back - pl.points).max() < 1e-9                 # on the facet's plane
    assert set(np.unique(pl["crack__layer"])) == {1}
    assert set(np.unique(pl["crack__type"])) == {0}              # plate 5.10 seeds I only
    assert state.reports["cracks.collisions"] > 0                # junctions formed


def test_runs_are_byte_identical(host, plate_5_10):
    state, _ = plate_5_10
    recipe = load_recipe("meshes/plate-5-10", host, ["steps.cells.params.target_cells=5000"])
    again = run(recipe, host, seed=1, progress=False).state
    for dom, field in (("cells", "crack__width"), ("cells", "stress__spectrum"), ("cracks", "crack__width")):
        assert np.asarray(state.domains[dom][field]).tobytes() == np.asarray(again.domains[dom][field]).tobytes()
    assert state.domains["cracks"].points.tobytes() == again.domains["cracks"].points.tobytes()


def _one_step_release(host, base, d: float, rel: float, **params):
    """One I crack at facet 0's centre, one step per head: the spectrum before and after, and
    the birth column (whose centres project onto both heads' first steps, so both release
    there) with each cell's distance x from the horizontal path, in cells."""
    state, _ = _run(host, base)
    before = np.asarray(state.domains["cells"]["stress__spectrum"])[:, 1].copy()
    seeds = _seeds(state, 0, [[0.0, 0.0]])
    state, _ = _run(host, base + ({"rule": "cracks.propagate", "params": {
        "resistance": 0.05, "seeds": seeds, "seed_types": ["I"], "release_distance": d,
        "release": rel, "max_module_steps": 1, "lookahead": 0.0, **params}, "until": "stable"},))
    sc = state.domains["cells"]
    after = np.asarray(sc["stress__spectrum"])[:, 1]
    p0 = _lines_2d(state, 0)[0][1][0]                       # the birth cell's centre
    rel_xy = (np.asarray(sc.center2d) - p0) / sc.size
    inside = (np.asarray(sc.face) == 0) & (np.abs(rel_xy[:, 0]) < 0.05) & (np.abs(rel_xy[:, 1]) < d + 2)
    assert inside.sum() >= 9
    return before, after, inside, np.abs(rel_xy[inside, 1])


def test_release_is_linear_in_distance_and_never_negative(host):
    """One I crack, one step per head, on a uniform field: the vertical axis drops by
    release x S x (1 - x/d) at distance x from the (horizontal) path, 0 beyond d."""
    d, rel = 4.0, 0.5
    before, after, inside, x = _one_step_release(host, _uniform(20000), d, rel)
    assert (after >= 0).all()
    assert np.allclose(before[:, 0], after[:, 0])                 # along the path: untouched
    expect = np.where(x < d, 2 * rel * 0.9 * (1 - x / d), 0.0)
    assert (expect > 0).sum() >= 7
    np.testing.assert_allclose(before[inside, 2] - after[inside, 2], expect, atol=1e-9)


def test_90_10_field_gives_horizontal_cracks(host):
    base = _uniform(20000)
    state, _ = _run(host, base)
    seeds = _seeds(state, 0, [[-15.0, 0.0]])
    state, _ = _run(host, base + ({"rule": "cracks.propagate", "params": {
        "resistance": 0.5, "seeds": seeds, "max_module_steps": 30}, "until": "stable"},))
    lines = _lines_2d(state, 0)
    assert state.domains["cracks"]["crack__type"][0] == 0          # Table 5.3: M0S0 -> I
    assert len(lines) == 2
    for _, p in lines:
        d = p[-1] - p[0]
        assert abs(np.degrees(np.arctan2(d[1], d[0])) % 180 - 90) > 89    # horizontal


def test_two_parallel_cracks_meet_at_about_a_right_angle(host):
    """Plate 5.5: two parallel I cracks on a 90/10 field; the one drawn into the other meets
    it at 90 +- 20 degrees."""
    base = _uniform(40000)
    state, _ = _run(host, base)
    seeds = _seeds(state, 0, [[-20.0, 2.0], [20.0, -2.0]])
    state, _ = _run(host, base + ({"rule": "cracks.propagate", "params": {
        "resistance": 0.05, "seeds": seeds, "seed_types": ["I", "I"], "release_distance": 8.0,
        "max_module_steps": 200}, "until": "stable"},))
    lines = _lines_2d(state, 0)
    segs = [(p[k], p[k + 1]) for _, p in lines for k in range(len(p) - 1)]
    angles = []
    for i, p in lines:
        end, last = p[-1], p[-1] - p[-2]
        if np.linalg.norm(last) == 0:
            continue
        # the nearest segment of another line, within a cell of the end
        best, ang = np.inf, None
        for a, b in segs:
            if np.allclose(a, p[-2]) or np.allclose(b, end) or np.allclose(a, end):
                continue
            ab = b - a
            t = np.clip(np.dot(end - a, ab) / max(np.dot(ab, ab), 1e-300), 0, 1)
            dist = np.linalg.norm(end - (a + t * ab))
            if dist < best and np.linalg.norm(ab) > 0:
                best = dist
                ang = abs(np.degrees(wrap_angle(np.arctan2(last[1], last[0]) - np.arctan2(ab[1], ab[0]))))
        if best < state.domains["cells"].size * 1.5:
            angles.append(min(ang, 180 - ang))
    assert state.reports["cracks.collisions"] >= 1
    assert angles and max(angles) >= 70.0
    assert all(a > 70.0 for a in angles if a > 45.0)
    # the run's own report of the meeting angles (shown on the plate-5.5 card) agrees
    met = [a for a in angles if a > 45.0]
    assert state.reports["cracks.meetings"] == len(met)
    assert state.reports["cracks.meeting_angle_deg"] == pytest.approx(np.median(met), abs=0.5)


def test_fork_children_leave_at_60_degrees(host):
    """Two equal axes (a tie within epsilon): the CM forks into two at +-pi/3."""
    base = _uniform(6000, percent=(90, 0, 90, 0))
    state, _ = _run(host, base)
    seeds = _seeds(state, 0, [[0.0, 0.0]])
    state, _ = _run(host, base + ({"rule": "cracks.propagate", "params": {
        "resistance": 0.5, "seeds": seeds, "seed_types": ["I"], "inertia": 100.0,
        "max_module_steps": 6}, "until": "stable"},))
    assert state.reports["cracks.forks"] >= 2
    lines = _lines_2d(state, 0)
    birth = tuple(np.round(lines[0][1][0], 12))
    ends: dict[tuple, list[np.ndarray]] = {}
    for _, p in lines:
        ends.setdefault(tuple(np.round(p[-1], 12)), []).append(p[-1] - p[-2])
    found = 0
    for _, p in lines:
        parents = ends.get(tuple(np.round(p[0], 12)))
        if parents is None or tuple(np.round(p[0], 12)) == birth or _near_edge(state, 0, p[0]):
            continue                                # not a fork (birth, facet crossing)
        child = p[1] - p[0]
        turns = [abs(np.degrees(wrap_angle(np.arctan2(child[1], child[0]) - np.arctan2(q[1], q[0]))))
                 for q in parents]                  # two heads may end on one point
        assert min(abs(t - 60.0) for t in turns) < 1e-6
        found += 1
    assert found >= 4


@pytest.mark.parametrize("kind,n_heads", [("T", 3), ("Y", 3), ("X", 4)])
def test_seeded_types_start_their_heads(host, kind, n_heads):
    base = _uniform(20000)
    state, _ = _run(host, base)
    seeds = _seeds(state, 0, [[0.0, 0.0]])
    state, _ = _run(host, base + ({"rule": "cracks.propagate", "params": {
        "resistance": 0.5, "seeds": seeds, "seed_types": [kind], "inertia": 100.0,
        "max_module_steps": 3}, "until": "stable"},))
    lines = _lines_2d(state, 0)
    assert len(lines) == n_heads
    ang = np.sort([np.arctan2(*(p[1] - p[0])[::-1]) % (2 * np.pi) for _, p in lines])
    gaps = np.diff(np.concatenate([ang, [ang[0] + 2 * np.pi]]))
    want = {"T": [90, 90, 180], "Y": [120, 120, 120], "X": [90, 90, 90, 90]}[kind]
    np.testing.assert_allclose(np.sort(np.degrees(gaps)), want, atol=1e-6)


@pytest.mark.parametrize("drag", [1.0, 0.5])
def test_kinetic_potential_runs_out_below_mr_at_the_drag_rate(host, drag):
    """A CM born with K = p x imax on a uniform field 0.1 below mR loses p x drag x 0.1 x step
    per step: it ends after ceil(imax / (drag x 0.1 x step)) steps, straight (no axis above mR
    to turn it), whatever p."""
    base = _uniform(20000)
    state, _ = _run(host, base)
    seeds = _seeds(state, 0, [[0.0, 0.0]])
    state, _ = _run(host, base + ({"rule": "cracks.propagate", "params": {
        "resistance": 1.0, "seeds": seeds, "seed_types": ["I"], "release": 0.0, "drag": drag,
        "potential": 3.0}, "until": "stable"},))
    sc = state.domains["cells"]
    n_steps = int(np.ceil(0.9 / (drag * 0.1 * 0.7)))
    lines = _lines_2d(state, 0)
    assert len(lines) == 2 and state.reports["cracks.stopped_by_potential"] == 2
    for _, p in lines:
        assert len(p) == 2                                           # straight
        assert np.linalg.norm(p[1] - p[0]) / sc.size == pytest.approx(0.7 * n_steps, abs=1e-6)


def test_cell_release_takes_a_share_of_each_cells_own_stress(host):
    """release_of = "cell": a cell at x cells from the path loses release x (1 - x/d) of its
    own across stress (here from both heads' first steps), whatever the stress driving the
    CM; the share caps at 1."""
    base = _uniform(20000)[:-1] + ({"rule": "cracks.stress", "params": {
        "mode": "uniform", "percent": [10.0, 0.0, 90.0, 0.0], "jitter": 0.3}},)
    d, rel = 4.0, 0.3
    before, after, inside, x = _one_step_release(host, base, d, rel, release_of="cell")
    share = np.where(x < d, np.minimum(2 * rel * (1 - x / d), 1.0), 0.0)
    assert (share > 0).sum() >= 7
    np.testing.assert_allclose(after[inside, 2], before[inside, 2] * (1 - share), atol=1e-12)
    np.testing.assert_allclose(after[:, 0], before[:, 0])             # along the path: untouched


def test_spectra_turn_between_facet_frames_conserving_their_total():
    """A spectrum read in a facet turned by 90 degrees has its axes swapped (0 <-> 90, 45 <->
    135); by 30 degrees it is interpolated between the two nearest axes; every row and column of
    the reading weights sums to 1, so what relaxation carries over a facet edge is conserved."""
    from procgen_cracks.stress import frame_weights

    def turn(deg: float, flip: bool = False) -> np.ndarray:
        a = np.radians(deg)
        m = np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])
        return m @ np.diag([1.0, -1.0]) if flip else m

    w = frame_weights(np.stack([turn(90), turn(30), turn(0), turn(20, flip=True)]))
    np.testing.assert_allclose(w[0], np.eye(4)[[2, 3, 0, 1]], atol=1e-12)
    np.testing.assert_allclose(w[1, 0], [1 / 3, 2 / 3, 0, 0], atol=1e-12)
    np.testing.assert_allclose(w[2], np.eye(4), atol=1e-12)
    np.testing.assert_allclose(w.sum(axis=2), 1.0, atol=1e-12)
    np.testing.assert_allclose(w.sum(axis=1), 1.0, atol=1e-12)


@pytest.mark.parametrize("shape", ["cube", "icosphere"])
def test_walking_over_facet_edges_and_back_returns_to_the_start(host, shape):
    """A point walked several cells over facet edges (unfolded edge by edge), then walked back
    along the carried direction reversed, lands where it started; the carried frame stays
    orthonormal (a rotation or a reflection)."""
    from procgen_cracks.modules import FacetEdges
    state, _ = _run(host, ({"rule": "mesh.primitive", "params": {"shape": shape}},
                           {"rule": "surface.cells", "params": {"target_cells": 3000}}))
    sc = state.domains["cells"]
    ed = FacetEdges(sc)
    rng = np.random.default_rng(0)
    face = np.asarray(sc.face)[rng.integers(0, sc.n_cells, 300)]
    xy = sc.layout.frames.corners2d[face].mean(axis=1)
    ang = rng.uniform(0, 2 * np.pi, len(face))
    disp = 12.0 * sc.size * np.column_stack([np.cos(ang), np.sin(ang)])
    e1, e2 = np.tile([1.0, 0.0], (len(face), 1)), np.tile([0.0, 1.0], (len(face), 1))
    f2, p2, _, (m1, m2) = ed.walk(face, xy, disp, dirs=(e1, e2))
    assert (f2 >= 0).all() and (f2 != face).sum() > 200          # most cross some edge
    mat = np.stack([m1, m2], axis=2)
    np.testing.assert_allclose(np.einsum("mji,mjk->mik", mat, mat), np.broadcast_to(np.eye(2), mat.shape),
                               atol=1e-9)
    back = -np.einsum("mij,mj->mi", mat, disp)
    f3, p3, _, _ = ed.walk(f2, p2, back)
    to3 = sc.layout.frames.to_3d
    np.testing.assert_allclose(to3(f3, p3), to3(face, xy), atol=1e-6 * sc.size)
