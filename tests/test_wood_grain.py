"""Wood grain (thesis 3.1, Figs 3.1-3.11) and texgen (4.3.4): reference values and invariants."""
from __future__ import annotations

import numpy as np
import pytest
from scipy import ndimage

from procgen_wood.grain import hash_noise, smooth_noise, turbulence, wood_texture
from procgen_wood.texgen import sample_bilinear, texture_coordinates


@pytest.mark.parametrize("xy, value", [((0, 0), -0.281790984), ((1, 0), -0.226373051),
                                       ((0, 1), 0.204343985), ((10, 20), -0.638634722),
                                       ((-3, 5), 0.625854307)])
def test_noise_reference_values_of_the_corrected_hash(xy, value):
    assert hash_noise(np.array(xy[0]), np.array(xy[1])) == pytest.approx(value, abs=1e-9)


def test_printed_hash_is_kept_and_leaves_the_stated_range():
    assert hash_noise(np.array(1), np.array(0), "printed") == pytest.approx(-1.731355046, abs=1e-9)


def test_smooth_noise_reference_and_lattice_identity():
    assert smooth_noise(np.array(0), np.array(0)) == pytest.approx(0.007429826, abs=1e-9)
    x, y = np.meshgrid(np.arange(-40, 40), np.arange(-20, 20))
    assert np.array_equal(hash_noise(x + 57, y), hash_noise(x, y + 1))    # n = x + 57 y


def test_noise_statistics_on_a_512_window():
    y, x = np.mgrid[0:512, 0:512]
    n = hash_noise(x, y)
    assert n.min() > -1 and n.max() <= 1
    assert n.std() == pytest.approx(0.578, abs=0.01)
    assert smooth_noise(x, y).std() == pytest.approx(0.216, abs=0.01)


def test_smoothing_weights_sum_to_one(monkeypatch):
    import procgen_wood.grain as g
    monkeypatch.setattr(g, "hash_noise", lambda x, y, variant="elias": np.full(np.broadcast(x, y).shape, 0.37))
    assert np.allclose(g.smooth_noise(np.arange(5), np.arange(5)), 0.37)


def test_turbulence_bound_blocks_and_continuity():
    y, x = np.mgrid[0:256, 0:256]
    for interp in ("truncate", "bilinear", "cosine"):
        assert np.abs(turbulence(x, y, 128, interp)).max() <= 255
    # truncate: the 128 octave is constant on aligned 128-px blocks -> a jump at u = 128
    tr = turbulence(x, y, 128, "truncate")
    bl = turbulence(x, y, 128, "bilinear")
    jump_tr = np.abs(tr[:, 128] - tr[:, 127]).mean()
    jump_bl = np.abs(bl[:, 128] - bl[:, 127]).mean()
    assert jump_tr > 5 * np.abs(np.diff(tr[:, 1:127], axis=1)).mean()
    assert jump_bl < 2 * np.abs(np.diff(bl[:, 1:127], axis=1)).mean()
    assert tr.min() == pytest.approx(tr.min())          # determinism of the pure function
    assert np.array_equal(bl, turbulence(x, y, 128, "bilinear"))


@pytest.mark.parametrize("turb_power, ring", [(0.0, "half_ellipse"), (2.0, "circle"), (0.2, "cos_pi_x")])
def test_texture_bytes_in_the_printed_ranges(turb_power, ring):
    img = wood_texture(ring=ring, turb_power=turb_power)
    lo, hi = img.reshape(-1, 3).min(0), img.reshape(-1, 3).max(0)
    assert (lo >= [190, 120, 70]).all() and (hi <= [205, 135, 80]).all()


@pytest.mark.parametrize("period, rings", [(20, 14), (30, 21)])
def test_half_ellipse_ring_count(period, rings):
    """floor(2 P f_max) dark rings, f_max = (255/256)^2 / 9 + 1/4 at the corner (u, v) = (255, 0).

    f grows monotonically along the segment from its zero (0, 128) to that corner, so the bright
    runs along it are the bands between dark rings: rings + 1 of them.
    """
    img = wood_texture(ring="half_ellipse", xy_period=period, turb_power=0.0)
    t = np.linspace(0, 1, 4000)
    u, v = np.round(255 * t).astype(int), np.round(128 - 128 * t).astype(int)
    bright = (img[v, u, 0] >= 198).astype(int)             # |sin| >= ~0.53
    runs = int(bright[0]) + int(np.sum(np.diff(bright) == 1))
    assert runs == rings + 1


def test_no_turbulence_means_the_image_depends_on_f_only():
    a = wood_texture(turb_power=0.0, interp="truncate")
    b = wood_texture(turb_power=0.0, interp="bilinear", turb_size=8)
    assert np.array_equal(a, b)


def test_object_linear_and_sphere_map():
    rng = np.random.default_rng(0)
    p = rng.normal(size=(50, 3))
    n = rng.normal(size=(50, 3))
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    st = texture_coordinates(p, n, plane_s=(1, 0, 0, 0.5), scale=2.0)
    assert np.allclose(st[:, 0], 2 * (p[:, 0] + 0.5)) and np.allclose(st[:, 1], 2 * p[:, 1])
    st = texture_coordinates(p, n, plane_s=(0, 1, 0, 0))
    assert np.allclose(st, p[:, [1, 2]])                       # t = next axis cyclically
    st = texture_coordinates(p, n, mode="sphere_map")
    assert np.allclose(st, n[:, :2] / 2 + 0.5)
    img = wood_texture(64, 64, turb_size=16) / 255.0
    col = sample_bilinear(img, rng.normal(scale=10, size=(500, 2)))
    assert np.isfinite(col).all()
    assert (col >= img.reshape(-1, 3).min(0) - 1e-12).all() and (col <= img.reshape(-1, 3).max(0) + 1e-12).all()


def test_bilinear_sampling_hits_texel_centres_and_wraps():
    img = np.random.default_rng(1).random((8, 16, 3))
    j, i = 3, 5
    st = np.array([[(i + 0.5) / 16, (j + 0.5) / 8], [(i + 0.5) / 16 + 7, (j + 0.5) / 8 - 3]])
    assert np.allclose(sample_bilinear(img, st), img[j, i])
