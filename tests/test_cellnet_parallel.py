"""Several behaviours in one synchronous step (seed 002 Figure 1) and one-sided regrouping (Table 1)."""
from __future__ import annotations

import numpy as np
import pytest

from procgen import RecipeError, State
from procgen.ca.lifelike import life_step, parse_rule
from _cellnet import permuted
from procgen_cellnet.boxes import pairs_kdtree
from procgen_cellnet.network import CellNetwork
from procgen_cellnet.parallel import ParallelBehaviours, life_step_gated, parallel_step, regroup_step
from procgen_cellnet.seeding import link_radius, seed_cells
from procgen_cellnet.states import ACTIVE, INFLUENCING, RECEIVING, SLEEPING, put_states, receives, sends

#: every behaviour on some materials; the crack shares cells with diffuse (0) and corrode (6)
MIX = {"diffuse": [0, 1], "melt": [1], "life": [2], "regroup": [3], "majority": [4],
       "young": [5], "corrode": [6], "watercolor": [7], "crack": [0, 3, 6]}
SETTINGS = {"life": {"rule": "B3/S23"}, "young": {"field": "young__alive", "r1": 1.5, "r2": 3.5},
            "corrode": {"fraction_labels": 0.5, "dp": 0.3}, "watercolor": {"dp": 0.05},
            "crack": {"crack_state": "influencing"}}


def network(seed=0, n=24.0):
    v = np.array([[0, 0, 0], [n, 0, 0], [n, n / 2, 0], [0, n / 2, 0]], float)
    s = seed_cells(v, np.array([[0, 1, 2], [0, 2, 3]]), "square8", 1.0)
    rng = np.random.default_rng(seed)
    p = s.positions + np.column_stack([np.zeros((len(s.positions), 2)),
                                       0.2 * rng.random(len(s.positions))])
    r = link_radius("square8", 1.0, 0.01)
    net = CellNetwork(p, pairs_kdtree(p, r), cs=1.0, grid="square8", radius=r)
    net.add_field("cell__normal", s.normals, at="cell")
    mat = np.minimum(p[:, 0] // (n / 4), 3).astype(np.int16) + 4 * (p[:, 1] > n / 4)
    net.add_field("cell__material", mat, at="cell")
    gs = rng.choice([SLEEPING, RECEIVING, INFLUENCING, ACTIVE], net.n_cells,
                    p=[0.05, 0.1, 0.1, 0.75]).astype(np.int8)
    put_states(net, gs)
    color = rng.random((net.n_cells, 3)).astype(np.float32)
    net.add_field("surface__color", color, at="cell")
    net.add_field("cell__colored", rng.random(net.n_cells) < 0.6, at="cell")
    net.add_field("ca__alive", rng.random(net.n_cells) < 0.5, at="cell")
    net.add_field("young__alive", rng.random(net.n_cells) < 0.5, at="cell")
    net.add_field("voronoi__label", (1 + p[:, 0] // 3 + 10 * (p[:, 1] // 3)).astype(np.int32), at="cell")
    wet = mat == 7
    net.add_field("water__volume", np.where(wet, rng.random(net.n_cells), 0.0), at="cell")
    net.add_field("pigment__color", rng.random((net.n_cells, 3)).astype(np.float32), at="cell")
    net.add_field("paint__layer", np.where(wet & (rng.random(net.n_cells) < 0.7), 1, 0).astype(np.int8),
                  at="cell")
    return net


def ready(net, seed=7):
    """A set-up cellnet.parallel (its rules) on a state holding ``net``."""
    state = State(seed=seed)
    state.add_domain("cells", net)
    rule = ParallelBehaviours.from_params({"behaviours": MIX, "settings": SETTINGS}, "t")
    rule.setup(state)
    return rule._rules


def gates(net):
    gs = np.asarray(net["cell__state"])
    return sends(gs), receives(gs)


def test_one_step_equals_each_behaviour_alone_from_the_same_old_state():
    net = network()
    rules = ready(net)
    old = permuted(net, np.arange(net.n_cells))              # an untouched copy of time t
    send, update = gates(net)
    out, changed = parallel_step(net, rules, send, update)
    assert changed
    mat = np.asarray(old["cell__material"])
    # each behaviour run alone on its own cells, from the same time-t network
    alone = {b: r.advance(old, send, update & np.isin(mat, MIX[b])) for b, r in rules.items()}
    cracked = alone["crack"].written
    assert cracked.any() and np.isin(mat[cracked], MIX["crack"]).all()
    written = np.zeros(net.n_cells, bool)
    for b, nxt in alone.items():
        written |= nxt.written
        acts = nxt.positions is not None and not np.array_equal(nxt.positions, old.positions)
        for name, a in nxt.fields.items():
            w = nxt.written & ~cracked if b != "crack" and name in alone["crack"].fields else nxt.written
            assert np.array_equal(np.asarray(out[name])[w], a[w], equal_nan=a.dtype.kind == "f"), (b, name)
            acts |= name not in old or not np.array_equal(a[w], np.asarray(old[name])[w],
                                                          equal_nan=a.dtype.kind == "f")
        assert acts, f"{b} changed nothing"                    # each one does something
        if nxt.positions is not None:
            assert np.array_equal(out.positions[nxt.written], nxt.positions[nxt.written])
    # cells no behaviour writes keep every time-t value
    for name in old.field_names():
        a, b = np.asarray(out[name]), np.asarray(old[name])
        assert np.array_equal(a[~written], b[~written], equal_nan=a.dtype.kind == "f"), name
    assert np.array_equal(out.positions[~written], old.positions[~written])
    # running them one after another is not the same: regroup would read Life's new cells
    alive, want = np.asarray(old["ca__alive"]), np.asarray(out["ca__alive"])
    own = {b: update & np.isin(mat, MIX[b]) for b in ("life", "regroup")}
    after_life = np.where(own["life"], want, alive)
    seq = regroup_step(old, after_life, send, own["regroup"], "one_sided")
    assert not np.array_equal(seq[own["regroup"]], want[own["regroup"]])


def test_gated_life_is_conways_life_when_every_cell_is_active():
    net = network()
    alive = np.asarray(net["ca__alive"])
    everyone = np.ones(net.n_cells, bool)
    g = net.cell_graph("moore")
    lut = parse_rule("B3/S23").lut(int(g.degree.max()))
    assert np.array_equal(life_step_gated(net, alive, everyone, everyone, "B3/S23"),
                          life_step(g, alive, lut))


def test_one_step_commutes_with_cell_permutation():
    net = network(3)
    perm = np.random.default_rng(4).permutation(net.n_cells)
    pnet = permuted(net, perm)
    a, _ = parallel_step(net, ready(net), *gates(net))
    b, _ = parallel_step(pnet, ready(pnet), *gates(pnet))
    assert np.allclose(a.positions[perm], b.positions)
    for name in ("surface__color", "cell__normal", "water__volume", "pigment__color",
                 "corrosion__potential"):
        assert np.allclose(np.asarray(a[name])[perm], b[name], atol=1e-6, equal_nan=True), name
    for name in ("ca__alive", "young__alive", "cell__colored", "cell__state", "crack__mask",
                 "paint__layer"):
        assert np.array_equal(np.asarray(a[name])[perm], b[name]), name


def test_one_sided_regrouping_only_kills_cells_with_fewer_than_half_live_senders():
    net = network(5)
    send, update = gates(net)
    indptr, indices, _ = net.csr
    alive = np.asarray(net["ca__alive"])
    for _ in range(60):
        new = regroup_step(net, alive, send, update, "one_sided")
        for i in range(net.n_cells):           # per-cell reference of Table 1's row
            nb = indices[indptr[i]:indptr[i + 1]]
            k, kp = send[nb].sum(), (send[nb] & alive[nb]).sum()
            dies = update[i] and alive[i] and kp < k / 2
            assert new[i] == (alive[i] and not dies)
        assert not np.any(new & ~alive)        # nothing is ever born
        if np.array_equal(new, alive):
            break
        alive = new
    else:
        pytest.fail("one-sided regrouping did not reach a fixed point")
    assert 0 < alive.sum() < np.asarray(net["ca__alive"]).sum()
    born = regroup_step(net, np.asarray(net["ca__alive"]), send, update, "majority")
    assert np.any(born & ~np.asarray(net["ca__alive"]))   # the two-sided vote also gives births


def test_overlapping_writers_are_refused():
    with pytest.raises((RecipeError, ValueError), match="material 2 runs both"):
        ParallelBehaviours.from_params({"behaviours": {"life": [2], "regroup": [2, 3]}}, "t", None)
    with pytest.raises((RecipeError, ValueError), match="material 1 runs both"):
        ParallelBehaviours.from_params({"behaviours": {"diffuse": [1], "watercolor": [1]}}, "t", None)
    with pytest.raises((RecipeError, ValueError), match="unknown"):
        ParallelBehaviours.from_params({"behaviours": {"boil": [1]}}, "t", None)
    with pytest.raises((RecipeError, ValueError), match="settings.corrode: parameter 'dp'"):
        ParallelBehaviours.from_params({"behaviours": {"corrode": [1]},
                                        "settings": {"corrode": {"dp": -1.0}}}, "t", None)
    # the crack may share cells with any behaviour: it writes only the cells it marks
    ParallelBehaviours.from_params({"behaviours": {"diffuse": [1], "crack": [1]}}, "t", None)


def test_a_behaviour_stops_after_its_steps_and_the_rest_go_on():
    net = network(6)
    state = State(seed=1)
    state.add_domain("cells", net)
    rule = ParallelBehaviours.from_params({"behaviours": {"diffuse": [0], "watercolor": [7]},
                                           "settings": {"watercolor": {"dp": 0.05}},
                                           "steps": {"diffuse": 2}}, "t")
    rule.setup(state)
    frozen = None
    for t in range(6):
        assert rule.step(state)
        net = state.get("cells", CellNetwork)
        if t == 1:
            frozen = np.asarray(net["surface__color"]).copy()
            water = np.asarray(net["water__volume"]).copy()
    assert np.array_equal(np.asarray(net["surface__color"]), frozen)     # diffusion stopped
    assert not np.array_equal(np.asarray(net["water__volume"]), water)  # the water still flows
