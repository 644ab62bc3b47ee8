"""Gallery numbers as people read them, the fake anti-aliasing (plate B.1), normals overlay (3.1(a))."""
from __future__ import annotations

import io

import numpy as np
import pytest
from PIL import Image

from procgen import InputError, TriMesh
from procgen.gallery import _entry_from
from procgen.site.numbers import format_number, report_text
from procgen.errors import RecipeError
from procgen.exchange.preview import preview_png
from procgen_surface.domain import SurfaceCells
from procgen_surface.exporters import surface_png


def test_numbers_read_with_three_figures_units_and_the_thesis_beside():
    assert report_text("cells.voronoi.completion_r10", 0.9621451, {"cells.voronoi.completion_r10": 0.87}) == \
        "cells.voronoi.completion_r10 = 96.2 % (thesis: 87 %)"
    assert report_text("cells.voronoi.steps_to_full", 129, {"cells.voronoi.steps_to_full": 110.0}) == \
        "cells.voronoi.steps_to_full = 129 steps (thesis: 110 steps)"
    assert report_text("cells.n_cells", 247008, {}) == "cells.n_cells = 247,008 cells"
    assert report_text("c.corrosion.saturation_ratio", 9.7954, {}) == "c.corrosion.saturation_ratio = 9.8x"
    assert format_number(12345.678) == "12,300" and format_number(0.0090509) == "0.00905"
    assert format_number(None) == "-" and format_number(True) == "True"


def test_a_thesis_table_must_hold_numbers():
    e = _entry_from({"recipe": "meshes/plate-3-2", "thesis": {"a.b": 0.87}}, "g", 0)
    assert e.thesis == {"a.b": 0.87}
    with pytest.raises(RecipeError, match="thesis must be a table"):
        _entry_from({"recipe": "meshes/plate-3-2", "thesis": {"a.b": "87 %"}}, "g", 0)


def _voronoi_cells() -> SurfaceCells:
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    sc = SurfaceCells.from_mesh(v, f, target_cells=3000)
    sc.add_field("voronoi__label", (np.arange(sc.n_cells) * 7919 % 13 + 1).astype(np.int32), at="cell")
    return sc


def _img(png: bytes) -> np.ndarray:
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB"), dtype=float)


def test_fake_antialiasing_softens_borders_without_blurring():
    sc = _voronoi_cells()
    opts = dict(color_by="voronoi", width=160, height=140, exaggerate=0.0)
    one = surface_png(sc, **opts)
    assert surface_png(sc, antialias=1, **opts) == one              # default: one render, same bytes
    a, b = _img(one), _img(surface_png(sc, antialias=3, **opts))
    def hard_steps(im: np.ndarray) -> int:                           # pixel-to-pixel jumps
        return int(np.sum(np.abs(np.diff(im, axis=1)).sum(axis=2) > 90) + np.sum(np.abs(np.diff(im, axis=0)).sum(axis=2) > 90))
    assert hard_steps(b) < 0.9 * hard_steps(a)                        # the staircases soften (0.82 here)
    changed = np.any(np.abs(a - b) > 1, axis=2)
    assert 0.0 < changed.mean() < 0.5                                 # borders only, not the whole image
    with pytest.raises(InputError, match="antialias must be 1..8"):
        surface_png(sc, antialias=0, **opts)


def test_preview_draws_visible_edges_and_white_normals():
    v = np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1.0]])
    f = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    m = TriMesh(v, f)
    plain = _img(preview_png(m, width=200, height=180))
    drawn = _img(preview_png(m, width=200, height=180, edges=True, normals=0.3))
    white = np.all(drawn > 250, axis=2) & ~np.all(plain > 250, axis=2)
    assert white.sum() > 5                     # normal strokes over the (grey) faces
    edges = _img(preview_png(m, width=200, height=180, edges=True))
    dark = (edges.sum(axis=2) < 150) & (plain.sum(axis=2) >= 150)
    assert dark.sum() > 100                    # the visible edges drawn dark over the faces
    with pytest.raises(InputError, match="normals must be"):
        preview_png(m, normals=-1.0)
