"""Several behaviours in one synchronous step (seed 002 Figure 1) and one-sided regrouping (Table 1)."""
from __future__ import annotations

import numpy as np
import pytest

from procgen import RecipeError
from procgen.ca.lifelike import life_step, parse_rule
from _cellnet import permuted
from procgen_cellnet.boxes import pairs_kdtree
from procgen_cellnet.colour import spread
from procgen_cellnet.melting import melt_step
from procgen_cellnet.network import CellNetwork
from procgen_cellnet.parallel import ParallelBehaviours, life_step_gated, parallel_step, regroup_step
from procgen_cellnet.seeding import link_radius, seed_cells
from procgen_cellnet.states import ACTIVE, INFLUENCING, RECEIVING, SLEEPING, receives, sends

MIX = {"diffuse": [0, 1], "melt": [1], "life": [2], "regroup": [3], "majority": [0]}


def network(seed=0, n=18.0):
    v = np.array([[0, 0, 0], [n, 0, 0], [n, n, 0], [0, n, 0]], float)
    s = seed_cells(v, np.array([[0, 1, 2], [0, 2, 3]]), "square8", 1.0)
    rng = np.random.default_rng(seed)
    p = s.positions + np.column_stack([np.zeros((len(s.positions), 2)),
                                       0.2 * rng.random(len(s.positions))])
    r = link_radius("square8", 1.0, 0.01)
    net = CellNetwork(p, pairs_kdtree(p, r), cs=1.0, grid="square8", radius=r)
    net.add_field("cell__normal", s.normals, at="cell")
    quad = (p[:, 0] > n / 2).astype(np.int16) + 2 * (p[:, 1] > n / 2)
    net.add_field("cell__material", quad, at="cell")
    gs = rng.choice([SLEEPING, RECEIVING, INFLUENCING, ACTIVE], net.n_cells,
                    p=[0.05, 0.1, 0.1, 0.75]).astype(np.int8)
    net.add_field("cell__state", gs, at="cell")
    color = rng.random((net.n_cells, 3)).astype(np.float32)
    net.add_field("surface__color", color, at="cell")
    net.add_field("cell__colored", rng.random(net.n_cells) < 0.6, at="cell")
    net.add_field("ca__alive", rng.random(net.n_cells) < 0.5, at="cell")
    return net


def gates(net):
    gs = np.asarray(net["cell__state"])
    return sends(gs), receives(gs)


def test_one_step_equals_each_behaviour_alone_from_the_same_old_state():
    net = network()
    send, update = gates(net)
    out, changed = parallel_step(net, MIX, send, update, rule="B3/S23")
    assert changed
    mat = np.asarray(net["cell__material"])
    own = {b: update & np.isin(mat, m) for b, m in MIX.items()}
    alive, color, colored = (np.asarray(net[f]) for f in ("ca__alive", "surface__color", "cell__colored"))
    # each behaviour run alone on its own cells, from the same time-t network
    c, k = spread(net, color, colored, send, own["diffuse"])
    assert np.array_equal(out["surface__color"], c) and np.array_equal(out["cell__colored"], k)
    pos, nrm = melt_step(net, send, own["melt"])
    assert np.array_equal(out.positions, pos) and np.array_equal(out["cell__normal"], nrm)
    want = alive.copy()
    for b, nxt in (("life", life_step_gated(net, alive, send, own["life"], "B3/S23")),
                   ("regroup", regroup_step(net, alive, send, own["regroup"], "one_sided")),
                   ("majority", regroup_step(net, alive, send, own["majority"], "majority"))):
        assert not np.array_equal(nxt[own[b]], alive[own[b]])      # each one does something
        want[own[b]] = nxt[own[b]]
    assert np.array_equal(out["ca__alive"], want)
    # cells that run none of the state behaviours (material 1, non-receiving) keep their state
    idle = ~(own["life"] | own["regroup"] | own["majority"])
    assert np.array_equal(out["ca__alive"][idle], alive[idle])
    # running them one after another is not the same: regroup would read Life's new cells
    after_life = np.where(own["life"], want, alive)
    seq = regroup_step(net, after_life, send, own["regroup"], "one_sided")
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
    a, _ = parallel_step(net, MIX, *gates(net))
    b, _ = parallel_step(pnet, MIX, *gates(pnet))
    assert np.allclose(a.positions[perm], b.positions)
    for name in ("surface__color", "cell__normal"):
        assert np.allclose(np.asarray(a[name])[perm], b[name], atol=1e-6)
    for name in ("ca__alive", "cell__colored"):
        assert np.array_equal(np.asarray(a[name])[perm], b[name])


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
    with pytest.raises((RecipeError, ValueError), match="unknown"):
        ParallelBehaviours.from_params({"behaviours": {"boil": [1]}}, "t", None)
