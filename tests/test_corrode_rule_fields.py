"""The layers.corrode rule's fields against their recomputation from the kernel's state over the
whole grid (thesis 2.4.1 / App. A states, plate 2.2 maps), on a Grid and on mesh cells, on the
numpy and the compiled path, through a first step and a second one that resumes from the fields:
the fields kept current (state, age, strong, seeded, time and the source ledger) after every
step, the ones copied by ``publish`` (thickness, alive, map, coverage) after a publish that
follows one step or several, and after ``finish``."""
from __future__ import annotations

import numpy as np
import pytest
import trimesh

from procgen import State
from procgen.ca.cells import cell_values
from procgen.domains import Grid
from procgen_layers import corrosion as cz
from procgen_layers.materials import parse_materials
from procgen_layers.rules import Corrode
from procgen_layers.stack import cell_areas, put_thickness, store_table
from procgen_surface.domain import SurfaceCells

PARAMS = dict(consume=["wood", "paint"], product="char", k1=0.004, k2=0.01, k3=0.5, seed_rate=2e-3,
              max_seeds=12, initial_seeds=2, a0=1.2, b0=1.4, strong_fraction=0.3)


def _domain(kind: str):
    if kind == "grid":
        return Grid((40, 50))
    sphere = trimesh.creation.icosphere(subdivisions=2)
    return SurfaceCells.from_mesh(np.asarray(sphere.vertices), np.asarray(sphere.faces), target_cells=2500)


def _check_published(state: State, dom, rule: Corrode, t_start: np.ndarray, ref: dict) -> None:
    """The fields ``publish`` copies, and the coverage curve, against the kernel state."""
    st = rule._st
    t = cell_values(dom, "layers__thickness")
    assert np.array_equal(t[:, rule._cons], st.consumable) and np.array_equal(t[:, rule._prod], st.product)
    other = [i for i in range(t.shape[1]) if i not in rule._cons and i != rule._prod]
    assert np.array_equal(t[:, other], t_start[:, other])
    assert np.array_equal(cell_values(dom, "cell__alive"), st.status != cz.HOLE)
    want_map = np.where(st.status > 0, 1.0 + st.status, 1.0 - st.strong)
    assert cell_values(dom, "corrosion__map").tobytes() == want_map.tobytes()
    cov = state.get("coverage")
    k = len(rule._log.cumulative)
    assert cov.offsets.tolist() == [0, k, 2 * k]
    assert cov.points[:k, 1].tolist() == rule._log.cumulative
    assert cov.points[k:, 1].tolist() == rule._log.per_step
    _check_live(dom, rule, ref)


def _check_live(dom, rule: Corrode, ref: dict) -> None:
    """The fields kept current after every step (no publish) against the kernel state."""
    st = rule._st
    for name, arr in (("corrosion__state", st.status), ("corrosion__age", st.age),
                      ("corrosion__strong", st.strong)):
        assert np.array_equal(cell_values(dom, name), arr)
    assert np.array_equal(cell_values(dom, "corrosion__time"), ref["when"])
    # the ledger, exactly: the whole-grid sum of every step's change (the kernel books it where it thins)
    assert cell_values(dom, "layers__source").tobytes() == ref["source"].tobytes()
    seeded = cell_values(dom, "corrosion__seeded")
    assert seeded.sum() == st.seeds_used and np.all(st.status[seeded] != cz.NORMAL)
    touched = np.count_nonzero(st.status != cz.NORMAL) - (len(st.status) - ref["n0"])
    assert rule._log.cumulative[-1] == 100.0 * (touched / ref["n0"])


def _run_step(state: State, dom, iterations: int, t0: int, publish_at: set[int]) -> cz.CorrosionState:
    """One recipe step of ``iterations``, published after the iterations in ``publish_at`` (as
    the runner does before a frame) and by ``finish``."""
    n = dom.n_cells
    t_start = np.array(cell_values(dom, "layers__thickness"))
    status0 = np.array(cell_values(dom, "corrosion__state")) if "corrosion__state" in dom else np.zeros(n, np.int8)
    rule = Corrode(**PARAMS)
    state.step_index, state.rule_name, state.iteration = 0, rule.name, -1
    rule.setup(state)
    st = rule._st
    ref = {"n0": int(np.count_nonzero(status0 == cz.NORMAL)),
           "source": np.array(cell_values(dom, "layers__source")),
           "when": np.where(status0 != st.status, t0, cell_values(dom, "corrosion__time"))}
    area = cell_areas(dom)
    _check_published(state, dom, rule, t_start, ref)
    for it in range(iterations):
        state.iteration = it
        before, c0, p0 = st.status.copy(), st.consumable.sum(axis=1), st.product.copy()
        going = rule.step(state)
        ref["source"] += (st.consumable.sum(axis=1) - c0 + st.product - p0) * area
        ref["when"][(before == cz.NORMAL) & (st.status == cz.CORRODED)] = t0 + it
        assert going == bool(np.any(st.status != before) or np.any(st.status == cz.CORRODED))
        _check_live(dom, rule, ref)
        if it in publish_at:
            rule.publish(state)
            _check_published(state, dom, rule, t_start, ref)
    rule.finish(state)
    _check_published(state, dom, rule, t_start, ref)
    return st


@pytest.mark.parametrize("kind", ["grid", "mesh"])
@pytest.mark.parametrize("path", ["numpy", "compiled"])
def test_fields_equal_their_recomputation_after_steps_and_publishes(kind, path, monkeypatch):
    if path == "compiled":
        pytest.importorskip("numba")
    monkeypatch.setenv("PROCGEN_ACCELERATE", "1" if path == "compiled" else "0")
    dom = _domain(kind)
    table = parse_materials([{"name": "wood", "color": [0.6, 0.4, 0.3]}, {"preset": "paint"},
                             {"name": "char", "color": [0.1, 0.1, 0.1]}])
    store_table(dom, table)
    n = dom.n_cells
    put_thickness(dom, np.column_stack([np.full(n, 0.05), np.full(n, 0.03), np.zeros(n)]), table)
    state = State(seed=4)
    state.add_domain("cells", dom)
    st = _run_step(state, dom, 30, 0, {0, 1, 2, 9, 17})   # after one step and after several
    assert np.any(st.status == cz.HOLE) and np.any(st.status == cz.CORRODED) and np.any(st.status == cz.NORMAL)
    st = _run_step(state, dom, 20, 30, set())          # resumes from the fields; published by finish only
    assert 0.05 < np.mean(st.status != cz.NORMAL) < 0.95
