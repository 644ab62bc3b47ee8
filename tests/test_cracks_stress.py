"""Stress spectrum, relaxation and sub-cell interpolation (3DSCA thesis 5.2.3; digest 16.6.1-3)."""
from __future__ import annotations

import numpy as np
import pytest

from procgen.ca.graph import grid_graph
from procgen.ca.subcell import (AXIS_ANGLES, across_share, bilinear_stencil, dominant_axis,
                                interpolate, slot_table)
from procgen_cracks.stress import (FaceSampler, coplanar_slots, imposed_spectrum, relax,
                                   thickness_spectrum)
from procgen_surface.domain import SurfaceCells


@pytest.fixture(scope="module")
def tetra_cells() -> SurfaceCells:
    v = np.array([[1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1]], float)
    f = np.array([[0, 1, 2], [0, 3, 1], [0, 2, 3], [1, 3, 2]])
    return SurfaceCells.from_mesh(v, f, target_cells=3000)


def _field(n: int, seed: int = 3) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.gamma(1.5, size=(n, 4)) * (rng.uniform(size=(n, 1)) < 0.7)


@pytest.mark.parametrize("share,loops", [(0.3, 1), (0.5, 15), (1.0, 7), (0.05, 25)])
def test_relaxation_conserves_each_axis_and_never_raises_the_max(tetra_cells, share, loops):
    g = tetra_cells.cell_graph("moore")
    spec = _field(tetra_cells.n_cells)
    out = relax(spec, g.rows, g.indices, share, loops)
    np.testing.assert_allclose(out.sum(axis=0), spec.sum(axis=0), rtol=1e-12)
    assert np.all(out.max(axis=0) <= spec.max(axis=0) + 1e-12)
    assert np.all(out.min(axis=0) >= spec.min(axis=0) - 1e-12)
    # and it smooths: the squared differences across links fall
    energy = lambda a: float(np.sum((a[g.rows] - a[g.indices]) ** 2))  # noqa: E731
    assert energy(out) < energy(spec)


def test_relaxation_with_one_loop_moves_the_printed_sigma():
    """One cell above two weaker neighbours on a 1x3 strip: C gives eP x (I_C - mean of the
    weaker) in total (the thesis's sigma), split by deficit."""
    g = grid_graph(1, 3, False)
    spec = np.zeros((3, 4))
    spec[:, 0] = [1.0, 4.0, 2.0]
    out = relax(spec, g.rows, g.indices, 0.2, 1)
    sigma = 0.2 * (4.0 - (1.0 + 2.0) / 2)
    # only the centre is above a neighbour; the outer cells are not neighbours of each other
    assert out[1, 0] == pytest.approx(4.0 - sigma)
    assert out[0, 0] - 1.0 == pytest.approx(0.2 * 3.0 / 2)
    assert out[2, 0] - 2.0 == pytest.approx(0.2 * 2.0 / 2)


@pytest.mark.parametrize("share,loops", [(0.0, 10), (0.4, 0)])
def test_relaxation_off_changes_nothing(tetra_cells, share, loops):
    g = tetra_cells.cell_graph("moore")
    spec = _field(tetra_cells.n_cells)
    assert np.array_equal(relax(spec, g.rows, g.indices, share, loops), spec)


def test_thickness_slope_gives_the_axis_components():
    """h = a x on a flat grid: slope a along axis 0, a / sqrt 2 along the diagonals, 0 along y."""
    ny, nx, s, a = 6, 7, 0.5, 0.3
    g = grid_graph(ny, nx, False)
    x = np.tile(np.arange(nx) * s, ny)
    spec = thickness_spectrum(a * x, slot_table(g), s, gradient=1.0, curvature=0.0)
    inner = np.zeros((ny, nx), bool)
    inner[1:-1, 1:-1] = True
    got = spec[inner.ravel()]
    np.testing.assert_allclose(got[:, 0], a)
    np.testing.assert_allclose(got[:, 1], a / np.sqrt(2))
    np.testing.assert_allclose(got[:, 3], a / np.sqrt(2))
    np.testing.assert_allclose(got[:, 2], 0.0, atol=1e-12)


def test_coplanar_edges_are_zeroed_and_folded_ones_are_not():
    """A square of two coplanar triangles, and the same square folded along its diagonal."""
    for fold, coplanar in ((0.0, True), (0.6, False)):
        v = np.array([[0, 0, 0], [1, 0, 0], [1, 1, fold], [0, 1, 0]], float)
        sc = SurfaceCells.from_mesh(v, np.array([[0, 1, 2], [0, 2, 3]]), target_cells=800)
        g = sc.cell_graph("moore")
        slots = slot_table(g)
        crossed = np.zeros_like(slots, bool)
        crossed[g.rows, g.direction.astype(np.int64)] = g.cross
        fn = np.cross(v[[1, 2]] - v[0], v[[2, 3]] - v[0])
        fn /= np.linalg.norm(fn, axis=1, keepdims=True)
        blocked = coplanar_slots(slots, crossed, np.asarray(sc.face), fn)
        assert blocked.any() == coplanar
        assert not (blocked & ~crossed).any()
        # a thickness jump across the diagonal shows up only where not blocked
        h = np.where(np.asarray(sc.face) == 0, 1.0, 2.0)
        spec = thickness_spectrum(h, slots, sc.size, gradient=1.0, curvature=0.0, blocked=blocked)
        across = crossed.any(axis=1)
        assert (spec[across].max() == 0.0) == coplanar


def test_imposed_field_is_the_percentages():
    spec = imposed_spectrum(5, [10, 0, 90, 0])
    np.testing.assert_allclose(spec, np.tile([0.1, 0.0, 0.9, 0.0], (5, 1)))
    axis, _ = dominant_axis(spec)
    np.testing.assert_allclose(axis, np.pi / 2)


def test_interpolation_is_the_cell_itself_at_its_centre(tetra_cells):
    spec = _field(tetra_cells.n_cells)
    sampler = FaceSampler(tetra_cells.layout)
    got = sampler.sample(spec, np.asarray(tetra_cells.face), np.asarray(tetra_cells.center2d))
    np.testing.assert_allclose(got, spec, atol=1e-12)


def test_interpolation_weights_of_figure_5_9():
    """40 % of the way across horizontally and 20 % vertically: the nearest cell weighs 0.48."""
    s = 2.0
    _, w = bilinear_stencil(np.array([[(0.5 + 0.4) * s, (0.5 + 0.2) * s]]), s)
    np.testing.assert_allclose(w[0], [0.6 * 0.8, 0.4 * 0.8, 0.6 * 0.2, 0.4 * 0.2])
    vals = np.array([[1.0], [2.0], [3.0], [4.0]])
    got = interpolate(vals, np.array([[0, 1, 2, 3]]), w)
    assert got[0, 0] == pytest.approx(0.48 * 1 + 0.32 * 2 + 0.12 * 3 + 0.08 * 4)
    # a missing cell drops out and the rest is renormalised
    got = interpolate(vals, np.array([[0, -1, 2, 3]]), w)
    assert got[0, 0] == pytest.approx((0.48 * 1 + 0.12 * 3 + 0.08 * 4) / 0.68)


def test_across_share_is_one_across_and_zero_along():
    share = across_share(np.array([0.0, np.pi / 2]))
    np.testing.assert_allclose(share[0], np.abs(np.sin(AXIS_ANGLES)), atol=1e-12)
    np.testing.assert_allclose(share[1], [1.0, np.sqrt(0.5), 0.0, np.sqrt(0.5)], atol=1e-12)
