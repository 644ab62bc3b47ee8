"""The crack-mirror effect of glazed ceramics (3DSCA thesis 5.2.5.b, Figures 5.15-5.18).

Under a thin transparent glaze a hairline crack is nearly invisible; what shows is the crack
wall's shadow and its reflection thrown onto the lower layer, beside the crack (Figure 5.15).
The wall is as high as the glaze is thick (t); light entering the glaze at alpha_1 from the
facet normal refracts to alpha_2 = asin(sin alpha_1 / n) (Snell, Eq. 1), so the wall's shadow
on the lower layer reaches d = t tan alpha_2 away from the crack, on the side away from the
light, and the light the wall reflects lands in a band of the same width on the light's side
(Eq. 2: the crack point moved down by the layer thickness, the refracted light ray, its
intersection with the lower layer's plane, projected across the crack).  The thesis's cheap
version (Eqs. 3-4) ignores refraction, d = tan alpha_1, and deadens it to d' = T d / sqrt(1+d^2)
= T sin alpha_1, which saturates at the thickness T and stays well-behaved at grazing angles.
Only facets lit from the front show the effect (Figure 5.17): a sun light's direction v_L
(from the light) must satisfy v_L . n < 0; a spot light at L, (C - L) . n < 0.

The bands are drawn with the same anti-aliased linked-segment routine as the cracks
(:func:`.render.micro_coverage`): each segment moved by half the offset across itself, the
band's width being the offset measured across the segment.
"""
from __future__ import annotations

import numpy as np

from procgen import geometry as geo

from .render import Segments

MODELS = ("snell", "damped")


def mirror_offset(cos_in: np.ndarray, thickness: np.ndarray, refraction: float,
                  model: str = "snell") -> np.ndarray:
    """Distance d >= 0 on the lower layer (thickness units) for light at cos(alpha_1) = ``cos_in``.

    ``snell``: t tan(asin(sin alpha_1 / n)) (Eq. 2); ``damped``: T sin alpha_1 (Eqs. 3-4), < T.
    """
    c = np.clip(np.asarray(cos_in, dtype=float), 0.0, 1.0)
    sin1 = np.sqrt(1.0 - c * c)
    t = np.asarray(thickness, dtype=float)
    if model == "damped":
        return t * sin1
    sin2 = sin1 / refraction
    return t * sin2 / np.sqrt(1.0 - sin2 * sin2)


def light_vectors(points: np.ndarray, light: np.ndarray) -> np.ndarray:
    """Unit vectors from ``points`` (n, 3) towards the light: (3,) sun direction or (1, 3) spot."""
    lv = np.asarray(light, dtype=float)
    if lv.ndim == 2:                                  # a spot light's position
        d = lv[0] - points
    else:
        d = np.broadcast_to(lv, points.shape)
    return d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-300)


def front_lit_faces(cells, light: np.ndarray) -> np.ndarray:
    """(m,) facets lit from the front (Figure 5.17), a spot light judged at each facet centroid."""
    normal = geo.face_normals(cells.vertices, cells.faces)
    centre = cells.vertices[cells.faces].mean(axis=1)
    return np.sum(light_vectors(centre, light) * normal, axis=1) > 0


def mirror_bands(cells, seg: Segments, thickness: np.ndarray, light: np.ndarray, *,
                 refraction: float = 1.5, model: str = "snell") -> tuple[Segments, Segments, np.ndarray]:
    """(shadow, highlight) band segments and the front-lit mask of each crack segment.

    ``thickness`` (S,): glaze thickness at each segment, in surface length.  Returned bands keep
    only the front-lit segments; each band is the segment moved d/2 across itself (away from the
    light for the shadow, towards it for the highlight) with width d across the segment.
    """
    fr = cells.layout.frames
    normal = geo.face_normals(cells.vertices, cells.faces)[seg.face]
    mid = fr.to_3d(seg.face, 0.5 * (seg.a + seg.b))
    lv = light_vectors(mid, light)
    cos_in = np.sum(lv * normal, axis=1)
    front = cos_in > 0                               # v_L . n < 0 with v_L pointing from the light
    tangent = np.column_stack([np.sum(lv * fr.ex[seg.face], 1), np.sum(lv * fr.ey[seg.face], 1)])
    tl = np.linalg.norm(tangent, axis=1)
    towards = tangent / np.maximum(tl, 1e-300)[:, None]        # in-plane direction to the light
    ab = seg.b - seg.a
    across = np.column_stack([-ab[:, 1], ab[:, 0]]) / np.maximum(np.linalg.norm(ab, axis=1), 1e-300)[:, None]
    side = np.sum(across * towards, axis=1)
    across = across * np.where(side < 0, -1.0, 1.0)[:, None]   # unit normal on the light's side
    d = mirror_offset(cos_in, thickness, refraction, model) * np.abs(side) * (tl > 1e-12)
    shift = 0.5 * d[:, None] * across
    keep = front & (d > 0)
    shadow = seg.shifted(-shift).with_width(d).select(keep)
    highlight = seg.shifted(shift).with_width(d).select(keep)
    return shadow, highlight, front
