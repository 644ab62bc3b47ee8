"""The compiled drop step (procgen_water.kernels) against the numpy reference, bit for bit."""
from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pytest

from procgen.errors import InputError
from procgen_water import particles as P

from test_water_particles import _capacity_case, _thesis_case

SURFACE = ("thickness", "held", "deposit", "emitted", "evaporated", "drained", "drained_sediment", "path")
DROPS = ("pos", "vel", "volume", "sediment", "kind", "moving", "age")


def _run(case, accelerate, steps: int = 25, continued: bool = True, check=None):
    """``steps`` steps from ``case``; ``accelerate`` a bool or, per step, a function of it;
    ``continued`` after the first step (as the rule does: nothing else writes the surface);
    ``check(s, d)`` after each step."""
    s, d, p = case
    s, d = copy.deepcopy(s), copy.deepcopy(d)
    for it in range(steps):
        if it == 8:
            d = d.concat(P.emit(s, p, np.random.default_rng(it), 80, "top", 0.2))
        acc = accelerate(it) if callable(accelerate) else accelerate
        d = P.step(s, d, p, accelerate=acc, continued=continued and it > 0)
        cells = P._cell_of(d.pos, s.shape)
        assert np.all(cells[1:] >= cells[:-1]), it          # the canonical (cell) order
        if check is not None:
            check(s, d)
    return s, d


def _spaced(case, spacing):
    s, d, p = case
    s.spacing = spacing            # (the kernels multiply by 1 / spacing when it is a power of 2)
    return s, d, p


def _with(case, **params):
    s, d, p = case
    return s, d, dataclasses.replace(p, **params)


CASES = {
    "thesis": lambda: _thesis_case()[:3],
    "thesis-capacity": lambda: _with(_thesis_case()[:3], sediment_capacity=2.0),
    "thesis-spacing-0.7": lambda: _spaced(_thesis_case()[:3], 0.7),
    "thesis-spacing-0.5": lambda: _spaced(_thesis_case()[:3], 0.5),
    "thesis-dry-fast": lambda: _thesis_case(evaporation=0.05, threshold=0.0)[:3],
    "capacity-cell": lambda: _capacity_case(footprint="cell")[:3],
    "capacity-bilinear": lambda: _capacity_case(footprint="bilinear")[:3],
    "capacity-disc-fade": lambda: _capacity_case(footprint="disc", fade=True)[:3],
}


@pytest.mark.parametrize("name", sorted(CASES))
def test_compiled_step_equals_numpy_step_exactly(name):
    case = CASES[name]()
    s0, d0 = _run(case, False)
    s1, d1 = _run(case, True)
    assert len(d0) == len(d1) and len(d0) > 0
    for f in DROPS:
        np.testing.assert_array_equal(getattr(d1, f), getattr(d0, f), err_msg=f)
    for f in SURFACE:
        np.testing.assert_array_equal(getattr(s1, f), getattr(s0, f), err_msg=f)
    assert s0.deposit.sum() > 0 and (s0.held.sum() > 0 or name.startswith("capacity"))   # phases run


def _assert_same(a, b):
    (s0, d0), (s1, d1) = a, b
    for f in DROPS:
        np.testing.assert_array_equal(getattr(d1, f), getattr(d0, f), err_msg=f)
    for f in SURFACE:
        np.testing.assert_array_equal(getattr(s1, f), getattr(s0, f), err_msg=f)


@pytest.mark.parametrize("name", ["thesis", "capacity-cell"])
def test_continued_steps_agree_with_the_full_pass(name):
    """With ``continued`` the compiled step recomputes height and excess water only at the cells
    the last step's drops were in; that must give the full pass's numbers, also when the paths
    alternate (after a numpy step the compiled cache is stale and must not be used)."""
    case = CASES[name]()
    ref = _run(case, False)
    _assert_same(ref, _run(case, True, continued=False))
    _assert_same(ref, _run(case, True))
    _assert_same(ref, _run(case, lambda it: it % 3 != 1))


def test_continued_step_really_skips_the_grid_pass():
    """A poisoned cached height where no drop was survives a continued step (so that step read
    the grid only at the last step's cells) and is gone after a step that is not continued."""
    from procgen_water import kernels as K
    s, d, p = copy.deepcopy(CASES["thesis"]())
    d = P.step(s, d, p, accelerate=True)
    h = s.__dict__[K._ATTR].h
    dry = np.flatnonzero(s.held.sum(axis=1) == 0)            # (a drop emptied here wet it)
    empty = np.setdiff1d(dry, P._cell_of(d.pos, s.shape))[:5]
    assert empty.size == 5
    h[empty] = np.nan
    d = P.step(s, d, p, accelerate=True, continued=True)
    assert np.isnan(h[empty]).all()
    P.step(s, d, p, accelerate=True, continued=False)
    assert np.isfinite(h).all()


def test_continued_is_a_promise_other_writers_must_not_break():
    """Without ``continued`` an outside change of the layers (another rule thinning one) is seen
    at the next step on both paths alike."""
    case = CASES["capacity-cell"]()

    def thinned(accelerate):
        s, d, p = copy.deepcopy(case)
        for it in range(6):
            if it == 3:
                s.thickness[:, -1] *= 0.5          # water above the new capacity is released
            d = P.step(s, d, p, accelerate=accelerate, continued=it not in (0, 3))
        return s, d
    a, b = thinned(False), thinned(True)
    _assert_same(a, b)


@pytest.mark.parametrize("name", ["thesis", "capacity-cell"])
def test_compiled_step_on_two_threads_equals_numpy_step_exactly(name, monkeypatch):
    """The one-cell footprint's interaction split into chunks of whole cells (one per thread,
    here even for a few drops), the grid passes and the drops' loops over numba's threads."""
    numba = pytest.importorskip("numba")
    from procgen_water import kernels as K
    monkeypatch.setattr(K, "_MIN_CHUNK", 1)
    case = CASES[name]()
    s0, d0 = _run(case, False)
    before = numba.get_num_threads()
    numba.set_num_threads(min(2, numba.config.NUMBA_NUM_THREADS))
    try:
        s1, d1 = _run(case, True)
        chunks = s1.__dict__[K._ATTR].chunks
    finally:
        numba.set_num_threads(before)
    if numba.config.NUMBA_NUM_THREADS >= 2:
        assert 0 < chunks[1] < chunks[2]               # the last step really ran in two chunks
    for f in DROPS:
        np.testing.assert_array_equal(getattr(d1, f), getattr(d0, f), err_msg=f)
    for f in SURFACE:
        np.testing.assert_array_equal(getattr(s1, f), getattr(s0, f), err_msg=f)


@pytest.mark.parametrize("threads", [1, 2])
@pytest.mark.parametrize("name", ["thesis", "thesis-spacing-0.7", "thesis-dry-fast", "thesis-capacity"])
def test_listed_evaporation_equals_numpy_step_exactly(name, threads, monkeypatch):
    """A continued step evaporates only the cells the last step listed (those holding water or a
    drop) once they are fewer than 1 / _SPARSE of the grid; here from the second step on, on one
    thread and on two.  After every step the list holds each wet cell and each drop's cell,
    once, in order, and the numbers are the numpy step's."""
    numba = pytest.importorskip("numba")
    from procgen_water import kernels as K
    monkeypatch.setattr(K, "_SPARSE", 0.2)       # (wet layers + drops counted: 4 per cell at most)
    monkeypatch.setattr(K, "_MIN_CHUNK", 1)
    listed = []

    def check(s, d):
        work = s.__dict__[K._ATTR]
        listed.append(int(work.nwet[0]))
        if work.nwet[0] >= 0:
            cells = work.wet[:work.nwet[0]]
            assert np.all(np.diff(cells) > 0)
            must = np.union1d(np.flatnonzero(s.held.sum(axis=1) > 0), P._cell_of(d.pos, s.shape))
            assert np.isin(must, cells).all()

    case = CASES[name]()
    ref = _run(case, False)
    before = numba.get_num_threads()
    numba.set_num_threads(min(threads, numba.config.NUMBA_NUM_THREADS))
    try:
        got = _run(case, True, check=check)
    finally:
        numba.set_num_threads(before)
    _assert_same(ref, got)
    assert all(n >= 0 for n in listed)                         # the listed pass really ran


def test_listed_evaporation_visits_only_the_listed_cells(monkeypatch):
    """Water put behind the step's back into a dry cell off the list stays through a continued
    step (the step did not visit the cell) and evaporates in a step that is not continued."""
    from procgen_water import kernels as K
    monkeypatch.setattr(K, "_SPARSE", 0.2)
    s, d, p = copy.deepcopy(CASES["thesis"]())
    d = P.step(s, d, p, accelerate=True)
    work = s.__dict__[K._ATTR]
    assert work.nwet[0] >= 0
    near = np.zeros(s.shape, bool)                 # the drops' cells and their neighbours
    iy, ix = np.unravel_index(P._cell_of(d.pos, s.shape), s.shape)
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            near[np.clip(iy + dy, 0, s.shape[0] - 1), np.clip(ix + dx, 0, s.shape[1] - 1)] = True
    off = np.setdiff1d(np.flatnonzero(~near), work.wet[:work.nwet[0]])[:2]
    assert off.size == 2 and not s.held[off].any()
    s.held[off, 0] = 1e-6
    d = P.step(s, d, p, accelerate=True, continued=True)
    assert (s.held[off, 0] == 1e-6).all()
    P.step(s, d, p, accelerate=True, continued=False)
    assert (s.held[off, 0] < 1e-6).all()


@pytest.mark.parametrize("footprint", ["cell", "disc"])
def test_crowds_leaving_the_grid_drain_as_on_the_numpy_path(footprint):
    """Drops of one cell that leave in one step are summed into that cell's drained water and
    sediment in drop order (as np.bincount): crowds of different volumes and loads at the edge
    cells, every step of which loses some, give numpy's ledgers bit for bit."""
    s, d, p = _with(CASES["capacity-cell"](), footprint=footprint)
    rng = np.random.default_rng(4)
    k = len(d)
    edge = rng.integers(0, 3, k)                            # three cells on the right edge
    d.pos[:, 0] = s.shape[1] - 1 + rng.uniform(0.2, 0.95, k)
    d.pos[:, 1] = 5.5 + 6 * edge
    d.vel[:, 0] = rng.uniform(-0.5, 2.0, k)                 # most leave, at different steps
    d.volume *= rng.uniform(0.5, 1.5, k)
    d.sediment[:] = rng.uniform(0, 0.01, k)
    d.kind[:] = 0
    d.moving[:] = True
    runs = [_run((s, d, p), acc, steps=6) for acc in (False, True)]
    _assert_same(*runs)
    s0 = runs[0][0]
    cells = (5 + 6 * np.arange(3)) * s.shape[1] + s.shape[1] - 1
    assert s0.drained[cells].all() and s0.drained_sediment[cells].all()
    assert s0.drained[cells].sum() > 0.5 * d.volume.sum()


def test_compiled_step_keeps_no_grid_sized_temporaries_between_steps():
    from procgen_water import kernels as K
    s, d, p = CASES["thesis"]()
    d = P.step(s, d, p, accelerate=True)
    work = s.__dict__[K._ATTR]
    ids = {id(a) for a in (work.sk, work.h, work.counts, work.wet, work.wout)}
    d = P.step(s, d, p, accelerate=True)
    assert ids == {id(a) for a in (work.sk, work.h, work.counts, work.wet, work.wout)}   # (lists swap)
    assert not work.sk[:, 3].any()                # the deposit columns are left at zero
    assert not work.cell_sk[..., 3].any()
    assert work.grid_bytes == s.ncell * K.bytes_per_cell(s.n_layers, p.footprint) + 4    # + 1 sort slot
    ids = [id(a) for a in (work.fa, work.fb, work.kept, work.pairs)]
    d = P.step(s, d, p, accelerate=True)
    assert ids == [id(a) for a in (work.fa, work.fb, work.kept, work.pairs)]


def test_accelerate_true_without_numba_is_one_line_error(monkeypatch):
    import procgen.accel as A
    monkeypatch.setattr(A, "_load", lambda module: None)
    s, d, p = CASES["thesis"]()
    with pytest.raises(InputError, match="fast"):
        P.step(s, d, p, accelerate=True)
    monkeypatch.setenv(A.ENV, "0")
    assert len(P.step(s, d, p)) > 0                         # the switch off: numpy


def test_a_drop_with_sediment_but_no_kind_is_refused_before_any_write():
    """Sediment is laid into its drop's kind layer, so such a drop (not made by a step: erosion
    sets the kind with the first sediment) would lay into no layer; the compiled step says so
    before it writes anything (the release of excess water included)."""
    pytest.importorskip("numba")
    s, d, p = CASES["thesis"]()
    s.held[:] = 2 * s.thickness * s.capacity * s.cell_area   # water to release
    d.sediment[len(d) // 2] = 0.1
    d.kind[len(d) // 2] = -1
    s0, d0 = copy.deepcopy(s), copy.deepcopy(d)
    with pytest.raises(AssertionError, match="no sediment kind"):
        P.step(s, d, p, accelerate=True)
    _assert_same((s0, d0), (s, d))
