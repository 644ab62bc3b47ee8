"""Crack rendering (3DSCA thesis 5.2.5): micro-cell coverage, the crack mirror, the textured mesh
and the SVG sheet, on crack paths built here by the family's contract (a Polylines of 3-D points,
each segment inside facet ``crack__face``, widths per point)."""
from __future__ import annotations

import io
from pathlib import Path

import numpy as np
import pytest
import shapely
import trimesh
from PIL import Image
from scipy.integrate import quad

from procgen import Polylines, State
from procgen_cracks.exporters import crack_glb, crack_obj, crack_svg, texel_colors
from procgen_cracks.mirror import mirror_offset
from procgen_cracks import render
from procgen_cracks.render import (PROFILES, band_coverage, coverage_bound, profile_constants,
                                     profile_density)
from procgen_cracks.render_rules import CrackMirror, CrackSheet, DrawCracks, RenderCracks
from procgen_layers.materials import parse_materials
from procgen_layers.stack import put_thickness, store_table
from procgen_surface.domain import SurfaceCells

GREEN, CREAM = [0.15, 0.55, 0.3], [0.95, 0.92, 0.85]


def stacked(v: np.ndarray, f: np.ndarray, size: float) -> SurfaceCells:
    """Cells with a green ceramic under a cream glaze of uniform thickness."""
    sc = SurfaceCells.from_mesh(v, f, cell_size=size)
    table = parse_materials([{"name": "ceramic", "color": GREEN, "opacity": 0.99},
                             {"name": "glaze", "color": CREAM, "opacity": 0.9}])
    store_table(sc, table)
    put_thickness(sc, np.tile([1.0, 0.6], (sc.n_cells, 1)), table)
    return sc


def flat_state(lines: list[list[float]], size: float = 0.1) -> State:
    """A unit square (two triangles, z = 0) with cracks drawn by cracks.draw."""
    v = np.array([[-0.5, -0.5, 0], [0.5, -0.5, 0], [0.5, 0.5, 0], [-0.5, 0.5, 0]], float)
    state = State(seed=3)
    state.add_domain("cells", stacked(v, np.array([[0, 1, 2], [0, 2, 3]]), size))
    DrawCracks(lines=lines).step(state)
    return state


def micro_centres(sc: SurfaceCells, k: int, corner: tuple[float, float] = (0.5, 0.5)) -> np.ndarray:
    """(n, k, k, 3) world positions of a point of every micro-cell [cell, x, y] (default centre)."""
    sub = (np.arange(k)[:, None] + np.asarray(corner)) / k * sc.size            # (k, 2)
    xy = sc.ij[:, None, None, :] * sc.size + np.stack(np.meshgrid(sub[:, 0], sub[:, 1], indexing="ij"), -1)
    face = np.repeat(sc.face, k * k)
    return sc.layout.frames.to_3d(face, xy.reshape(-1, 2)).reshape(sc.n_cells, k, k, 3)


@pytest.mark.parametrize("profile", PROFILES[1:])
def test_profiles_cover_the_central_micro_cell_fully(profile):
    """App. B 2.2.2: int_d^{d + C_s/2} f = 1/2 (d = 0 for V types), f >= 0, zero beyond C_t/2."""
    cs = 0.1
    for ct in (0.25, 0.4, 1.3):
        _, d, constant = profile_constants(np.array([ct]), cs, profile, 0.5)
        assert not constant[0]
        area, _ = quad(lambda x: float(profile_density(x, ct, cs, profile, 0.5)), d[0], d[0] + cs / 2,
                       points=[ct / 2], limit=200)
        assert area == pytest.approx(0.5, abs=1e-9)
        x = np.linspace(0, ct, 401)
        f = profile_density(x, ct, cs, profile, 0.5)
        assert np.all(f >= 0) and np.all(f[x > ct / 2] == 0)


def test_straight_band_coverage_is_the_exact_area_fraction():
    """Constant profile: coverage = area of (band ∩ micro-cell) / C_s^2, against shapely."""
    rng = np.random.default_rng(4)
    th, w, dist = rng.uniform(0, np.pi, 200), rng.uniform(0.02, 3, 200), rng.uniform(0, 2.5, 200)
    cov = band_coverage(dist, np.abs(np.cos(th)), np.abs(np.sin(th)), w, 1.0, "constant")
    square = shapely.box(-0.5, -0.5, 0.5, 0.5)
    for i in range(200):
        u, n = np.array([np.cos(th[i]), np.sin(th[i])]), np.array([-np.sin(th[i]), np.cos(th[i])])
        c = -dist[i] * n
        band = shapely.Polygon([c - 9 * u - w[i] / 2 * n, c + 9 * u - w[i] / 2 * n,
                                c + 9 * u + w[i] / 2 * n, c - 9 * u + w[i] / 2 * n])
        assert cov[i] == pytest.approx(band.intersection(square).area, abs=1e-12)


def test_micro_cells_of_a_drawn_crack_match_the_band_area_and_vanish_far_away():
    """A straight crack across the diagonal facet edge of a flat square, k = 8, constant profile."""
    w, k = 0.023, 8
    state = flat_state([[-0.42, 0.13, w, 0.41, 0.13, w]])
    sc = state.get("cells")
    RenderCracks(k=k, profile="constant").step(state)
    cov = np.asarray(sc["crack__coverage"])
    assert cov.shape == (sc.n_cells, k, k) and cov.min() >= 0 and cov.max() <= 1
    p = micro_centres(sc, k)[..., :2].reshape(-1, 2)
    flat = cov.ravel()
    cs = sc.size / k
    band = shapely.box(-0.42, 0.13 - w / 2, 0.41, 0.13 + w / 2)
    own = np.repeat(sc.face, k * k)                 # micro-cells outside their triangle are not shown
    lower = p[:, 1] < p[:, 0]                       # facet 0 is the lower-right triangle
    inner = (lower == (own == 0)) & (np.abs(p[:, 0]) < 0.38)      # the band runs on over the edge
    inner &= np.abs(p[:, 1] - 0.13) < 2 * cs
    quads = np.stack([micro_centres(sc, k, c)[..., :2].reshape(-1, 2)[inner]
                      for c in ((0, 0), (1, 0), (1, 1), (0, 1))], axis=1)          # facet frames turn
    ref = shapely.area(shapely.intersection(band, shapely.polygons(quads))) / cs ** 2
    np.testing.assert_allclose(flat[inner], ref, atol=1e-6)
    assert ref.max() == pytest.approx(1.0) and (ref > 0).sum() >= 3 * 50
    far = shapely.distance(shapely.points(p), shapely.LineString([(-0.42, 0.13), (0.41, 0.13)]))
    assert np.all(flat[far > w / 2 + cs * np.sqrt(0.5) + 1e-9] == 0)


@pytest.mark.parametrize("profile", ["constant", "u_linear", "v_parabolic_b"])
def test_coverage_grows_with_the_crack_width(profile):
    covs = []
    for w in (0.004, 0.01, 0.03, 0.06):
        state = flat_state([[-0.4, -0.31, w, 0.37, 0.22, w]])
        RenderCracks(k=6, profile=profile).step(state)
        covs.append(np.asarray(state.get("cells")["crack__coverage"]).sum())
    assert np.all(np.diff(covs) > 0)
    if profile == "constant":            # wider cracks cover every micro-cell at least as much
        state = [flat_state([[-0.4, -0.31, w, 0.37, 0.22, w]]) for w in (0.01, 0.03)]
        for s in state:
            RenderCracks(k=6, profile=profile).step(s)
        a, b = (np.asarray(s.get("cells")["crack__coverage"]) for s in state)
        assert np.all(b >= a - 1e-6)


@pytest.mark.parametrize("profile", PROFILES)
def test_coverage_bound_is_never_below_the_coverage(profile):
    """The pruning bound holds for hairlines and wide cracks, any direction, in and out of the band."""
    rng = np.random.default_rng(7)
    cs, n = 0.01, 200_000
    ang = rng.uniform(0.0, np.pi / 2, n)
    c, s = np.cos(ang), np.sin(ang)
    ct = cs * np.exp(rng.uniform(np.log(0.05), np.log(40.0), n))
    dist = rng.uniform(0.0, 1.0, n) * (0.5 * ct + cs)
    cov = band_coverage(dist, c, s, ct, cs, profile, 0.3)
    bound = coverage_bound(dist, c, s, ct, cs, profile, 0.3)
    assert np.all(bound >= cov) and (cov > 0.05).mean() > 0.3
    assert np.median(bound[cov > 0.05] / cov[cov > 0.05]) < 3.0       # tight enough to prune


@pytest.mark.parametrize("profile", ["v_linear", "u_parabolic_b"])
def test_pruned_coverage_equals_the_maximum_over_every_pair(profile, monkeypatch):
    """Wide bending cracks (many overlapping pieces): same bytes as evaluating every pair."""
    lines = [[-0.42, -0.3, 0.05, -0.1, 0.05, 0.12, 0.2, -0.12, 0.02, 0.41, 0.3, 0.08],
             [-0.3, 0.35, 0.03, 0.3, -0.38, 0.06]]
    covs = []
    for prune in (True, False):
        state = flat_state(lines, size=0.04)
        if not prune:
            monkeypatch.setattr(render, "coverage_bound", lambda dist, *a: np.full(len(dist), np.inf))
        RenderCracks(k=9, profile=profile).step(state)
        covs.append(np.asarray(state.get("cells")["crack__coverage"]))
    assert (covs[0] > 0).sum() > 5000 and covs[0].tobytes() == covs[1].tobytes()


def _every_row_and_column(seg, radius, cells, k, cs):
    """Reference scan: every micro-cell of each piece's facet grid (no reach at all)."""
    nx, ny = cells.nx[seg.face] * k, cells.ny[seg.face] * k
    piece = np.repeat(np.arange(len(seg)), ny)
    my = np.arange(len(piece)) - np.repeat(np.cumsum(ny) - ny, ny)
    return piece, my, np.zeros(len(piece), np.int64), nx[piece]


@pytest.mark.parametrize("profile", ["v_linear", "u_linear"])
def test_scanning_only_micro_cells_within_reach_keeps_the_bytes(profile, monkeypatch):
    """Against every (piece, micro-cell) pair of the facet grids, all integrated (no bound)."""
    lines = [[-0.42, -0.3, 0.05, -0.1, 0.05, 0.12, 0.2, -0.12, 0.02, 0.41, 0.3, 0.08],
             [-0.3, 0.35, 0.03, 0.3, -0.38, 0.06], [-0.45, 0.1, 0.02, 0.45, 0.1, 0.09],
             [0.1, -0.45, 0.01, 0.1, 0.45, 0.07]]                  # horizontal and vertical too
    covs = []
    for reach in (True, False):
        state = flat_state(lines, size=0.05)
        if not reach:
            monkeypatch.setattr(render, "_row_spans", _every_row_and_column)
            monkeypatch.setattr(render, "coverage_bound", lambda dist, *a: np.full(len(dist), np.inf))
        RenderCracks(k=7, profile=profile).step(state)
        covs.append(np.asarray(state.get("cells")["crack__coverage"]))
    assert (covs[0] > 0).sum() > 3000 and covs[0].tobytes() == covs[1].tobytes()


def test_row_spans_hold_every_micro_cell_within_reach_and_little_else():
    """Random pieces, every direction (axis-aligned included), thin to many micro-cells wide."""
    state = flat_state([[0.0, 0.0, 0.01, 0.1, 0.0, 0.01]], size=0.05)
    cells, k, cs = state.get("cells"), 8, 0.05 / 8
    rng = np.random.default_rng(11)
    n = 400
    a = rng.uniform(-0.45, 0.45, (n, 2))
    ang = rng.choice([0.0, np.pi / 2, np.pi / 4, 1.0], n) + rng.choice([0.0, 1.0], n) * rng.uniform(0, 7, n)
    b = a + 0.05 * rng.uniform(0.1, 1.0, n)[:, None] * np.column_stack([np.cos(ang), np.sin(ang)])
    seg = render.Segments(np.zeros(n, np.int64), a, b, np.zeros(n), np.zeros(n))
    fr = cells.layout.frames
    seg = render.Segments(seg.face, fr.to_2d(seg.face, np.column_stack([a, np.zeros(n)])),
                          fr.to_2d(seg.face, np.column_stack([b, np.zeros(n)])), seg.wa, seg.wb)
    radius = cs * rng.uniform(0.7, 12.0, n)
    piece, mx, my = render._pairs(render._row_spans(seg, radius, cells, k, cs))
    got = set(zip(piece.tolist(), mx.tolist(), my.tolist()))
    ref = render._pairs(_every_row_and_column(seg, radius, cells, k, cs))
    p = (np.column_stack([ref[1], ref[2]]) + 0.5) * cs
    d = render._point_segment_distance(p, seg.a[ref[0]], seg.b[ref[0]])
    within = d < radius[ref[0]]
    want = set(zip(*(v[within].tolist() for v in ref)))
    assert len(want) > 20_000 and want <= got
    assert len(got) < 1.5 * len(want)                  # the scan follows the capsule, not the box


def test_texture_changes_only_in_cracked_cells_and_shows_the_lower_layer():
    state = flat_state([[-0.45, -0.3, 0.004, -0.1, 0.05, 0.06, 0.45, 0.35, 0.01]])
    sc = state.get("cells")
    RenderCracks(k=6, profile="constant").step(state)
    cracked = np.asarray(sc["crack__coverage"])
    with_cracks = texel_colors(sc)
    sc.add_field("crack__coverage", np.zeros_like(cracked), at="cell", units="1")
    without = texel_colors(sc)
    changed = np.any(with_cracks != without, axis=-1)
    np.testing.assert_array_equal(changed, cracked > 0)
    full = cracked >= 1.0 - 1e-6
    assert full.sum() > 10
    np.testing.assert_allclose(with_cracks[full], np.broadcast_to(GREEN, (int(full.sum()), 3)), atol=1e-6)
    np.testing.assert_allclose(without[full].mean(0), CREAM, atol=0.05)


def test_mirror_bands_lie_on_the_far_side_from_the_light_and_swap_with_it():
    """A crack along y on a z-up plane; a sun at azimuth 0 (towards +x) elevation 40 degrees."""
    state = flat_state([[0.02, -0.4, 0.003, 0.02, 0.4, 0.003]], size=0.05)
    sc = state.get("cells")
    assert np.all(np.cross(sc.vertices[1] - sc.vertices[0], sc.vertices[2] - sc.vertices[0])[2] > 0)
    x = micro_centres(sc, 8)[..., 0]
    rule = CrackMirror(k=8, lights=[[0.0, 40.0], [180.0, 40.0], [0.0, -40.0]], depth=2.0)
    bands = []
    for it in range(3):
        state.iteration = it
        rule.step(state)
        bands.append((np.asarray(sc["crack__shadow"]).copy(), np.asarray(sc["crack__highlight"]).copy()))
    shadow, light = bands[0]
    assert shadow.sum() > 0 and light.sum() > 0
    cs = sc.size / 8
    assert np.all(x[shadow > 0] < 0.02 + 0.75 * cs) and np.all(x[light > 0] > 0.02 - 0.75 * cs)
    assert np.average(x, weights=shadow) < 0.02 - cs < 0.02 + cs < np.average(x, weights=light)
    # the mirror-image light swaps the sides exactly (plate 5.11 (a) vs (c))
    np.testing.assert_array_equal(bands[1][0] > 0, bands[0][1] > 0)
    np.testing.assert_array_equal(bands[1][1] > 0, bands[0][0] > 0)
    # a light under the plane: the facet is back-lit, no mirror
    assert bands[2][0].sum() == 0 and bands[2][1].sum() == 0
    # band reach: thickness 0.6 x depth 2 cells, Snell n = 1.5 at 50 degrees from the normal
    d = mirror_offset(np.cos(np.radians(50)), 0.6 * 2 * sc.size, 1.5)
    assert np.all(np.abs(x[shadow > 0] - 0.02) < d + 0.003 + sc.size / 8)


def test_cheap_mirror_offset_stays_below_the_thickness_and_is_monotone():
    cos_in = np.cos(np.linspace(0, np.pi / 2 - 1e-6, 200))
    d = mirror_offset(cos_in, 0.7, 1.5, "damped")
    assert np.all(d >= 0) and np.all(d < 0.7) and np.all(np.diff(d) > 0)
    snell = mirror_offset(cos_in, 0.7, 1.5, "snell")
    assert np.all(np.diff(snell) > 0) and snell[-1] == pytest.approx(0.7 / np.sqrt(1.5 ** 2 - 1), rel=1e-4)


def cube_state() -> State:
    """A unit cube with one crack across the top face, over the edge and down the -x side."""
    box = trimesh.creation.box(extents=(1, 1, 1))
    v, f = np.asarray(box.vertices), np.asarray(box.faces)
    state = State(seed=3)
    sc = stacked(v, f, 0.05)
    state.add_domain("cells", sc)
    # trimesh's box: facet 4 is the top's y > x half, facet 0 the -x side's z > y half
    assert np.allclose(box.face_normals[[4, 0]], [[0, 0, 1], [-1, 0, 0]])
    pts = np.array([[-0.1, 0.3, 0.5], [-0.3, 0.2, 0.5], [-0.5, 0.1, 0.5], [-0.5, -0.1, 0.2]])
    face = np.array([4, 4, 0, 0])
    paths = Polylines(pts[:4], np.array([0, 4]))
    paths.add_field("crack__width", np.array([0.004, 0.01, 0.02, 0.006]), at="point", units="length")
    paths.add_field("crack__face", face[:4], at="point", units="")
    paths.add_field("crack__layer", np.array([1]), at="line", units="")
    paths.add_field("crack__type", np.array([0]), at="line", units="")
    state.add_domain("cracks", paths)
    return state


def test_mirror_only_on_front_lit_facets_of_a_cube():
    state = cube_state()
    sc = state.get("cells")
    RenderCracks(k=4).step(state)
    CrackMirror(k=4, lights=[[0.0, 35.0]], depth=3.0).step(state)      # lights the top and +x
    normal = trimesh.Trimesh(sc.vertices, sc.faces, process=False).face_normals[sc.face]
    shadow = np.asarray(sc["crack__shadow"]).reshape(sc.n_cells, -1).max(1)
    cov = np.asarray(sc["crack__coverage"]).reshape(sc.n_cells, -1).max(1)
    assert (cov[normal[:, 0] < -0.9] > 0).any() and (cov[normal[:, 2] > 0.9] > 0).any()
    assert (shadow[normal[:, 2] > 0.9] > 0).any()
    assert np.all(shadow[normal[:, 0] < -0.9] == 0)                  # the -x side is back-lit


def test_textured_obj_and_glb_load_in_trimesh_with_the_cracks_in_the_atlas(tmp_path: Path):
    state = cube_state()
    sc = state.get("cells")
    RenderCracks(k=4).step(state)
    files = crack_obj(sc, stem="cube")
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    obj = trimesh.load(tmp_path / "cube.obj", process=False)
    glb = trimesh.load(io.BytesIO(crack_glb(sc)), file_type="glb")
    glb = glb.to_geometry() if hasattr(glb, "to_geometry") else glb.dump(concatenate=True)
    for m in (obj, glb):
        assert m.visual.kind == "texture" and len(m.visual.uv) == len(m.vertices)
        mat = m.visual.material
        img = getattr(mat, "image", None) or mat.baseColorTexture
        img = np.asarray(img.convert("RGB"), float) / 255
        greenish = (img[..., 1] > img[..., 0] + 0.2).sum()          # the ceramic in the cracks
        assert greenish > 20


def test_svg_sheet_has_one_path_per_segment_with_the_crack_widths(tmp_path: Path):
    import cairosvg
    import vpype

    state = cube_state()
    CrackSheet().step(state)
    sheet = state.get("crack_sheet")
    layer = np.asarray(sheet["crack__layer"])
    assert (layer >= 0).sum() == 2                 # the crack cut at the top/side patch border
    assert (layer < 0).sum() == 8                  # two square panels' outlines
    svg = crack_svg(sheet, background=None)        # (a background rect would be one more line)
    path = tmp_path / "cracks.svg"
    path.write_bytes(svg)
    doc = vpype.read_svg_by_attributes(str(path), ["stroke-width"], quantization=0.001)
    assert sum(len(lc) for lc in doc.layers.values()) == 3 + 8
    by_width = {lc.metadata["svg_stroke-width"]: len(lc) for lc in doc.layers.values()}
    # segment means of the point widths 0.004, 0.01, 0.02, 0.006 (model units), then the hairlines
    assert {w: by_width.get(w) for w in ("0.007", "0.015", "0.013")} == {"0.007": 1, "0.015": 1, "0.013": 1}
    assert sorted(by_width.values()) == [1, 1, 1, 8]
    png = cairosvg.svg2png(bytestring=svg, output_width=300)
    img = np.asarray(Image.open(io.BytesIO(png)).convert("L"))
    assert (img < 100).sum() > 50                    # dark crack strokes are drawn


def test_rendering_is_deterministic():
    outs = []
    for _ in range(2):
        state = cube_state()
        RenderCracks(k=4, profile="u_parabolic_a").step(state)
        CrackMirror(k=4, lights=[[20.0, 50.0]]).step(state)
        CrackSheet().step(state)
        sc = state.get("cells")
        outs.append((sc["crack__coverage"].tobytes(), sc["crack__shadow"].tobytes(),
                     crack_glb(sc), crack_svg(state.get("crack_sheet"))))
    assert outs[0] == outs[1]


def test_drawn_paths_follow_the_contract():
    state = flat_state([[-0.45, -0.3, 0.004, -0.1, 0.05, 0.03, 0.45, 0.35, 0.01]])
    sc, paths = state.get("cells"), state.get("cracks")
    pts, face = np.asarray(paths.points), np.asarray(paths["crack__face"])
    assert len(pts) == 4                            # 3 given points + the diagonal crossing
    mid = 0.5 * (pts[:-1] + pts[1:])
    bc = trimesh.triangles.points_to_barycentric(sc.vertices[sc.faces[face[:-1]]], mid)
    assert np.all(bc > -1e-9)                       # every segment inside its facet
    assert face[-1] == face[-2]


def test_stress_flowers_point_along_the_strong_axis_and_grow_with_the_intensity():
    from procgen_cracks.sheet import stress_flowers

    state = flat_state([[-0.4, 0.0, 0.01, 0.4, 0.0, 0.01]], size=0.05)
    sc = state.get("cells")
    spec = np.zeros((sc.n_cells, 4))
    spec[:, 2] = np.linspace(1.0, 9.0, sc.n_cells)          # tension along the frame's y axis
    spec[:, 0] = 1.0
    every = 3
    fl = stress_flowers(sc, spec, every=every)
    picked = np.nonzero(np.all(sc.ij % every == 0, axis=1) & sc.comp_in)[0]
    closed = np.asarray(fl.closed)
    assert closed.sum() == len(picked) and (~closed).sum() == 4     # flowers, then the square's edges
    stars = np.asarray(fl.points)[:16 * len(picked)].reshape(len(picked), 16, 2)
    centre = stars.mean(axis=1)                              # the stars are centrally symmetric
    r = np.linalg.norm(stars - centre[:, None], axis=2)
    tips = r[:, 0::2]                                        # 8 petals: axes 0..3, then opposites
    np.testing.assert_allclose(tips[:, :4], tips[:, 4:], rtol=1e-9)     # central symmetry
    assert np.all(tips[:, 2] >= tips[:, 0])                  # the strong axis has the long petal
    order = np.argsort(spec[picked, 2])
    assert np.all(np.diff(tips[order, 2]) >= -1e-12)         # longer with more tension
