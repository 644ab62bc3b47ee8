"""Rule parameters: dataclass fields with ranges, units and docs, and their validation.

A rule's parameters are its dataclass fields, so the recipe checker can reject an unknown key,
a wrong type, NaN or an out-of-range value with a precise message before anything runs.
"""
from __future__ import annotations

import collections.abc
import dataclasses
import difflib
import math
import types
import typing
from dataclasses import dataclass
from typing import Any, Union


@dataclass(frozen=True)
class ParamInfo:
    """The metadata ``param()`` attaches to a rule field."""

    ge: float | None = None
    le: float | None = None
    gt: float | None = None
    lt: float | None = None
    choices: tuple[Any, ...] | None = None
    units: str = ""
    doc: str = ""

    def range_text(self) -> str:
        lo = f"[{self.ge:g}" if self.ge is not None else (f"({self.gt:g}" if self.gt is not None else "(-inf")
        hi = f"{self.le:g}]" if self.le is not None else (f"{self.lt:g})" if self.lt is not None else "inf)")
        if self.choices is not None:
            return "one of " + ", ".join(repr(c) for c in self.choices)
        return "" if lo == "(-inf" and hi == "inf)" else f"{lo}, {hi}"


def param(default: Any = dataclasses.MISSING, *, ge: float | None = None, le: float | None = None,
          gt: float | None = None, lt: float | None = None, choices: Any = None,
          units: str = "", doc: str = "") -> Any:
    """Declare a rule parameter (a dataclass field) with its allowed range, units and doc."""
    info = ParamInfo(ge, le, gt, lt, tuple(choices) if choices is not None else None, units, doc)
    meta = {"procgen": info}
    if isinstance(default, (list, dict, set)):
        frozen_default = default
        return dataclasses.field(default_factory=lambda: _deepcopy(frozen_default), metadata=meta)
    if default is dataclasses.MISSING:
        return dataclasses.field(metadata=meta)
    return dataclasses.field(default=default, metadata=meta)


def _deepcopy(value: Any) -> Any:
    import copy

    return copy.deepcopy(value)


def param_info(f: dataclasses.Field) -> ParamInfo:
    return f.metadata.get("procgen", ParamInfo())


def type_name(tp: Any) -> str:
    origin = typing.get_origin(tp)
    if origin in (Union, types.UnionType):
        return " | ".join(type_name(a) for a in typing.get_args(tp))
    if origin is not None:
        args = ", ".join(type_name(a) for a in typing.get_args(tp) if a is not Ellipsis)
        return f"{getattr(origin, '__name__', str(origin))}[{args}]"
    if tp is type(None):
        return "None"
    return getattr(tp, "__name__", str(tp))


def coerce(value: Any, tp: Any, where: str) -> Any:
    """Check ``value`` against annotation ``tp``; return it converted (int->float, list->tuple).

    Raises ValueError with a message naming ``where``.
    """
    origin = typing.get_origin(tp)
    if tp is Any:
        return value
    if origin in (Union, types.UnionType):
        args = typing.get_args(tp)
        if value is None and type(None) in args:
            return None
        errors = []
        for a in args:
            if a is type(None):
                continue
            try:
                return coerce(value, a, where)
            except ValueError as exc:
                errors.append(str(exc))
        raise ValueError(errors[0] if len(errors) == 1 else f"{where}: expected {type_name(tp)}, got {_show(value)}")
    if origin is typing.Literal:
        if value not in typing.get_args(tp):
            raise ValueError(f"{where}: expected one of {list(typing.get_args(tp))}, got {_show(value)}")
        return value
    if tp is bool:
        if not isinstance(value, bool):
            raise ValueError(f"{where}: expected true or false, got {_show(value)}")
        return value
    if tp is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise ValueError(f"{where}: expected an integer, got {_show(value)}")
        return value
    if tp is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise ValueError(f"{where}: expected a number, got {_show(value)}")
        if not math.isfinite(value):
            raise ValueError(f"{where}: must be a finite number, got {value}")
        return float(value)
    if tp is str:
        if not isinstance(value, str):
            raise ValueError(f"{where}: expected a string, got {_show(value)}")
        return value
    if origin in (list, tuple, collections.abc.Sequence):
        if not isinstance(value, (list, tuple)):
            raise ValueError(f"{where}: expected a list, got {_show(value)}")
        args = typing.get_args(tp)
        if origin is tuple and args and args[-1] is not Ellipsis:
            if len(value) != len(args):
                raise ValueError(f"{where}: expected {len(args)} values, got {len(value)}")
            return tuple(coerce(v, a, f"{where}[{i}]") for i, (v, a) in enumerate(zip(value, args)))
        elem = args[0] if args else Any
        out = [coerce(v, elem, f"{where}[{i}]") for i, v in enumerate(value)]
        return tuple(out) if origin is tuple else out
    if origin is dict:
        if not isinstance(value, dict):
            raise ValueError(f"{where}: expected a table, got {_show(value)}")
        kt, vt = typing.get_args(tp) or (Any, Any)
        return {coerce(k, kt, where): coerce(v, vt, f"{where}.{k}") for k, v in value.items()}
    if isinstance(tp, type):
        if not isinstance(value, tp):
            raise ValueError(f"{where}: expected {type_name(tp)}, got {_show(value)}")
        return value
    return value


#: The magnitude no number in a parameter may exceed on a side where the parameter declares no
#: bound of its own: 1e9 for a real number, 2^32 for an integer (a cell count a memory estimate
#: then refuses in its own words).  Every number a rule takes is then finite and far inside
#: float64, and a product of two integers inside int64, so a fuzzed ``2^63`` or ``1e15`` is
#: refused in one line instead of overflowing a cast or an allocation deep in a step.  Lengths,
#: counts and coordinates in the shipped recipes stay below 1e7.
DEFAULT_BOUND = 1e9
DEFAULT_INT_BOUND = 2**32


def check_range(value: Any, info: ParamInfo, where: str) -> None:
    """Apply ``info``'s bounds (DEFAULT_BOUND where it declares none) to a number, or to every
    number inside a list or table."""
    if info.choices is not None:
        if value not in info.choices:
            raise ValueError(f"{where}: {_short(value)} is not one of {list(info.choices)}")
        return
    if isinstance(value, (list, tuple)):
        for i, v in enumerate(value):
            check_range(v, info, f"{where}[{i}]")
        return
    if isinstance(value, dict):
        for k, v in value.items():
            check_range(v, info, f"{where}.{k}")
        return
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return
    if isinstance(value, float) and not math.isfinite(value):
        raise ValueError(f"{where}: must be a finite number, got {value}")
    bad = ((info.ge is not None and value < info.ge) or (info.le is not None and value > info.le)
           or (info.gt is not None and value <= info.gt) or (info.lt is not None and value >= info.lt))
    if bad:
        raise ValueError(f"{where}: {_short(value)} is outside the allowed range {info.range_text()}")
    most = DEFAULT_INT_BOUND if isinstance(value, int) else DEFAULT_BOUND
    if ((info.le is None and info.lt is None and value > most)
            or (info.ge is None and info.gt is None and value < -most)):
        shown = "2^32" if isinstance(value, int) else f"{most:.0e}"
        raise ValueError(f"{where}: {_short(value)} is beyond {shown}, the largest magnitude "
                         f"{'an integer' if isinstance(value, int) else 'a number'} parameter or option takes")


def _short(value: Any) -> str:
    """A number as a message shows it: huge integers in float notation, never 4,000 digits."""
    if isinstance(value, int) and not isinstance(value, bool) and abs(value) >= 10**15:
        return f"{value:.3e}" if abs(value) < 10**300 else "an integer of over 300 digits"
    if isinstance(value, float) and abs(value) >= 1e7:
        return f"{value:g}"
    return repr(value)


def did_you_mean(word: str, options: typing.Iterable[str]) -> str:
    close = difflib.get_close_matches(word, list(options), n=1, cutoff=0.6)
    return f" (did you mean {close[0]!r}?)" if close else ""


def _show(value: Any) -> str:
    text = repr(value)
    return f"{type(value).__name__} {text[:40]}"
