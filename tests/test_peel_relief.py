"""The lifted, peeling paint through the standard surface exporters (relief option).

The partial-peeling elevation ``peel__lift`` (thesis 5.3.3, Figure 5.30) drives the generic
``relief`` option of surface_obj / surface_glb / surface_png: the exported files, read back by
trimesh, have the lifted vertices moved along the normal by the lift and the rest unchanged.
"""
from __future__ import annotations

import io

import numpy as np
import pytest
import trimesh
from scipy.spatial import cKDTree

from procgen import InputError
from procgen.plugins import get_plugin_manager
from procgen.testing import drive_rule, run_example
from procgen_cracks.peel import Peel
from procgen_surface.domain import SurfaceCells
from procgen_surface.exporters import surface_glb, surface_obj, surface_png
from test_peel_render import flat_cells

LIFT = 0.03


def flat_square() -> SurfaceCells:
    """The flat unit square of cells (copper under paint) with a raised plateau in the middle."""
    sc = flat_cells()
    x, y = sc.center3d[:, 0], sc.center3d[:, 1]
    sc.add_field("peel__lift", np.where((np.abs(x) < 0.2) & (np.abs(y) < 0.2), LIFT, 0.0),
                 at="cell", units="length")
    return sc


def load_obj(files: dict[str, bytes]) -> trimesh.Trimesh:
    obj = next(v for k, v in files.items() if k.endswith(".obj"))
    return trimesh.load(io.BytesIO(obj), file_type="obj", process=False, force="mesh")


def load_glb(data: bytes) -> trimesh.Trimesh:
    return trimesh.load(io.BytesIO(data), file_type="glb", process=False, force="mesh")


@pytest.mark.parametrize("scale", [1.0, 2.5])
def test_obj_plateau_is_raised_by_the_lift_and_the_rest_is_unchanged(scale):
    sc = flat_square()
    opts = {"stem": "t", "cells_per_segment": 1.0, "exaggerate": 0.0}
    flat = load_obj(surface_obj(sc, **opts))
    lifted = load_obj(surface_obj(sc, relief="peel__lift", relief_scale=scale, **opts))
    v0, v1 = np.asarray(flat.vertices), np.asarray(lifted.vertices)
    assert v0.shape == v1.shape and np.array_equal(flat.faces, lifted.faces)
    np.testing.assert_allclose(v1[:, :2], v0[:, :2], atol=2e-6)        # moved along z only
    dz = v1[:, 2] - v0[:, 2]
    cell = 0.05
    inner = np.all(np.abs(v0[:, :2]) < 0.2 - 1.5 * cell, axis=1)
    outer = np.any(np.abs(v0[:, :2]) > 0.2 + 1.5 * cell, axis=1)
    assert inner.sum() > 20 and outer.sum() > 100
    np.testing.assert_allclose(dz[inner], scale * LIFT, atol=2e-6)     # OBJ writes 6 decimals
    np.testing.assert_allclose(dz[outer], 0.0, atol=2e-6)
    assert dz.min() >= -2e-6 and dz.max() <= scale * LIFT + 2e-6


def test_glb_of_a_peeled_cube_moves_lifted_vertices_along_the_normal_by_the_lift():
    """End to end: cracks.imposed + cracks.peel (mid-peel, lift on), then the standard GLB."""
    st = run_example(Peel, get_plugin_manager(), seed=3, upto=len(Peel.example) - 1)
    drive_rule(Peel(lift_height=0.02, grow=False, peel_share=0.5), st)
    sc = st.get("cells")
    lift = np.asarray(sc["peel__lift"])
    assert (lift > 0).sum() > 100 and (lift == 0).sum() > 100
    # up = "y": the file keeps the model's own axes, so its vertices compare with the cells' centres
    opts = {"cells_per_segment": 1.0, "exaggerate": 0.0, "up": "y"}
    plain = load_glb(surface_glb(sc, **opts))
    raised = load_glb(surface_glb(sc, relief="peel__lift", **opts))
    v0, v1 = np.asarray(plain.vertices), np.asarray(raised.vertices)
    assert v0.shape == v1.shape
    d = v1 - v0
    # the vertex takes the lift of the cell under it: between the lifts of its nearest cells, and
    # outwards along the exporter's rounded-facet normal (interpolated from the cube's diagonal
    # vertex normals, so within about 25 degrees of the facet normal; checked inside facets)
    _, near = cKDTree(sc.center3d).query(v0, k=4)
    lv = lift[near]
    mag = np.linalg.norm(d, axis=1)
    assert np.all(mag >= lv.min(axis=1) - 1e-6) and np.all(mag <= lv.max(axis=1) + 1e-6)
    face = sc.face[near]
    inside = (np.ptp(face, axis=1) == 0) & (lv.min(axis=1) > 0)
    assert inside.sum() > 50
    up = np.einsum("ij,ij->i", d, sc.normal[near[:, 0]])
    assert np.all(up[inside] >= 0.9 * mag[inside])
    same = np.ptp(lv, axis=1) == 0
    sel = same & (lv[:, 0] > 0)
    np.testing.assert_allclose(mag[sel], lv[sel, 0], rtol=1e-4, atol=1e-6)
    still = same & (lv[:, 0] == 0)
    assert still.sum() > 50
    np.testing.assert_allclose(d[still], 0.0, atol=1e-6)               # the rest is unchanged


def test_png_relief_draws_and_zero_relief_changes_no_byte():
    sc = flat_square()
    opts = {"width": 160, "height": 120, "elevation": 60.0, "cells_per_segment": 1.0}
    base = surface_png(sc, **opts)
    assert surface_png(sc, relief="peel__lift", **opts) != base
    sc.add_field("peel__lift", np.zeros(sc.n_cells), at="cell", units="length")
    assert surface_png(sc, relief="peel__lift", **opts) == base
    assert surface_glb(sc, relief="peel__lift") == surface_glb(sc)


def test_bad_relief_options_are_one_line_errors():
    sc = flat_square()
    bad = ({"relief": "nope"}, {"relief": "layers__thickness"},
           {"relief": "peel__lift", "relief_scale": -1.0}, {"relief": "peel__lift", "relief_rim": 2.0})
    for kw in bad:
        with pytest.raises(InputError, match="surface_glb") as e:
            surface_glb(sc, **kw)
        assert "\n" not in str(e.value)
