"""Age -> colour: the thesis's "cell value" picks a colour by range (thesis 3.2, 4.3.3).

The thesis gives neither the ranges nor the colours.  This palette is ours, designed in CIE
L*a*b* (D65) from the wood-weathering literature the thesis's 2.2 paraphrases (Feist & Hon
1984; Williams 2005): light wood first yellows (b* rises) and darkens (L* falls), then loses
chroma as the lignin products wash out, ending as a silvery grey.  Along the palette the
thresholds rise, the colour difference from fresh wood (Delta E*ab) strictly rises (a cell's
colour never moves back towards fresh) and the chroma never rises after the yellowing stage.
(With ``interpolate`` the colour runs along straight sRGB segments between the stages; on the last
one, grey to silver, lightness climbs back towards that of fresh wood while the chroma stays low.)

| from value | stage | L* | a* | b* |
| --- | --- | --- | --- | --- |
| 0 | fresh wood | 66 | 12 | 30 |
| 1 | yellowed | 62 | 12.5 | 35 |
| 30 | darker brown | 50 | 11 | 28 |
| 80 | brown-grey | 47 | 5 | 14 |
| 140 | grey | 52 | 1.5 | 5 |
| 200 | silvery grey | 68 | 0 | 0.5 |

Values count steps alive (ca.life's cumulative age): after the thesis's 432 steps the mean is
roughly 160-270, so the last range is reached by many cells but not all.
"""
from __future__ import annotations

import numpy as np

from procgen import InputError

LAB_STAGES = np.array([[66, 12, 30], [62, 12.5, 35], [50, 11, 28], [47, 5, 14], [52, 1.5, 5],
                       [68, 0, 0.5]], float)
THRESHOLDS = (0, 1, 30, 80, 140, 200)
#: index of the first stage that needs wetting (greying: lignin products washed out by rain)
FIRST_GREY = 3

_WHITE = np.array([0.95047, 1.0, 1.08883])
_RGB2XYZ = np.array([[0.4124564, 0.3575761, 0.1804375],
                     [0.2126729, 0.7151522, 0.0721750],
                     [0.0193339, 0.1191920, 0.9503041]])


def srgb_to_lab(rgb: np.ndarray) -> np.ndarray:
    """sRGB in [0, 1] -> CIE L*a*b* (D65)."""
    c = np.asarray(rgb, float)
    lin = np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)
    xyz = lin @ _RGB2XYZ.T / _WHITE
    f = np.where(xyz > (6 / 29) ** 3, np.cbrt(xyz), xyz / (3 * (6 / 29) ** 2) + 4 / 29)
    return np.stack([116 * f[..., 1] - 16, 500 * (f[..., 0] - f[..., 1]),
                     200 * (f[..., 1] - f[..., 2])], axis=-1)


def lab_to_srgb(lab: np.ndarray) -> np.ndarray:
    """CIE L*a*b* (D65) -> sRGB in [0, 1] (unclipped: out-of-gamut shows as < 0 or > 1)."""
    lab = np.asarray(lab, float)
    fy = (lab[..., 0] + 16) / 116
    f = np.stack([fy + lab[..., 1] / 500, fy, fy - lab[..., 2] / 200], axis=-1)
    xyz = np.where(f > 6 / 29, f ** 3, 3 * (6 / 29) ** 2 * (f - 4 / 29)) * _WHITE
    lin = xyz @ np.linalg.inv(_RGB2XYZ).T
    return np.where(lin <= 0.0031308, 12.92 * lin, 1.055 * np.abs(lin) ** (1 / 2.4) - 0.055)


def default_colors() -> list[list[int]]:
    """The palette's stages as sRGB bytes."""
    return np.round(lab_to_srgb(LAB_STAGES) * 255).astype(int).tolist()


def check_palette(thresholds: list[float], colors: list[list[float]], where: str = "palette") -> None:
    """One line naming what is wrong with a (thresholds, sRGB byte colours) palette."""
    if len(thresholds) != len(colors) or len(colors) < 1:
        raise InputError(f"{where}: need as many thresholds as colours, got {len(thresholds)} "
                         f"and {len(colors)}")
    if any(len(c) != 3 or min(c) < 0 or max(c) > 255 for c in colors):
        raise InputError(f"{where}: colours are [r, g, b] bytes in 0..255")
    if list(thresholds) != sorted(set(thresholds)) or thresholds[0] != 0:
        raise InputError(f"{where}: thresholds must rise strictly from 0, got {list(thresholds)}")


def palette_index(value: np.ndarray, thresholds: np.ndarray) -> np.ndarray:
    """Index of the range each value falls in (values below 0 count as 0)."""
    return np.searchsorted(np.asarray(thresholds, float), np.asarray(value, float), side="right") - 1


def palette_colors(value: np.ndarray, thresholds: np.ndarray, colors: np.ndarray, *,
                   interpolate: bool = False, cap: np.ndarray | None = None) -> np.ndarray:
    """sRGB in [0, 1] per value: the colour of its range, or linear between range starts.

    ``cap`` (per value, optional) limits the range index (e.g. dry cells never grey).
    """
    th = np.asarray(thresholds, float)
    col = np.asarray(colors, float) / 255.0
    v = np.maximum(np.asarray(value, float), 0.0)
    k = palette_index(v, th)
    if cap is not None:
        k = np.minimum(k, cap)
        v = np.minimum(v, th[k])
    if not interpolate or len(th) == 1:
        return col[k]
    k1 = np.minimum(k + 1, len(th) - 1)
    span = np.where(k1 > k, th[k1] - th[k], 1.0)
    w = np.where(k1 > k, np.clip((v - th[k]) / span, 0, 1), 0.0)[:, None]
    return col[k] * (1 - w) + col[k1] * w
