"""Colours of cells in previews and exports: flat colours for labelled cells (Voronoi regions,
per-triangle grids), and the Phong lobes a bake rule left (a stack's look, procgen_layers.bake).
"""
from __future__ import annotations

import colorsys
from typing import Any

import numpy as np


def label_colors(labels: np.ndarray, seed: int = 0) -> np.ndarray:
    """Distinct pastel colours per integer label (0 = unlabelled -> grey)."""
    rng = np.random.default_rng(seed)
    k = int(labels.max()) + 1 if len(labels) else 1
    hues = (np.arange(k) * 0.618033988749895 + rng.random()) % 1.0
    pal = np.array([colorsys.hsv_to_rgb(h, 0.55, 0.95) for h in hues])
    pal[0] = (0.6, 0.6, 0.6)
    return pal[np.clip(labels, 0, None)]


def lobe_colors(cells: Any, *, light: np.ndarray, eye: np.ndarray) -> np.ndarray:
    """(n, 3) Phong colour per cell from baked lobes: A + max(N.L, 0) D + sum_j s_j max(R.E, 0)^e_j
    (white highlights, none on the unlit side), with the cell normals.

    ``shade__ambient`` A and ``shade__diffuse`` D (n, 3), ``shade__specular`` s (n, J) and
    ``shade__exponent`` e (J,) are whatever a bake rule wrote (a layer stack: one lobe per
    layer, procgen_layers.bake), so the preview lights any camera without knowing what made them.
    """
    n = np.asarray(cells.normal, float)
    lv = np.asarray(light, float) / np.linalg.norm(light)
    ev = np.asarray(eye, float) / np.linalg.norm(eye)
    ndl = n @ lv
    rde = np.clip((2.0 * ndl[:, None] * n - lv) @ ev, 0.0, None)
    s = np.asarray(cells["shade__specular"], float)
    ex = np.asarray(cells["shade__exponent"], float)
    spec = np.where(ndl > 0, np.sum(s * rde[:, None] ** ex[None, :], axis=1), 0.0)
    c = (np.asarray(cells["shade__ambient"], float) + np.clip(ndl, 0.0, None)[:, None]
         * np.asarray(cells["shade__diffuse"], float) + spec[:, None])
    return np.clip(c, 0.0, 1.0)
