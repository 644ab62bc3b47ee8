"""Age -> colour palette and composition (thesis 4.3.3-4.3.4, Fig. 4.15; the palette is ours)."""
from __future__ import annotations

import numpy as np
import pytest

from procgen import InputError
from procgen_wood.compose import compose
from procgen_wood.grain import wood_texture
from procgen_wood.palette import (FIRST_GREY, LAB_STAGES, THRESHOLDS, check_palette, default_colors,
                                  lab_to_srgb, palette_colors, palette_index, srgb_to_lab)

COLORS = np.asarray(default_colors(), float)


def test_lab_round_trip_and_white_point():
    rgb = np.random.default_rng(0).random((200, 3))
    assert np.allclose(lab_to_srgb(srgb_to_lab(rgb)), rgb, atol=1e-9)
    assert np.allclose(srgb_to_lab(np.ones(3)), [100, 0, 0], atol=1e-3)


def test_palette_is_in_gamut_and_its_bytes_reproduce_the_designed_lab():
    raw = lab_to_srgb(LAB_STAGES)
    assert (raw >= 0).all() and (raw <= 1).all()
    assert np.allclose(srgb_to_lab(COLORS / 255), LAB_STAGES, atol=0.6)


def test_value_and_colour_never_decrease_along_the_palette():
    """Thresholds rise; Delta E from fresh wood rises strictly (never back towards fresh);
    chroma never rises after the yellowing stage; lightness falls, then rises to silver."""
    assert np.all(np.diff(THRESHOLDS) > 0)
    lab = srgb_to_lab(COLORS / 255)
    de = np.linalg.norm(lab - lab[0], axis=1)
    assert np.all(np.diff(de) > 0)
    chroma = np.hypot(lab[:, 1], lab[:, 2])
    assert chroma[1] > chroma[0] and np.all(np.diff(chroma[1:]) <= 0)
    assert lab[2, 0] < lab[0, 0] and lab[-1, 0] > lab[3, 0]
    assert chroma[-1] < 2                                   # the end is a neutral grey


def test_colour_of_a_growing_value_never_moves_back_towards_fresh():
    lab0 = srgb_to_lab(COLORS[0] / 255)
    values = np.arange(0, 433)
    de = np.linalg.norm(srgb_to_lab(palette_colors(values, THRESHOLDS, COLORS)) - lab0, axis=1)
    assert np.all(np.diff(de) >= 0) and de[-1] > 25
    k = palette_index(values, THRESHOLDS)
    assert np.all(np.diff(k) >= 0) and k[0] == 0 and k[-1] == len(THRESHOLDS) - 1


def test_piecewise_constant_and_interpolated_lookup():
    v = np.array([0, 1, 29, 30, 79.5, 200, 10_000])
    c = palette_colors(v, THRESHOLDS, COLORS)
    assert np.allclose(c * 255, COLORS[[0, 1, 1, 2, 2, 5, 5]])
    ci = palette_colors(np.array([55.0]), THRESHOLDS, COLORS, interpolate=True)
    assert np.allclose(ci * 255, (COLORS[2] + COLORS[3]) / 2)


def test_cap_keeps_dry_cells_brown():
    v = np.full(4, 400.0)
    cap = np.array([FIRST_GREY - 1, 99, FIRST_GREY - 1, 99])
    c = palette_colors(v, THRESHOLDS, COLORS, cap=np.minimum(cap, len(THRESHOLDS) - 1))
    assert np.allclose(c[0] * 255, COLORS[FIRST_GREY - 1]) and np.allclose(c[1] * 255, COLORS[-1])


@pytest.mark.parametrize("th, col", [([0, 5], [[1, 2, 3]]), ([1, 5], [[1, 2, 3], [4, 5, 6]]),
                                     ([0, 5, 5], [[1, 2, 3]] * 3), ([0], [[1, 2, 300]])])
def test_bad_palettes_are_refused(th, col):
    with pytest.raises(InputError):
        check_palette(th, col)


def _wood(n=5000):
    img = wood_texture(128, 128, turb_size=32) / 255.0
    return img.reshape(-1, 3)[:n]


def test_blends_stay_in_gamut_and_modulate_only_darkens():
    wood = _wood()
    age = np.random.default_rng(2).integers(0, 433, len(wood)).astype(float)
    ca = palette_colors(age, THRESHOLDS, COLORS)
    fresh = COLORS[0] / 255
    for blend in ("modulate", "lerp", "ca_only", "texture_only"):
        out = compose(wood, ca, age, blend=blend, fresh=fresh)
        assert out.shape == wood.shape and (out >= 0).all() and (out <= 1).all()
    mod = compose(wood, ca, age, blend="modulate", fresh=fresh)
    assert (mod <= wood + 1e-12).all()
    assert np.allclose(mod[age == 0], wood[age == 0])        # untouched cells show the bare texture


def test_modulate_cannot_reach_silver_grey_but_lerp_does():
    """Blue <= 80/255 in this texture: no modulated pixel is a neutral grey brighter than that."""
    wood = _wood()
    age = np.full(len(wood), 432.0)
    ca = palette_colors(age, THRESHOLDS, COLORS)
    fresh = COLORS[0] / 255
    mod = compose(wood, ca, age, blend="modulate", fresh=fresh)
    lab = srgb_to_lab(mod)
    neutral = np.hypot(lab[:, 1], lab[:, 2]) < 3
    assert not (neutral & (mod.min(1) > 80 / 255)).any()
    lerp = compose(wood, ca, age, blend="lerp", fresh=fresh)
    lab = srgb_to_lab(lerp)
    assert np.hypot(lab[:, 1], lab[:, 2]).max() < 3 and lerp.min() > 0.55    # silvery grey
    lum = lerp @ [0.2126, 0.7152, 0.0722]
    wl = wood @ [0.2126, 0.7152, 0.0722]
    assert np.corrcoef(lum, wl)[0, 1] > 0.99                 # the grain survives as luminance
