"""Drops as a water depth map: the film ``layers.shade`` draws on top of the stack (plate 2.5)."""
from __future__ import annotations

import numpy as np



def water_depth_map(shape: tuple[int, int], pos: np.ndarray, volume: np.ndarray, spacing: float,
                    gain: float = 1.0) -> np.ndarray:
    """Drop volume splatted per cell as a water depth (volume / cell area * gain)."""
    ny, nx = shape
    if len(volume) == 0:
        return np.zeros(shape)
    ix = np.clip(np.floor(pos[:, 0]).astype(np.int64), 0, nx - 1)
    iy = np.clip(np.floor(pos[:, 1]).astype(np.int64), 0, ny - 1)
    d = np.bincount(iy * nx + ix, weights=volume, minlength=ny * nx) / (spacing * spacing)
    return gain * d.reshape(shape)
