"""Flat colours for labelled cells (Voronoi regions, per-triangle grids) in previews and exports.

Colours seen through a layer stack are the layered-materials family's (procgen_layers.light).
"""
from __future__ import annotations

import colorsys

import numpy as np


def label_colors(labels: np.ndarray, seed: int = 0) -> np.ndarray:
    """Distinct pastel colours per integer label (0 = unlabelled -> grey)."""
    rng = np.random.default_rng(seed)
    k = int(labels.max()) + 1 if len(labels) else 1
    hues = (np.arange(k) * 0.618033988749895 + rng.random()) % 1.0
    pal = np.array([colorsys.hsv_to_rgb(h, 0.55, 0.95) for h in hues])
    pal[0] = (0.6, 0.6, 0.6)
    return pal[np.clip(labels, 0, None)]
