"""The rule contract suite, run over every registered rule (built-ins and plugins alike)."""
from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import pytest

from procgen import get_plugin_manager
from procgen.testing import check_rule_contract

_HOST = get_plugin_manager()


@pytest.mark.parametrize("name", list(_HOST.rules))
def test_rule_contract(name):
    check_rule_contract(_HOST.rules[name], _HOST)


def test_contract_catches_a_lying_rule():
    from procgen import FieldSpec, Grid, RuleBase, param

    @dataclass(kw_only=True)
    class Liar(RuleBase):
        """Declares a field it never writes."""

        name: ClassVar[str] = "test.liar"
        creates: ClassVar[dict[str, str]] = {"g": "Grid"}
        fields: ClassVar[tuple] = (FieldSpec("water__depth", "g", "cell", "out"),)
        k: float = param(1.0, ge=0.0, doc="k")

        def step(self, state):
            state.add_domain("g", Grid((2, 2)))
            return True

    from procgen.plugins import plugin_module

    host = get_plugin_manager([plugin_module("liar", procgen_register_rules=lambda: [Liar])])
    with pytest.raises(AssertionError, match="did not write"):
        check_rule_contract(Liar, host)
