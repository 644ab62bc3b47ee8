"""Connected components and hop distances over a CellGraph, against independent references."""
from collections import deque

import numpy as np
import pytest
from scipy import ndimage

from procgen import InputError
from procgen.ca.components import connected_components, hop_distance
from procgen.ca.graph import CellGraph, grid_graph


def _same_partition(a: np.ndarray, b: np.ndarray) -> bool:
    """Two labellings (-1 = no region) describe the same partition of the cells."""
    if not np.array_equal(a < 0, b < 0):
        return False
    pairs = np.unique(np.stack([a[a >= 0], b[b >= 0]]), axis=1)
    return len(np.unique(pairs[0])) == pairs.shape[1] == len(np.unique(pairs[1]))


def _brute_components(n, edges, mask):
    """Plain BFS flood fill on an undirected edge list."""
    adj = [[] for _ in range(n)]
    for u, v in edges:
        if mask[u] and mask[v]:
            adj[u].append(v)
            adj[v].append(u)
    lab = [-1] * n
    k = 0
    for s in range(n):
        if mask[s] and lab[s] < 0:
            lab[s] = k
            q = deque([s])
            while q:
                u = q.popleft()
                for v in adj[u]:
                    if lab[v] < 0:
                        lab[v] = k
                        q.append(v)
            k += 1
    return np.array(lab), k


def _random_graph(rng, n, m):
    """A CSR graph from m random directed links (some one-way, as cross-edge links may be)."""
    r, c = rng.integers(0, n, m), rng.integers(0, n, m)
    order = np.argsort(r, kind="stable")
    indptr = np.concatenate([[0], np.cumsum(np.bincount(r, minlength=n))])
    return CellGraph(indptr.astype(np.int64), c[order].astype(np.int64)), list(zip(r[order], c[order]))


@pytest.mark.parametrize("neigh,structure", [("moore", np.ones((3, 3))),
                                              ("von_neumann", ndimage.generate_binary_structure(2, 1))])
def test_components_match_ndimage_label(neigh, structure):
    rng = np.random.default_rng(3)
    img = rng.random((40, 55)) < 0.55
    g = grid_graph(40, 55).neighbourhood(neigh)
    lab, n = connected_components(g, img.ravel())
    ref, nref = ndimage.label(img, structure=structure)
    assert n == nref
    assert _same_partition(lab, ref.ravel() - 1)
    # numbered by smallest cell: the first cell of region k comes before that of region k+1
    first = np.array([np.nonzero(lab == k)[0][0] for k in range(n)])
    assert np.all(np.diff(first) > 0)


def test_components_match_brute_force_on_random_graphs():
    rng = np.random.default_rng(11)
    for _ in range(20):
        n = int(rng.integers(5, 60))
        g, edges = _random_graph(rng, n, int(rng.integers(0, 2 * n)))
        mask = rng.random(n) < 0.8
        lab, k = connected_components(g, mask)
        ref, kref = _brute_components(n, edges, mask)
        assert k == kref
        assert np.array_equal(lab, ref)          # both number regions by their smallest cell


def test_link_mask_splits_a_region():
    g = grid_graph(6, 10).neighbourhood("von_neumann")
    col = np.arange(60) % 10
    # drop every link between columns 4 and 5: two regions, though no cell is masked out
    keep = ~(((col[g.rows] == 4) & (col[g.indices] == 5)) | ((col[g.rows] == 5) & (col[g.indices] == 4)))
    lab, n = connected_components(g, keep=keep)
    assert n == 2
    assert np.array_equal(lab, (col >= 5).astype(int))
    assert connected_components(g)[1] == 1


@pytest.mark.parametrize("neigh,metric", [("moore", "chessboard"), ("von_neumann", "taxicab")])
def test_hop_distance_is_the_grid_distance_transform(neigh, metric):
    rng = np.random.default_rng(5)
    seeds = rng.random((30, 45)) < 0.01
    seeds[0, 0] = True
    g = grid_graph(30, 45).neighbourhood(neigh)
    d = hop_distance(g, seeds.ravel())
    ref = ndimage.distance_transform_cdt(~seeds, metric=metric)
    assert np.array_equal(d, ref.ravel())


def test_hop_distance_respects_walls_and_unreachable_cells():
    rng = np.random.default_rng(8)
    for _ in range(15):
        n = int(rng.integers(5, 50))
        g, edges = _random_graph(rng, n, 2 * n)
        mask = rng.random(n) < 0.7
        src = rng.choice(n, 2, replace=False)
        d = hop_distance(g, src, mask)
        # brute force BFS through masked cells (sources count as masked)
        ok = mask.copy()
        ok[src] = True
        adj = [[] for _ in range(n)]
        for u, v in edges:
            if ok[u] and ok[v]:
                adj[u].append(v)
                adj[v].append(u)
        ref = [-1] * n
        q = deque()
        for s in src:
            ref[s] = 0
            q.append(s)
        while q:
            u = q.popleft()
            for v in adj[u]:
                if ref[v] < 0:
                    ref[v] = ref[u] + 1
                    q.append(v)
        assert np.array_equal(d, ref)


def test_no_sources_and_bad_shapes():
    g = grid_graph(3, 3)
    assert np.all(hop_distance(g, np.zeros(9, bool)) == -1)
    with pytest.raises(InputError, match="cell mask"):
        connected_components(g, np.ones(4, bool))
    with pytest.raises(InputError, match="link mask"):
        connected_components(g, keep=np.ones(3, bool))
    with pytest.raises(InputError, match="out of range"):
        hop_distance(g, [9])
