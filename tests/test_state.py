"""State: save/load round trip, per-rule random streams, reproducibility."""
from __future__ import annotations

import numpy as np

from procgen import Grid, PointSet, Polylines, State, TriMesh
from procgen.recipes import check_recipe
from procgen.runner import run
from procgen.testing import state_arrays


def test_save_load_round_trip(tmp_path):
    st = State(seed=5)
    g = Grid((3, 4), spacing=0.5, origin=(1.0, 2.0), layers=("metal", "oxide"))
    g.add_field("layer__thickness", np.arange(24, dtype=float).reshape(3, 4, 2), at="cell", units="mm", doc="t")
    st.add_domain("g", g)
    m = TriMesh([[0, 0, 0], [1, 0, 0], [0, 1, 0], [0, 0, 1]], [[0, 1, 2], [0, 3, 1]])
    m.add_field("cell__state", np.array([1, 2], np.int8), at="face")
    m.add_field("surface__texture", np.zeros((4, 4, 3), np.uint8), at="domain")
    st.add_domain("m", m)
    st.add_domain("p", PointSet(np.random.default_rng(0).random((10, 2)), bounds=(0, 1, 0, 1)))
    st.add_domain("l", Polylines.from_list([np.eye(2), np.ones((3, 2))], closed=[True, False]))
    st.report("N_s", np.int64(42))
    st.save(tmp_path / "s.npz")
    back = State.load(tmp_path / "s.npz")
    assert back.seed == 5 and back.reports == {"N_s": 42}
    a, b = state_arrays(st), state_arrays(back)
    assert a.keys() == b.keys()
    for k in a:
        assert a[k].dtype == b[k].dtype and np.array_equal(a[k], b[k])
    assert back.get("g").layers == ("metal", "oxide")
    assert back.get("g").field_info("layer__thickness").units == "mm"
    # equal states give equal bytes (no timestamps in the archive)
    st.save(tmp_path / "t.npz")
    assert (tmp_path / "s.npz").read_bytes() == (tmp_path / "t.npz").read_bytes()


def test_rng_depends_on_step_and_rule_not_on_other_params():
    st = State(seed=3)
    st.step_index, st.rule_name, st.iteration = 2, "a.b", 0
    x = st.rng().random(4)
    assert np.array_equal(x, st.rng().random(4))
    st.iteration = 1
    assert not np.array_equal(x, st.rng().random(4))
    st.iteration, st.rule_name = 0, "a.c"
    assert not np.array_equal(x, st.rng().random(4))


def test_changing_one_step_does_not_reshuffle_another(host):
    def recipe(r0):
        return check_recipe({"steps": [
            {"rule": "grid.noise", "params": {"grid": "a", "nx": 16, "ny": 16, "hurst": r0}},
            {"rule": "grid.noise", "params": {"grid": "b", "nx": 16, "ny": 16}}]}, host)

    s1 = run(recipe(0.5), host, seed=9).state
    s2 = run(recipe(0.9), host, seed=9).state
    assert not np.array_equal(s1.get("a")["surface__height"], s2.get("a")["surface__height"])
    assert np.array_equal(s1.get("b")["surface__height"], s2.get("b")["surface__height"])
    s3 = run(recipe(0.9), host, seed=10).state
    assert not np.array_equal(s2.get("b")["surface__height"], s3.get("b")["surface__height"])
