"""The wood thesis's result figures (Chidtavong 2007, chapter 4) as the shipped recipes and gallery
entries state them: the thesis's own numbers written once here (Figs 4.3-4.19), the recipes'
rules, steps and texgen planes checked against them, the stand-in meshes and cell grids compared
with its models, Fig. 4.7's link points recomputed independently, and the final table of Fig.
4.17 checked to show a weathering pattern at the thesis's 432 steps."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from procgen.gallery import load_gallery
from procgen.recipes import check_recipe, load_recipe
from procgen.runner import run
from procgen_surface.domain import SurfaceCells
from procgen_wood.links import link_kinds

#: the thesis's models (Figs 4.3-4.6: vertices (a), faces (b), cells (c); 4.6(c) prints
#: "57,1398.00", read as 571,398) and its rules per figure (4.3.3, 4.4)
MODELS = {"bunny": (2503, 4968, 389942), "table": (2372, 4608, 275398),
          "head": (689, 1355, 18978), "elephant": (623, 1148, 571398)}
CA_FIGURES = {"fig-4-8": ("bunny", "25/2356"), "fig-4-9": ("elephant", "25/2356"),
              "fig-4-10": ("head", "25/357"), "fig-4-11": ("table", "25/357"),
              "fig-4-16": ("bunny", "25/2356"), "fig-4-17": ("table", "25/2356"),
              "fig-4-18": ("elephant", "25/357"), "fig-4-19": ("head", "25/357")}
FINAL = ("fig-4-16", "fig-4-17", "fig-4-18", "fig-4-19")          # "CA steps: 432"
GRID_FIGURES = {"fig-4-5": "head", "fig-4-7b": "bunny", "fig-4-7c": "head", "fig-4-7d": "elephant",
                "fig-4-7e": "table"}
MESH_STEPS = {"bunny": {"rule": "mesh.load", "params": {"path": "bunny-4k.obj", "normalize": True}},
              "head": {"rule": "mesh.load", "params": {"path": "spot.obj"}},
              "table": {"rule": "wood.table"}}


def _step(recipe, sid):
    return next(s for s in recipe.steps if s.id == sid)


def _model_of(recipe_name: str) -> str | None:
    if not recipe_name.startswith("weathering/"):
        return None
    name = recipe_name.split("/")[-1]
    return CA_FIGURES.get(name, (GRID_FIGURES.get(name),))[0]


def test_rules_and_steps_are_the_thesiss(host):
    """Each CA figure runs the rule the thesis names for it (the table and the elephant change
    rule between their CA-only and final figures, as printed), in the tables' semantics; the
    final figures run the thesis's 432 CA steps."""
    for name, (_, rule) in CA_FIGURES.items():
        life = _step(load_recipe(f"weathering/{name}", host), "life")
        assert life.params["rule"] == rule and life.params["semantics"] == "table", name
        if name in FINAL:
            assert life.iterations == 432, name


@pytest.mark.parametrize("name, plane", [("fig-4-12", [1, 0, 0, 0]), ("fig-4-13", [0, 1, 0, 0])])
def test_texgen_planes_and_functions_are_the_thesiss(host, name, plane):
    """Figs 4.12 and 4.13: reference planes (1, 0, 0, 0) and (0, 1, 0, 0), panels a-c with
    f = x^2 - y^2, x^2 and cos(3.14 x); Fig. 4.14: the sphere map with f = x^2 + y^2."""
    rec = load_recipe(f"weathering/{name}", host)
    assert [float(x) for x in rec.steps[3].params["plane_s"]] == plane
    assert rec.steps[3].params["mode"] == "object_linear"
    panels = {e.figure[-1]: e for e in load_gallery(host) if e.recipe == f"weathering/{name}"}
    assert sorted(panels) == ["a", "b", "c"]
    rings = {k: e.set.get("steps.grain.params.ring", rec.steps[2].params["ring"]) for k, e in panels.items()}
    assert rings == {"a": "x2_minus_y2", "b": "x2", "c": "cos_pi_x"}
    from procgen_wood.grain import RINGS
    x = np.array([0.5, -1.0])
    assert np.allclose(RINGS["cos_pi_x"](x, x), np.cos(3.14 * x))
    sph = load_recipe("weathering/fig-4-14", host)
    assert sph.steps[3].params["mode"] == "sphere_map" and sph.steps[2].params["ring"] == "circle"


def test_gallery_thesis_tables_hold_the_thesiss_numbers(host):
    """Every entry drawn on one of the thesis's four models shows that model's face and cell
    counts beside ours (mesh.n_faces, cells.n_cells), except the texture-only figures, which
    have no CA grid and show the faces only."""
    seen = set()
    for e in load_gallery(host):
        model = _model_of(e.recipe)
        if e.recipe in ("weathering/fig-4-12", "weathering/fig-4-13"):
            assert e.thesis == {"mesh.n_faces": MODELS["bunny"][1]}, e.slug
        elif e.recipe == "weathering/fig-4-14":
            assert e.thesis == {"mesh.n_faces": MODELS["table"][1]}, e.slug
        elif model is not None:
            _, faces, cells = MODELS[model]
            assert e.thesis.get("mesh.n_faces") == faces and e.thesis.get("cells.n_cells") == cells, e.slug
            seen.add(e.recipe)
    assert {f"weathering/{n}" for n in (*CA_FIGURES, *GRID_FIGURES)} <= seen


def test_final_and_link_figures_quote_the_thesiss_times(host):
    """Figs 4.16-4.19 state a rendering time, Figs 4.5 and 4.7(b)-(e) a computing and drawing
    time: each entry quotes its figure's beside our run time."""
    want = {"weathering/fig-4-16": "less than 7 minutes", "weathering/fig-4-17": "less than 6 minutes",
            "weathering/fig-4-18": "less than 10 minutes", "weathering/fig-4-19": "less than 6 minutes",
            "weathering/fig-4-5": "less than 2 minutes"}
    want |= {f"weathering/fig-4-7{k}": "less than 0.5 minutes" for k in "bcde"}
    entries = [e for e in load_gallery(host) if e.recipe in want]
    assert {e.recipe for e in entries} == set(want)
    for e in entries:
        assert e.thesis_time == want[e.recipe], e.slug


def _mesh(host, model: str):
    """The stand-in as its recipes load it (mesh.load cleans: coincident vertices welded)."""
    step = MESH_STEPS.get(model) or {"rule": "mesh.load", "params": {
        "path": str(load_recipe("weathering/fig-4-9", host).base_dir / "elephant.obj")}}
    return run(check_recipe({"steps": [step]}, host), host, progress=False).state.get("mesh")


@pytest.mark.parametrize("model", sorted(MODELS))
def test_stand_in_meshes_compare_with_the_thesiss_models(host, model):
    """The stand-ins are triangle meshes of the same kind as the thesis's: vertices per face
    within 0.05 of its models' (Figs 4.3-4.6 (a)/(b); 0.50 is a closed surface, its models run
    a little above, having open edges or duplicated vertices).  The elephant is built at the
    thesis's size: faces within 1 % of its 1,148."""
    v, f, _ = MODELS[model]
    m = _mesh(host, model)
    assert abs(m.n_vertices / m.n_faces - v / f) < 0.05, (m.n_vertices, m.n_faces)
    if model == "elephant":
        assert abs(m.n_faces - f) <= 0.01 * f


def test_fig_4_5_head_grid_has_the_thesiss_cells_per_triangle(host):
    """Fig. 4.5: the head's 18,978 cells on 1,355 faces are 14.0 cells per triangle; the head
    stand-in (Spot, the grid of Figs 4.10 and 4.19 too) keeps that within 5 %, and its vertices
    outnumber the head's 689 in about the ratio its faces outnumber the head's faces."""
    v, f, cells = MODELS["head"]
    rep = run(load_recipe("weathering/fig-4-5", host), host, progress=False).state
    r = rep.reports
    assert abs(r["cells.n_cells"] / r["mesh.n_faces"] / (cells / f) - 1) < 0.05
    m = rep.get("mesh")
    assert abs((m.n_vertices / v) / (m.n_faces / f) - 1) < 0.05
    for name in ("fig-4-10", "fig-4-19", "fig-4-7c"):
        assert _step(load_recipe(f"weathering/{name}", host), "cells").params["target_cells"] == \
            _step(load_recipe("weathering/fig-4-5", host), "cells").params["target_cells"], name


def test_fig_4_7_draws_the_thesiss_pairs_on_the_ca_figures_grids(host):
    """Fig. 4.7(b)-(e) link the cells of the grids the CA figures run on, by the thesis's
    nearest-projection pairs (Programming2)."""
    grids = {"b": "fig-4-8", "c": "fig-4-10", "d": "fig-4-9", "e": "fig-4-11"}
    for k, ca in grids.items():
        cells = _step(load_recipe(f"weathering/fig-4-7{k}", host), "cells").params
        assert cells["neighbours"] == "pairs"
        assert cells["target_cells"] == _step(load_recipe(f"weathering/{ca}", host), "cells").params["target_cells"]


def _direct_kinds(sc: SurfaceCells):
    """Per-cell partner count and kind by walking the cross-edge entries one by one."""
    g = sc.graph
    count = np.zeros(sc.n_cells, int)
    per_face: dict[tuple[int, int], int] = {}
    links = set()
    for row, col, cross in zip(g.rows.tolist(), g.indices.tolist(), g.cross.tolist()):
        if cross:
            count[row] += 1
            key = (row, int(sc.face[col]))
            per_face[key] = per_face.get(key, 0) + 1
            links.add((min(row, col), max(row, col)))
    kind = np.where(count > 0, 1, 0)
    for (row, _), n in per_face.items():
        if n >= 2:
            kind[row] = 2
    return count, kind, len(links)


@pytest.mark.parametrize("neighbours", ["pairs", "unfold", "none"])
def test_link_points_match_a_direct_count(neighbours):
    s = trimesh.creation.icosphere(2)
    sc = SurfaceCells.from_mesh(s.vertices, s.faces, target_cells=4000, neighbours=neighbours)
    count, kind, n_links = link_kinds(sc.graph, np.asarray(sc.face))
    c2, k2, n2 = _direct_kinds(sc)
    assert np.array_equal(count, c2) and np.array_equal(kind, k2) and n_links == n2
    if neighbours == "none":
        assert n_links == 0 and not kind.any()
    if neighbours == "pairs":
        # the thesis's pairs are taken both ways: each link is two entries, and both ends linked
        assert 2 * n_links == int(sc.graph.cross.sum())
        g = sc.graph
        assert np.all(kind[g.indices[g.cross]] > 0)


def test_received_twice_is_negligible_for_a_small_enough_grid():
    """Thesis 3.4.3 (Fig. 3.26): at the ends of an edge "some cells will receive information
    twice", an effect that "can be negligible if the size of grid is small enough": the share of
    cells paired twice with one triangle falls as the cells get smaller, as does the share of
    linked cells (edge cells per cell go as one over the cells per side)."""
    s = trimesh.creation.icosphere(2)
    shares = []
    for n in (3000, 12000, 48000):
        sc = SurfaceCells.from_mesh(s.vertices, s.faces, target_cells=n, neighbours="pairs")
        _, kind, _ = link_kinds(sc.graph, np.asarray(sc.face))
        shares.append((np.mean(kind > 0), np.mean(kind == 2)))
    linked, twice = np.array(shares).T
    assert np.all(np.diff(linked) < 0) and np.all(np.diff(twice) < 0)
    assert twice[-1] < 0.5 * twice[0]
    # four times the cells halve the cells per side, so about halve the linked share
    assert 0.4 < linked[2] / linked[1] < 0.65


def test_fig_4_7_reports_match_the_rule(host):
    """The head's link drawing at the gallery's quick size: the reports are the rule's counts,
    and at the thesis's head resolution (14 cells per triangle) most cells are linked."""
    st = run(load_recipe("weathering/fig-4-7c", host, ["steps.cells.params.target_cells=20000"]), host,
             progress=False).state
    sc = st.get("cells")
    count, kind, n_links = link_kinds(sc.graph, np.asarray(sc.face))
    r = st.reports
    assert r["cells.links.n_links"] == n_links
    assert r["cells.links.linked_fraction"] == pytest.approx(np.mean(kind > 0))
    assert r["cells.links.twice_fraction"] == pytest.approx(np.mean(kind == 2))
    assert r["cells.links.linked_fraction"] > 0.5
    assert np.array_equal(np.asarray(sc["links__count"]), count)


def test_final_table_shows_a_weathering_pattern_not_one_colour(host):
    """Fig. 4.17 at the thesis's 432 steps and full size: with the sparse live start the cells
    spread over several palette ranges; the dense start it had (a live share of 0.01) left over
    99 % of them in the last range, a uniform table."""
    from procgen_wood.palette import THRESHOLDS, palette_index

    result = run(load_recipe("weathering/fig-4-17", host), host, progress=False)
    k = palette_index(np.asarray(result.state.get("cells")["ca__age"]), np.asarray(THRESHOLDS))
    share = np.bincount(k, minlength=len(THRESHOLDS)) / k.size
    assert share.max() < 0.7, share
    assert (share >= 0.04).sum() >= 3, share
