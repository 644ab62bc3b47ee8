"""One field vocabulary: every declared field is in docs/fields.md, with one unit everywhere."""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np
import pytest

from procgen import FieldSpec, Grid, RecipeError, RuleBase, get_plugin_manager, param
from procgen.plugins import plugin_module
from procgen.recipes import check_recipe
from procgen.testing import (check_rule_contract, field_vocabulary_problems, read_field_vocabulary,
                             undeclared_writes)

DOCS = Path(__file__).resolve().parents[1] / "docs" / "fields.md"
VOCABULARY = read_field_vocabulary(DOCS)


def _rule(rule_name: str, field: str, units: str, intent: str = "out", write: str | None = None):
    @dataclass(kw_only=True)
    class Writer(RuleBase):
        """Writes one field of a grid (test rule)."""

        name: ClassVar[str] = rule_name
        uses: ClassVar[dict[str, str]] = {"g": "Grid"}
        fields: ClassVar[tuple] = (FieldSpec(field, "g", "cell", intent, units=units),)
        k: float = param(1.0, ge=0.0, doc="value written")

        def step(self, state):
            g = state.get("g", Grid)
            for name in {field, write or field}:
                g.add_field(name, np.full(g.shape, self.k), at="cell", units=units)
            return True

    return Writer


def test_the_vocabulary_lists_the_core_names():
    assert VOCABULARY["layers__thickness"] == "length"
    assert VOCABULARY["corrosion__state"] == "" and VOCABULARY["surface__color"] == "rgb"
    assert len(VOCABULARY) > 50


def test_every_registered_rule_speaks_the_vocabulary():
    host = get_plugin_manager()
    assert field_vocabulary_problems(host.rules.values(), VOCABULARY) == []


def test_two_rules_declaring_one_name_with_two_units_are_caught():
    a = _rule("test.metres", "water__depth", "length")
    b = _rule("test.litres", "water__depth", "volume")
    problems = field_vocabulary_problems([a, b], VOCABULARY)
    assert any("test.litres declares 'volume'" in p for p in problems)
    assert any("not in the field vocabulary" in p for p in
               field_vocabulary_problems([_rule("test.new", "foo__bar", "m")], VOCABULARY))


def test_procgen_check_refuses_one_field_in_two_units():
    a = _rule("test.metres", "water__depth", "length")
    b = _rule("test.litres", "water__depth", "volume", intent="inout")
    host = get_plugin_manager([plugin_module("units", procgen_register_rules=lambda: [a, b])])
    steps = [{"rule": "grid.noise", "params": {"grid": "g", "nx": 8, "ny": 8}},
             {"rule": "test.metres"}, {"rule": "test.litres"}]
    with pytest.raises(RecipeError) as err:
        check_recipe({"steps": steps}, host, "r.toml")
    msg = str(err.value)
    assert "\n" not in msg and "steps[2] (test.litres)" in msg
    assert "'water__depth' on 'g' is declared in 'volume' here but in 'length' by r.toml: steps[1]" in msg


def test_the_contract_fails_a_rule_writing_an_undeclared_field():
    sneaky = _rule("test.sneaky", "water__depth", "length", write="water__secret")
    sneaky.example = ({"rule": "grid.noise", "params": {"grid": "g", "nx": 8, "ny": 8}},
                      {"rule": "test.sneaky"})
    host = get_plugin_manager([plugin_module("sneaky", procgen_register_rules=lambda: [sneaky])])
    with pytest.raises(AssertionError, match="writes fields it does not declare: g/water__secret"):
        check_rule_contract(sneaky, host)


def test_changing_an_existing_field_counts_as_writing_it():
    from procgen.state import State

    rule = _rule("test.quiet", "water__depth", "length")()
    before, after = State(seed=1), State(seed=1)
    for st, v in ((before, 0.0), (after, 1.0)):
        g = Grid((2, 2))
        g.add_field("water__depth", np.zeros((2, 2)), at="cell")
        g.add_field("surface__height", np.full((2, 2), v), at="cell")
        st.add_domain("g", g)
    assert undeclared_writes(rule, before, after) == ["g/surface__height"]
