"""Wood grain x CA colour (thesis 4.3.4, Fig. 4.15).

``modulate`` is the thesis's GL_MODULATE: texture x CA colour per channel, with the CA colour
taken relative to the palette's fresh-wood colour (clipped to <= 1) so an untouched cell shows
the bare texture.  A product can only darken, and this texture's blue channel is <= 80/255, so
modulation never reaches the silvery grey of weathered wood.  ``lerp`` mixes towards the palette
colour carrying the grain as a luminance ratio, by w = min(1, age / v_full): it reaches grey and
keeps the figure.
"""
from __future__ import annotations

import numpy as np

BLENDS = ("modulate", "lerp", "ca_only", "texture_only")
_LUMA = np.array([0.2126, 0.7152, 0.0722])


def compose(wood: np.ndarray | None, ca: np.ndarray, age: np.ndarray, *, blend: str,
            fresh: np.ndarray, v_full: float = 200.0) -> np.ndarray:
    """(n, 3) colours in [0, 1] from the grain ``wood`` and the CA colour ``ca`` (both in [0, 1])."""
    if blend == "ca_only":
        return np.clip(ca, 0, 1)
    assert wood is not None
    if blend == "texture_only":
        return np.clip(wood, 0, 1)
    if blend == "modulate":
        return wood * np.clip(ca / np.maximum(fresh, 1e-6), 0, 1)
    lum = wood @ _LUMA
    ratio = lum / max(float(lum.mean()), 1e-6)
    w = np.clip(np.asarray(age, float) / v_full, 0, 1)[:, None]
    return np.clip((1 - w) * wood + w * ca * ratio[:, None], 0, 1)
