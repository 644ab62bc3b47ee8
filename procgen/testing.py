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
from pathlib import Path
from typing import Any, Iterable

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


def run_example(cls: type[RuleBase], host: PluginHost, seed: int = 1, *, upto: int | None = None) -> State:
    """Run the rule's example (its first ``upto`` steps only, if given)."""
    steps = example_steps(cls)[:upto]
    if not steps:
        return State(seed=seed)
    recipe = check_recipe({"steps": steps}, host, f"<contract {cls.name}>")
    return run(recipe, host, seed=seed, progress=False).state


def undeclared_writes(rule: RuleBase, before: State, after: State) -> list[str]:
    """Fields the rule's step created or changed without declaring them (``domain/field``).

    Fields carried to a created domain under ``passes_fields`` count as declared.
    """
    declared = {(s.domain, s.name) for s in rule.field_specs() if s.intent in ("out", "inout")}
    values = rule.param_values()
    carried = {out_t.format(**values): in_t.format(**values) for out_t, in_t in rule.passes_fields.items()}
    bad = []
    for dname, dom in after.domains.items():
        old = before.domains.get(dname)
        src = after.domains.get(carried.get(dname, ""))
        for fname, arr, _ in dom.fields():
            if (dname, fname) in declared or (src is not None and fname in src):
                continue
            prev = old[fname] if old is not None and fname in old else None
            if prev is None or prev.shape != arr.shape or not np.array_equal(prev, arr, equal_nan=arr.dtype.kind in "fc"):
                bad.append(f"{dname}/{fname}")
    return bad


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
    hidden = undeclared_writes(rule, run_example(cls, host, seed=11, upto=-1), s1)
    assert not hidden, f"{name}: writes fields it does not declare: {', '.join(hidden)}"
    a1, a2 = state_arrays(s1), state_arrays(s2)
    assert a1.keys() == a2.keys(), f"{name}: same seed gave different domains/fields"
    for key in a1:
        assert a1[key].shape == a2[key].shape and np.array_equal(a1[key], a2[key], equal_nan=a1[key].dtype.kind in "fc"), \
            f"{name}: same seed gave different values for {key}"
    assert all(isinstance(r.changed, bool) for r in s1.records), f"{name}: step() must return bool"


def read_field_vocabulary(path: str | Path) -> dict[str, str]:
    """Field name -> units from the tables of a markdown vocabulary (docs/fields.md); '-' -> ''."""
    out: dict[str, str] = {}
    for line in Path(path).read_text(encoding="utf-8").splitlines():
        cells = [c.strip() for c in line.strip().strip("|").split("|")]
        if len(cells) >= 4 and cells[0].startswith("`") and "__" in cells[0]:
            out[cells[0].strip("`")] = "" if cells[2] == "-" else cells[2]
    return out


def field_vocabulary_problems(rules: Iterable[type[RuleBase]], vocabulary: dict[str, str]) -> list[str]:
    """Every way the rules' declared fields break the vocabulary: unlisted names, other units,
    and one name declared with two units by two rules.  Names chosen by a parameter are skipped."""
    problems: list[str] = []
    seen: dict[str, tuple[str, str]] = {}
    for cls in rules:
        for spec in cls.fields:
            if "{" in spec.name:
                continue
            if spec.name not in vocabulary:
                problems.append(f"{cls.name}: field {spec.name!r} is not in the field vocabulary")
            elif spec.units != vocabulary[spec.name]:
                problems.append(f"{cls.name}: field {spec.name!r} declared in {spec.units or '-'!r}, "
                                f"the vocabulary says {vocabulary[spec.name] or '-'!r}")
            first = seen.setdefault(spec.name, (spec.units, cls.name))
            if first[0] != spec.units:
                problems.append(f"field {spec.name!r}: {first[1]} declares {first[0] or '-'!r}, "
                                f"{cls.name} declares {spec.units or '-'!r}")
    return problems


def all_rule_names(host: PluginHost | None = None) -> list[str]:
    host = host or get_plugin_manager()
    return list(host.rules)


__all__ = ["check_rule_contract", "all_rule_names", "run_example", "state_arrays", "example_steps",
           "undeclared_writes", "read_field_vocabulary", "field_vocabulary_problems", "ProcgenError"]


def drive_rule(rule: RuleBase, state: State, max_iterations: int = 100_000) -> int:
    """Run one rule on a hand-built state as the runner would (setup, steps until one returns
    False or ``max_iterations``, finish), without a recipe: for unit tests and benchmarks that
    time a rule alone.  Returns the number of iterations that changed something."""
    state.iteration = -1
    rule.setup(state)
    it = 0
    while it < max_iterations:
        state.iteration = it
        if not rule.step(state):
            break
        it += 1
    state.iteration = it
    rule.finish(state)
    return it
