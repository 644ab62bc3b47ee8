"""The rule protocol: keyword-only dataclasses with declared parameters, fields and domains."""
from __future__ import annotations

import dataclasses
import functools
import typing
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Mapping, Protocol, runtime_checkable

from .errors import MissingExtra, RecipeError
from .fields import FieldSpec
from .params import ParamInfo, check_range, coerce, did_you_mean, param_info, type_name

if typing.TYPE_CHECKING:
    from .state import State


@runtime_checkable
class Rule(Protocol):
    """What the runner needs from a rule; subclass :class:`RuleBase` to get it."""

    name: ClassVar[str]

    def setup(self, state: "State") -> None: ...

    def step(self, state: "State") -> bool: ...


@dataclass(kw_only=True)
class RuleBase:
    """Base class for rules. Subclasses are ``@dataclass(kw_only=True)``; fields are parameters.

    Class attributes a rule sets:
      name: ``family.process``; fields: FieldSpecs it reads/writes; uses / creates: domain
      name templates -> kind (``{"{mesh}": "TriMesh"}``); passes_fields: created domain ->
      source domain whose fields it carries over (converters); default_iterations: how many steps a
      recipe runs when it does not say (1 for generators and converters).
    """

    name: ClassVar[str] = ""
    fields: ClassVar[tuple[FieldSpec, ...]] = ()
    uses: ClassVar[dict[str, str]] = {}
    creates: ClassVar[dict[str, str]] = {}
    passes_fields: ClassVar[dict[str, str]] = {}
    default_iterations: ClassVar[int] = 1
    #: A tiny recipe (list of [[steps]] tables) whose LAST step uses this rule; the contract
    #: suite (procgen.testing) runs it. Needed when the rule reads domains others create.
    example: ClassVar[tuple[dict[str, Any], ...]] = ()
    #: The folder of the recipe being checked (set by ``from_params``), so ``validate`` can
    #: check files named relative to the recipe. None outside a recipe.
    recipe_dir: ClassVar["Path | None"] = None

    # -- the protocol ---------------------------------------------------------------------
    def setup(self, state: "State") -> None:
        """Prepare the state (create domains/fields) before the first step."""

    def step(self, state: "State") -> bool:
        """Advance one iteration; return False when nothing changed (the run is stable)."""
        raise NotImplementedError

    def finish(self, state: "State") -> None:
        """Called once after the last iteration (derive final outputs)."""

    def publish(self, state: "State") -> None:
        """Bring the domains this rule shows up to date; called before each frame is exported.

        Rules that keep cheap internal state (a snake, particles) and only copy it into domains
        now and then implement this, so frames cost nothing when a recipe writes none.
        """

    def validate(self) -> None:
        """Cross-parameter checks; raise ValueError('what is wrong') for a bad combination."""

    def check_chain(self, earlier: "list[RuleBase]") -> None:
        """Check this step against the recipe's earlier steps (their rule instances, in order).

        For what the data flow cannot see: a layer name this rule uses that an earlier rule's
        parameters define. Raise ValueError('what is wrong'); ``procgen check`` reports it as a
        one-line error naming this step.
        """

    def memory_estimate(self, sizes: "Mapping[str, int] | None" = None) -> int:
        """Bytes this rule will allocate at most; 0 if small or unknown.

        ``sizes`` holds the elements (cells, faces, points) of the recipe's earlier domains as far
        as they are known (see :meth:`domain_sizes`); an override may leave the argument out and
        estimate from its parameters alone.  The recipe check refuses a recipe whose estimate
        exceeds the machine's memory, so a typo like ``size = 1000000`` fails in one line instead
        of swapping for an hour.
        """
        return 0

    def domain_sizes(self, sizes: "Mapping[str, int]") -> dict[str, int]:
        """Elements (grid cells, mesh faces, points) of each domain this rule creates, as far as
        its parameters and ``sizes`` (the earlier domains' known sizes) tell; unknown ones left out.

        ``procgen check`` estimates later steps, frames and outputs from them.  By default a
        converter's domain (``passes_fields``) is taken to be as large as its source.
        """
        values = self.param_values()
        out = {}
        for made, source in self.passes_fields.items():
            n = sizes.get(source.format(**values))
            if n is not None:
                out[made.format(**values)] = n
        return out

    # -- introspection --------------------------------------------------------------------
    def param_values(self) -> dict[str, Any]:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    def field_specs(self) -> list[FieldSpec]:
        values = self.param_values()
        return [spec.resolve(values) for spec in self.fields]

    def domains_used(self) -> dict[str, str]:
        values = self.param_values()
        return {k.format(**values): v for k, v in self.uses.items()}

    def domains_created(self) -> dict[str, str]:
        values = self.param_values()
        return {k.format(**values): v for k, v in self.creates.items()}

    @classmethod
    def summary(cls) -> str:
        doc = (cls.__doc__ or "").strip().splitlines()
        return doc[0] if doc else ""

    @classmethod
    def parameters(cls) -> list["ParamRow"]:
        hints = type_hints(cls)
        rows = []
        for f in dataclasses.fields(cls):
            default = f.default if f.default is not dataclasses.MISSING else (
                f.default_factory() if f.default_factory is not dataclasses.MISSING else None)
            rows.append(ParamRow(f.name, type_name(hints.get(f.name, Any)), default, param_info(f),
                                 f.default is dataclasses.MISSING and f.default_factory is dataclasses.MISSING))
        return rows

    @classmethod
    def from_params(cls, params: dict[str, Any], where: str = "", recipe_dir: "Path | None" = None) -> "RuleBase":
        """Build the rule from recipe parameters, checking names, types, NaN and ranges."""
        prefix = f"{where}: " if where else ""
        if not isinstance(params, dict):
            raise RecipeError(f"{prefix}'params' must be a table, got {type(params).__name__}")
        hints = type_hints(cls)
        known = {f.name: f for f in dataclasses.fields(cls)}
        clean: dict[str, Any] = {}
        for key, value in params.items():
            f = known.get(key)
            if f is None:
                raise RecipeError(f"{prefix}unknown parameter {key!r}{did_you_mean(key, known)}"
                                  f"; known: {', '.join(known) or 'none'}")
            try:
                v = coerce(value, hints.get(key, Any), f"parameter {key!r}")
                check_range(v, param_info(f), f"parameter {key!r}")
            except ValueError as exc:
                raise RecipeError(f"{prefix}{exc}") from None
            clean[key] = v
        missing = [n for n, f in known.items() if n not in clean and f.default is dataclasses.MISSING
                   and f.default_factory is dataclasses.MISSING]
        if missing:
            raise RecipeError(f"{prefix}missing required parameter {missing[0]!r}")
        try:
            rule = cls(**clean)
            if recipe_dir is not None:
                rule.recipe_dir = recipe_dir  # type: ignore[misc]
            rule.validate()
        except MissingExtra as exc:
            raise MissingExtra(f"{prefix}{exc}", exc.extra) from None
        except (ValueError, TypeError) as exc:
            raise RecipeError(f"{prefix}{exc}") from None
        except ArithmeticError:       # a check computing with extreme values (1e-300, 1e9) overflowed
            raise RecipeError(f"{prefix}its parameters are too extreme to work with (a derived size "
                              f"overflows); bring the smallest or largest values closer to 1") from None
        return rule


@dataclass(frozen=True)
class ParamRow:
    """One row of ``procgen rules show``."""

    name: str
    type: str
    default: Any
    info: ParamInfo
    required: bool


@functools.lru_cache(maxsize=None)
def type_hints(cls: type) -> dict[str, Any]:
    """Resolved parameter annotations; unresolvable string annotations count as Any.

    Cached per class: resolving them is most of the cost of checking a step.  Callers must not
    modify the returned dict.
    """
    try:
        return typing.get_type_hints(cls)
    except (NameError, TypeError):
        out: dict[str, Any] = {}
        for f in dataclasses.fields(cls):
            out[f.name] = f.type if not isinstance(f.type, str) else {
                "float": float, "int": int, "bool": bool, "str": str}.get(f.type, Any)
        return out


def check_rule_class(cls: Any) -> None:
    """Raise PluginError-worthy ValueError if ``cls`` does not follow the rule protocol."""
    if not isinstance(cls, type) or not dataclasses.is_dataclass(cls):
        raise ValueError(f"{cls!r} is not a dataclass rule class")
    name = getattr(cls, "name", "")
    if not isinstance(name, str) or "." not in name:
        raise ValueError(f"{cls.__name__}: name must look like 'family.process', got {name!r}")
    for meth in ("setup", "step"):
        if not callable(getattr(cls, meth, None)):
            raise ValueError(f"{cls.__name__}: missing method {meth}()")
    for f in dataclasses.fields(cls):
        if not f.kw_only:
            raise ValueError(f"{cls.__name__}: use @dataclass(kw_only=True) (field {f.name!r})")
