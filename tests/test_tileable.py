"""Tileable (periodic, torus) grids (issue 35, item 4): what is made on them tiles.

The seam test: on a torus the wrap seam (last column -> first, last row -> first) is one more
line between neighbouring cells, so the height differences across it must be distributed like
those across the interior lines; a 2 x 2 tiling of the exported 16-bit height map must show no
line whose statistic stands out.  The non-periodic grid made the same way is the control: its
seam is an outlier by a wide margin, so the statistic can see a seam when there is one.
"""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
from PIL import Image
from scipy.stats import ks_2samp

from procgen import Grid, load_recipe, run
from procgen.runner import provenance, render_output

import procgen_water.particles as P
from procgen_layers.materials import parse_materials

ROUGH_TERRAIN = """
[recipe]
name = "tile-test"
seed = 3

[[steps]]
rule = "water.surface"
params = {{ nx = 64, ny = 48, base = "fbm", base_amplitude = 20.0, base_hurst = 0.8, base_smoothness = 1.5, periodic = {periodic}, layers = [
  {{ preset = "rock", thickness = 10.0, erosion_rate = 0.06, roughness = 0.02 }},
  {{ preset = "soil", thickness = 1.0, noise = 0.3, hurst = 0.6, erosion_rate = 0.15, absorption_rate = 0.0, capacity = 0.0, weakness_threshold = 0.0, roughness = 0.03, spots = [[0.02, 0.5, 0.2]] }},
] }}

[[steps]]
rule = "water.drops"
iterations = 30
params = {{ drops = 0, rain = 300, emission = "uniform", sediment_capacity = 2.0, min_slope = 0.05, deposition_rate = 0.05, max_age = 40, capacity_fade = true, footprint = "disc", brush_radius = 2.0, friction = 0.2, evaporation = 0.0 }}

[[outputs]]
domain = "terrain"
format = "heightmap_png16"
file = "height.png"

[[outputs]]
domain = "terrain"
format = "terrain_maps"
file = "terrain.png"
"""


def line_diffs(h: np.ndarray, axis: int) -> np.ndarray:
    """Differences across every line between neighbouring columns (axis 1) or rows (axis 0),
    the wrap seam last: shape (lines, cells along a line)."""
    d = np.roll(h, -1, axis=axis) - h
    return d.T if axis == 1 else d


def seam_z(stats: np.ndarray, seam: int) -> float:
    """Robust z-score of one line's statistic among all the others (median / MAD)."""
    rest = np.delete(stats, seam)
    mad = 1.4826 * np.median(np.abs(rest - np.median(rest)))
    return float((stats[seam] - np.median(rest)) / mad)


def seam_report(h: np.ndarray) -> dict[str, float]:
    """For both axes, robust z-scores of the seam among all lines of: the mean |difference|
    across the line (``z``) and the Kolmogorov-Smirnov distance between the line's differences
    and the interior lines' pooled (``ks``: is the seam's distribution the interior's?).  The
    differences along one line of fBm are correlated, so a KS p-value would be meaningless;
    the seam is ranked against the interior lines, which share that correlation."""
    out = {}
    for axis, name in ((1, "x"), (0, "y")):
        d = line_diffs(h, axis)
        pooled = d[:-1].ravel()
        ks = np.array([ks_2samp(line, pooled).statistic for line in d])   # one per line, ~100
        out[f"ks_{name}"] = seam_z(ks, len(d) - 1)
        out[f"z_{name}"] = seam_z(np.abs(d).mean(axis=1), len(d) - 1)
    return out


def run_recipe(text: str, host, tmp_path: Path, name: str):
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    recipe = load_recipe(path, host)
    res = run(recipe, host, progress=False)
    return recipe, res


# ---------------------------------------------------------------------------------------------


def test_periodic_grid_graph_wraps_and_survives_save():
    g = Grid((5, 7), periodic=True)
    moore, vn = g.cell_graph("moore"), g.cell_graph("von_neumann")
    assert np.all(np.diff(moore.indptr) == 8) and np.all(np.diff(vn.indptr) == 4)
    corner = set(moore.indices[moore.indptr[0]:moore.indptr[1]].tolist())
    assert corner == {1, 6, 7, 8, 13, 28, 29, 34}         # (0,0) touches the far column and row
    flat = Grid((5, 7)).cell_graph("moore")
    assert np.diff(flat.indptr)[0] == 3                         # the default stays bounded
    assert Grid.from_topology({}, g.topology_meta()).periodic
    assert "periodic" not in Grid((5, 7)).topology_meta()      # saved bounded grids do not change


@pytest.mark.parametrize("periodic", [True, False])
def test_fbm_seam_is_an_interior_line_only_when_periodic(host, tmp_path, periodic):
    text = f"""
[recipe]
name = "noise"
seed = 11
[[steps]]
rule = "grid.noise"
params = {{ nx = 128, ny = 96, hurst = 0.8, periodic = {str(periodic).lower()} }}
"""
    _, res = run_recipe(text, host, tmp_path, "noise")
    g = res.state.get("terrain", Grid)
    assert g.periodic is periodic
    rep = seam_report(np.asarray(g["surface__height"]))
    if periodic:
        assert max(abs(v) for v in rep.values()) < 4.0, rep
    else:                         # the control: a cut from a larger canvas has a visible seam
        assert min(rep.values()) > 5.0, rep


def test_periodic_grid_noise_refuses_what_does_not_tile(host, tmp_path):
    from procgen import RecipeError
    for bad in ('method = "midpoint", periodic = true', 'dome = 2.0, periodic = true'):
        path = tmp_path / "bad.toml"
        path.write_text(f'[recipe]\nname = "b"\n[[steps]]\nrule = "grid.noise"\nparams = {{ nx = 8, ny = 8, {bad} }}\n')
        with pytest.raises(RecipeError, match="tile"):
            load_recipe(path, host)


def test_drop_leaving_an_edge_reenters_opposite_and_nothing_drains():
    """One drop pushed over the left edge of a torus comes back at the right one, with its water."""
    table = parse_materials([{"preset": "rock", "absorption_rate": 0.0, "erosion_rate": 0.0, "roughness": 0.0}])
    ny, nx = 6, 10
    s = P.make_surface(np.zeros((ny, nx)), np.ones((ny, nx, 1)), table)
    s.periodic = True
    d = P.Drops(np.array([[0.2, 3.5]]), np.array([[-0.7, 0.0]]), np.array([1.0]), np.zeros(1),
                np.full(1, -1, np.int64), np.ones(1, bool), np.zeros(1, np.int64))

    class Params:
        gravity, friction, adhesion, contact_angle, max_speed = 1.0, 0.0, 0.0, 60.0, 1.0
        stable_speed, max_age, speed_ref, evaporation = 0.0, 0, 0.5, 0.0
        sediment_capacity, min_slope, deposition_rate, max_concentration = None, 0.01, 0.3, 1.0
        footprint, brush_radius, erode_stabilised, capacity_fade = "disc", 2.0, False, False

    out = P.step(s, d, Params(), accelerate=True)        # a torus always takes the numpy path
    assert len(out) == 1 and out.volume[0] == 1.0 and s.drained.sum() == 0.0
    assert out.pos[0, 0] == pytest.approx(nx + 0.2 - 0.7) and out.pos[0, 1] == pytest.approx(3.5)
    # the gradient across the seam: a ramp that wraps has the interior slope at the edge too
    s.base[:] = np.tile(np.sin(2 * np.pi * (np.arange(nx) + 0.5) / nx), ny)
    gx, _ = P.surface_gradient(s)
    want = (np.roll(s.base.reshape(ny, nx), -1, 1) - np.roll(s.base.reshape(ny, nx), 1, 1)) / 2
    np.testing.assert_allclose(gx, want)
    assert gx[0, 0] > 0 and gx[0, -1] > 0                   # both edges see the rising sine


def test_eroded_periodic_terrain_tiles_and_its_export_shows_no_seam(host, tmp_path):
    recipe, res = run_recipe(ROUGH_TERRAIN.format(periodic="true"), host, tmp_path, "tile")
    g = res.state.get("terrain", Grid)
    assert g.periodic
    assert float(np.asarray(g["water__drained"]).sum()) == 0.0        # nothing leaves a torus
    assert float(np.asarray(g["water__path"]).sum()) > 0
    h = np.asarray(g["surface__height"])
    rep = seam_report(h)
    assert max(abs(v) for v in rep.values()) < 4.0, rep
    # the spot centred on the left edge continues on the right one (solid laid down at the
    # start, per cell: rock 10 everywhere plus the soil where the spot is)
    laid = np.asarray(g["sediment__baseline"])
    assert laid[24, 0] > 10.5 and laid[24, -1] > 10.5 and laid[24, 32] == pytest.approx(10.0)
    # the exported 16-bit height map, tiled 2 x 2: the seams between the copies are ordinary lines
    prov = provenance(recipe, recipe.seed, host)
    files = render_output(res.state, recipe.outputs[0], host, prov)
    img = np.asarray(Image.open(io.BytesIO(files["height.png"])), dtype=np.float64)
    assert img.shape == h.shape
    tiled = np.tile(img, (2, 2))
    for axis, n in ((1, h.shape[1]), (0, h.shape[0])):
        stats = np.abs(np.diff(tiled, axis=axis)).mean(axis=1 - axis)
        for seam in (n - 1,):                              # between the copies
            assert abs(seam_z(stats, seam)) < 4.0, (axis, seam_z(stats, seam))
    # the normal map wraps too: its seam column matches the interior
    nrm = np.asarray(Image.open(io.BytesIO(render_output(res.state, recipe.outputs[1], host, prov)
                                           ["terrain_normal.png"])), dtype=np.float64)[..., 0]
    stats = np.abs(np.diff(np.tile(nrm, (1, 2)), axis=1)).mean(axis=0)
    assert abs(seam_z(stats, h.shape[1] - 1)) < 4.0


def test_bounded_terrain_keeps_its_seam_and_drains(host, tmp_path):
    """The control for the test above: the same recipe without ``periodic`` drains at the edges
    and its wrap seam is an outlier."""
    _, res = run_recipe(ROUGH_TERRAIN.format(periodic="false"), host, tmp_path, "flat")
    g = res.state.get("terrain", Grid)
    assert not g.periodic
    assert float(np.asarray(g["water__drained"]).sum()) > 0
    rep = seam_report(np.asarray(g["surface__height"]))
    assert min(rep.values()) > 5.0, rep


def test_periodic_surface_refuses_a_tilt_or_a_mountain(host, tmp_path):
    from procgen import RecipeError
    for bad in ('base = "mountain", base_amplitude = 5.0', 'base = "fbm", tilt_deg = 10.0'):
        path = tmp_path / "bad.toml"
        path.write_text(f'[recipe]\nname = "b"\n[[steps]]\nrule = "water.surface"\n'
                        f'params = {{ nx = 8, ny = 8, periodic = true, {bad} }}\n')
        with pytest.raises(RecipeError, match="tile"):
            load_recipe(path, host)


@pytest.mark.parametrize("periodic", [True, False])
def test_weak_map_regrouping_wraps_on_a_torus(periodic):
    """The corrosion weak/strong map (plate D-1's regrouped random map) tiles on a periodic grid."""
    from procgen_water.weak_map import weakness_score
    score = weakness_score((96, 128), np.random.default_rng(1), regroup="cubic", radius=8.0, periodic=periodic)
    rep = seam_report(score)
    if periodic:
        assert max(abs(v) for v in rep.values()) < 4.0, rep
    else:
        assert min(rep.values()) > 5.0, rep


def test_a_surface_laid_on_a_periodic_grid_is_periodic(host, tmp_path):
    """water.surface on grid.noise's torus keeps the torus (its drops wrap, its maps tile)."""
    text = """
[recipe]
name = "chain"
seed = 2
[[steps]]
rule = "grid.noise"
params = { nx = 40, ny = 32, periodic = true, amplitude = 3.0 }
[[steps]]
rule = "water.surface"
params = { base = "grid", layers = [ { preset = "stone", thickness = 1.0, noise = 0.2 } ] }
[[steps]]
rule = "water.drops"
iterations = 5
params = { drops = 200 }
"""
    _, res = run_recipe(text, host, tmp_path, "chain")
    g = res.state.get("terrain", Grid)
    assert g.periodic and float(np.asarray(g["water__drained"]).sum()) == 0.0
    assert max(abs(v) for v in seam_report(np.asarray(g["surface__height"])).values()) < 4.0


def test_a_torus_on_heights_that_do_not_wrap_is_refused_at_check(host):
    from procgen.errors import RecipeError
    from procgen.recipes import check_recipe

    steps = [{"rule": "grid.noise", "params": {"grid": "g", "nx": 16, "ny": 16}},
             {"rule": "water.surface", "params": {"base": "grid", "base_grid": "g", "periodic": True}}]
    with pytest.raises(RecipeError, match=r"steps\[1\] \(water.surface\): periodic = true needs a tileable Grid 'g'"):
        check_recipe({"steps": steps}, host, "r.toml")
    steps[0]["params"]["periodic"] = True
    check_recipe({"steps": steps}, host, "r.toml")


def test_heightfield_lighting_wraps_on_a_torus():
    """Normals (and so ``layers.shade``'s lighting and the terrain normal map) on a periodic grid
    commute with a shift round the torus, seam columns included; the bounded control does not."""
    from procgen.lighting import heightfield_normals
    h = np.random.default_rng(5).standard_normal((12, 17))
    shift = (5, 9)
    rolled = heightfield_normals(np.roll(h, shift, axis=(0, 1)), 0.5, periodic=True)
    assert np.allclose(rolled, np.roll(heightfield_normals(h, 0.5, periodic=True), shift, axis=(0, 1)))
    bounded = heightfield_normals(np.roll(h, shift, axis=(0, 1)), 0.5)
    assert not np.allclose(bounded, np.roll(heightfield_normals(h, 0.5), shift, axis=(0, 1)))
