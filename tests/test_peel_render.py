"""The partial-peeling elevation peel__lift (thesis Figure 5.30) drawn in the crack textures."""
from __future__ import annotations

import numpy as np
import pytest

from procgen import InputError
from procgen_cracks.exporters import texel_colors
from procgen_layers.materials import parse_materials
from procgen_layers.stack import put_thickness, store_table
from procgen_surface.domain import SurfaceCells


def flat_cells(size: float = 0.05, k: int = 2) -> SurfaceCells:
    """A flat unit square (z = 0) of cells: copper under a grey paint, no crack coverage."""
    v = np.array([[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0]], float)
    sc = SurfaceCells.from_mesh(v, np.array([[0, 1, 2], [0, 2, 3]]), cell_size=size)
    table = parse_materials([{"name": "copper", "color": [0.8, 0.45, 0.2], "opacity": 0.99},
                             {"name": "paint", "color": [0.5, 0.5, 0.5], "opacity": 0.99}])
    store_table(sc, table)
    put_thickness(sc, np.tile([1.0, 0.5], (sc.n_cells, 1)), table)
    sc.add_field("crack__coverage", np.zeros((sc.n_cells, k, k), np.float32), at="cell", units="1")
    return sc


def brightness(sc: SurfaceCells, **kw) -> np.ndarray:
    return texel_colors(sc, **kw).mean(axis=(1, 2, 3))


def test_lift_zero_changes_nothing():
    sc = flat_cells()
    before = texel_colors(sc)
    sc.add_field("peel__lift", np.zeros(sc.n_cells), at="cell", units="length")
    assert np.array_equal(texel_colors(sc, light=(1.0, 0.0, 1.0), lift_relief=5.0), before)


def test_a_lifted_ramp_is_lit_on_the_light_side_with_a_dark_rim_beside_it():
    sc = flat_cells()
    x = sc.center3d[:, 0]
    flat_before = brightness(sc)
    # a flake curling up towards x = 0.25 (its crack edge), flat beyond; no paint lifted at x < 0
    lift = np.where((x > 0) & (x < 0.25), 0.2 * x, 0.0)
    sc.add_field("peel__lift", lift, at="cell", units="length")
    towards = brightness(sc, light=(-1.0, 0.0, 1.0))     # the slope (normal tilted to -x) faces it
    away = brightness(sc, light=(1.0, 0.0, 1.0))
    ramp = (x > 0.06) & (x < 0.19)                          # inner cells: both neighbours lifted
    assert ramp.sum() > 20
    assert np.all(towards[ramp] > flat_before[ramp] + 1e-3)
    assert np.all(away[ramp] < flat_before[ramp] - 1e-3)
    rim = (lift == 0) & (np.abs(x - 0.25) < 0.05)          # flat cells beside the raised edge
    far = (lift == 0) & (np.abs(x - 0.25) > 0.2) & (x < -0.15)
    assert rim.sum() > 5 and far.sum() > 5
    assert np.all(towards[rim] < flat_before[rim] - 1e-3)
    assert np.array_equal(towards[far], flat_before[far])   # the effect stays local
    # relief 0 and rim 0: lifted or not, the texture is the unlifted one
    assert np.array_equal(texel_colors(sc, lift_relief=0.0, lift_rim=0.0), texel_colors(flat_cells()))


def test_a_uniform_lift_is_a_flat_plateau_with_a_rim_only_around_it():
    sc = flat_cells()
    x, y = sc.center3d[:, 0], sc.center3d[:, 1]
    before = brightness(sc)
    plateau = (np.abs(x) < 0.2) & (np.abs(y) < 0.2)
    sc.add_field("peel__lift", np.where(plateau, 0.03, 0.0), at="cell", units="length")
    after = brightness(sc)
    np.testing.assert_allclose(after[plateau], before[plateau], rtol=0, atol=1e-12)
    # the ring of flat cells sharing a side with the plateau (not its diagonal corners) darkens
    g = sc.cell_graph("von_neumann")
    side = ~plateau & (np.bincount(g.rows, plateau[g.indices], minlength=sc.n_cells) > 0)
    assert side.sum() > 20
    assert np.all(after[side] < before[side] - 1e-3)
    outside = ~plateau & ~side
    assert np.array_equal(after[outside], before[outside])

def test_bad_lift_options_are_one_line_errors():
    sc = flat_cells()
    sc.add_field("peel__lift", np.full(sc.n_cells, 0.01), at="cell", units="length")
    for kw in ({"light": (0.0, 0.0, 0.0)}, {"lift_relief": -1.0}, {"lift_rim": 2.0}):
        with pytest.raises(InputError, match="crack export"):
            texel_colors(sc, **kw)
