"""The rule contract suite, importable by outside plugin authors.

Use it in a plugin's tests::

    from procgen.testing import check_rule_contract

    def test_contract():
        check_rule_contract(MyRule)

or ``pytest.mark.parametrize`` over ``all_rule_names()``. A rule whose inputs come from other
rules gives a tiny ``example`` recipe (list of step tables whose last step is the rule).
"""
from __future__ import annotations

import copy
import dataclasses
import math
import typing
from typing import Any

import numpy as np

from .errors import ProcgenError, RecipeError
from .params import param_info
from .plugins import PluginHost, get_plugin_manager
from .recipes import check_recipe
from .rules import RuleBase, type_hints
from .runner import run
from .state import State


def example_steps(cls: type[RuleBase]) -> list[dict[str, Any]]:
    steps = [copy.deepcopy(s) for s in cls.example] or [{"rule": cls.name}]
    if steps[-1].get("rule") != cls.name:
        raise AssertionError(f"{cls.name}: the last step of its example must use the rule itself")
    return steps


def run_example(cls: type[RuleBase], host: PluginHost, seed: int = 1) -> State:
    recipe = check_recipe({"steps": example_steps(cls)}, host, f"<contract {cls.name}>")
    return run(recipe, host, seed=seed, progress=False).state


def state_arrays(state: State) -> dict[str, np.ndarray]:
    """Every topology array and field of every domain, keyed ``domain/name``."""
    out: dict[str, np.ndarray] = {}
    for dname, dom in state.domains.items():
        for k, arr in dom.topology_arrays().items():
            out[f"{dname}/@{k}"] = np.asarray(arr)
        for fname, arr, _ in dom.fields():
            out[f"{dname}/{fname}"] = np.asarray(arr)
    return out


def _bad_values(f: dataclasses.Field, tp: Any) -> list[Any]:
    """Values the parameter must reject: outside its range, NaN/inf, wrong type."""
    info = param_info(f)
    bad: list[Any] = []
    base = tp
    origin = typing.get_origin(tp)
    if origin is typing.Union or str(origin) == "<class 'types.UnionType'>":
        args = [a for a in typing.get_args(tp) if a is not type(None)]
        base = args[0] if len(args) == 1 else None
    if base in (int, float):
        if info.ge is not None:
            bad.append(info.ge - (1 if base is int else max(1e-6, abs(info.ge) * 1e-3)))
        if info.gt is not None:
            bad.append(info.gt if base is float else int(math.floor(info.gt)))
        if info.le is not None:
            bad.append(info.le + (1 if base is int else max(1e-6, abs(info.le) * 1e-3)))
        if info.lt is not None:
            bad.append(info.lt if base is float else int(math.ceil(info.lt)))
        if base is float:
            bad += [float("nan"), float("inf")]
        bad.append("not a number")
    elif base is bool:
        bad.append("yes")
    elif base is str:
        bad.append(12345)
        if info.choices is not None:
            bad.append("__no_such_choice__")
    return bad


def check_rule_contract(cls: type[RuleBase], host: PluginHost | None = None) -> None:
    """Assert the rule protocol for ``cls``; raises AssertionError saying what is broken."""
    host = host or get_plugin_manager()
    name = cls.name
    assert dataclasses.is_dataclass(cls), f"{name}: must be a dataclass"
    assert cls.summary(), f"{name}: needs a docstring (its first line is the summary)"
    hints = type_hints(cls)
    for f in dataclasses.fields(cls):
        assert f.kw_only, f"{name}: parameter {f.name} must be keyword-only"
        assert param_info(f).doc, f"{name}: parameter {f.name} needs doc= in param()"
    # unknown and out-of-range parameters are rejected with a RecipeError naming the key
    try:
        cls.from_params({"zz_not_a_parameter": 1})
    except RecipeError as exc:
        assert "zz_not_a_parameter" in str(exc), f"{name}: error should name the unknown key: {exc}"
    else:
        raise AssertionError(f"{name}: accepted an unknown parameter")
    base_params = example_steps(cls)[-1].get("params", {})
    for f in dataclasses.fields(cls):
        for value in _bad_values(f, hints.get(f.name)):
            params = dict(base_params, **{f.name: value})
            try:
                cls.from_params(params)
            except RecipeError as exc:
                assert f.name in str(exc), f"{name}: error for {f.name}={value!r} should name it: {exc}"
            else:
                raise AssertionError(f"{name}: accepted {f.name}={value!r}")
    # run the example twice: declared outputs exist, same seed gives identical arrays
    s1 = run_example(cls, host, seed=11)
    s2 = run_example(cls, host, seed=11)
    rule = cls.from_params(base_params)
    for dname, kind in rule.domains_created().items():
        assert dname in s1.domains, f"{name}: declares it creates domain {dname!r} but did not"
        from .domains import is_kind

        assert is_kind(type(s1.domains[dname]), kind), f"{name}: domain {dname!r} is {s1.domains[dname].kind}, declared {kind}"
    for spec in rule.field_specs():
        if spec.intent in ("out", "inout"):
            dom = s1.domains.get(spec.domain)
            assert dom is not None and spec.name in dom, \
                f"{name}: declares field {spec.name!r} on {spec.domain!r} but did not write it"
            assert dom.field_info(spec.name).at == spec.at, \
                f"{name}: field {spec.name!r} is on {dom.field_info(spec.name).at!r}, declared {spec.at!r}"
    a1, a2 = state_arrays(s1), state_arrays(s2)
    assert a1.keys() == a2.keys(), f"{name}: same seed gave different domains/fields"
    for key in a1:
        assert a1[key].shape == a2[key].shape and np.array_equal(a1[key], a2[key], equal_nan=True), \
            f"{name}: same seed gave different values for {key}"
    assert all(isinstance(r.changed, bool) for r in s1.records), f"{name}: step() must return bool"


def all_rule_names(host: PluginHost | None = None) -> list[str]:
    host = host or get_plugin_manager()
    return list(host.rules)


__all__ = ["check_rule_contract", "all_rule_names", "run_example", "state_arrays", "example_steps",
           "ProcgenError"]
