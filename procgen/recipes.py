"""Recipes: TOML data naming rules to run in order and outputs to write, checked before running.

The static check follows the data flow (which step creates which domain and field) so that a
recipe chaining incompatible domains fails in one line naming the step, before any compute.
"""
from __future__ import annotations

import copy
import inspect
import math
import os
import re
import tomllib
import typing
from dataclasses import dataclass, field
from pathlib import Path, PurePosixPath
from typing import TYPE_CHECKING, Any

from .budget import Budget
from .ca.cells import kind_accepts, kind_text
from .domains import DOMAIN_KINDS
from .errors import PluginError, ProcgenError, RecipeError
from .exchange.registry import field_options
from .fields import UnitsLedger
from .params import ParamInfo, check_range, coerce, did_you_mean
from .rules import RuleBase

if TYPE_CHECKING:
    from .plugins import PluginHost

TOP_KEYS = ("recipe", "steps", "outputs")
META_KEYS = ("name", "description", "seed", "figure", "caption", "table_row", "notes")
STEP_KEYS = ("id", "rule", "params", "iterations", "until", "max_iterations", "frames", "label")
STEP_ID = re.compile(r"[A-Za-z_][A-Za-z0-9_-]*")   # never all digits: ``steps.3`` stays an index
OUTPUT_KEYS = ("domain", "format", "file", "options")
FRAME_KEYS = ("every", "domain", "format", "options")
DEFAULT_MAX_ITERATIONS = 100_000
# Limits that keep ``procgen check`` fast and bounded on hostile or broken files (the largest
# shipped recipe is 8 kB, 30 steps and 7 levels deep): each refusal is one line, before parsing
# where it can be.
MAX_RECIPE_BYTES = 4 << 20
MAX_NESTING = 32            # arrays and tables inside each other
MAX_STEPS = 10_000
MAX_OUTPUTS = 10_000
MAX_ITERATIONS = 1_000_000_000
MAX_SEED = 2**63 - 1        # seeds are int64 wherever they are stored or hashed
_STEP_HEADER = re.compile(rb"^[ \t]*\[\[[ \t]*steps[ \t]*\]\]", re.M)
#: what a run writes beside its outputs (runner: run.json, --state; jobs: the stamp; frames/)
RESERVED_FILES = ("run.json", "state.npz", ".procgen-done.json")


@dataclass
class OutputSpec:
    domain: str
    format: str
    file: str
    options: dict[str, Any]


@dataclass
class FrameSpec:
    every: int
    domain: str
    format: str
    options: dict[str, Any]


@dataclass
class Step:
    index: int
    rule: RuleBase
    params: dict[str, Any]
    iterations: int
    until_stable: bool
    frames: FrameSpec | None = None
    label: str = ""
    id: str = ""

    @property
    def where(self) -> str:
        return f"steps[{self.index}] ({self.rule.name})"


@dataclass
class Recipe:
    """A checked recipe: rule instances ready to run, outputs to write."""

    source: str
    data: dict[str, Any]
    steps: list[Step]
    outputs: list[OutputSpec]
    meta: dict[str, Any] = field(default_factory=dict)
    base_dir: Path | None = None

    @property
    def name(self) -> str:
        return str(self.meta.get("name") or Path(self.source).stem)

    @property
    def seed(self) -> int:
        return int(self.meta.get("seed", 0))


# -- finding and reading -----------------------------------------------------------------------
def find_recipe(ref: str | Path, host: "PluginHost") -> Path:
    """A path to an existing file, or a built-in recipe name like ``clouds/cumulus``."""
    p = Path(ref)
    if p.is_file():
        return p
    name = str(ref).removesuffix(".toml")
    known = list_recipes(host)
    if name in known:
        return known[name]
    if os.path.lexists(p):      # a folder, a FIFO, a device, a dangling link: read_toml says which
        return p
    raise RecipeError(f"{ref}: no such recipe file or built-in recipe{did_you_mean(name, known)}")


def list_recipes(host: "PluginHost") -> dict[str, Path]:
    """Every recipe the loaded plugins ship, by name; the first plugin to ship a name wins."""
    out: dict[str, Path] = {}
    for folder in host.recipe_folders():
        for f in sorted(folder.path.rglob("*.toml")):
            out.setdefault(f.relative_to(folder.root).with_suffix("").as_posix(), f)
    return dict(sorted(out.items()))


def rules_missing(path: Path, host: "PluginHost") -> list[str]:
    """Rules a recipe file names that no loaded plugin registers (a disabled or absent family)."""
    try:
        steps = read_toml(path).get("steps", [])
    except RecipeError:
        return []          # unreadable: the full check reports it where the recipe is used
    names = [s.get("rule") for s in steps if isinstance(s, dict)] if isinstance(steps, list) else []
    return sorted({n for n in names if isinstance(n, str) and n not in host.rules})


def read_toml(path: Path) -> dict[str, Any]:
    """Read and parse a recipe file: a regular file of at most MAX_RECIPE_BYTES, UTF-8."""
    import stat

    try:
        with open(path, "rb", opener=lambda p, flags: os.open(p, flags | os.O_NONBLOCK)) as fh:
            mode = os.fstat(fh.fileno()).st_mode
            if not stat.S_ISREG(mode):
                what = ("a folder" if stat.S_ISDIR(mode) else "a named pipe (FIFO)" if stat.S_ISFIFO(mode)
                        else "a device or socket")
                raise RecipeError(f"{path}: is {what}, not a regular file (a recipe is a .toml file)")
            blob = fh.read(MAX_RECIPE_BYTES + 1)
    except IsADirectoryError:
        raise RecipeError(f"{path}: is a folder, not a regular file (a recipe is a .toml file)") from None
    except OSError as exc:
        raise RecipeError(f"{path}: cannot read ({exc.strerror or 'I/O error'})") from None
    if len(blob) > MAX_RECIPE_BYTES:
        if len(_STEP_HEADER.findall(blob)) > MAX_STEPS:
            raise RecipeError(f"{path}: more than {MAX_STEPS} [[steps]] tables, the most a recipe may have")
        raise RecipeError(f"{path}: larger than {MAX_RECIPE_BYTES >> 20} MiB, the most a recipe may be")
    try:
        text = blob.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise RecipeError(f"{path}: not UTF-8 text (byte {exc.start})") from None
    return parse_toml(text, str(path))


def parse_toml(text: str, source: str) -> dict[str, Any]:
    """Parse recipe TOML within the size, step-count and nesting limits; one-line errors."""
    if len(text) > MAX_RECIPE_BYTES:
        raise RecipeError(f"{source}: larger than {MAX_RECIPE_BYTES >> 20} MiB, the most a recipe may be")
    headers = len(_STEP_HEADER.findall(text.encode("utf-8", "replace")))
    if headers > MAX_STEPS:       # refused before the parse, which would take seconds
        raise RecipeError(f"{source}: {headers} [[steps]] tables, more than the {MAX_STEPS} a recipe may have")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise RecipeError(f"{source}: invalid TOML ({exc})") from None
    except ValueError:            # the only other one tomllib raises: int() of a huge literal
        raise RecipeError(f"{source}: invalid TOML (an integer with thousands of digits)") from None
    except RecursionError:
        raise RecipeError(f"{source}: arrays or tables nested more than {MAX_NESTING} levels deep") from None
    check_nesting(data, source)
    return data


def check_nesting(data: Any, source: str) -> None:
    """Refuse arrays and tables nested more than MAX_NESTING deep (without recursing)."""
    stack: list[tuple[Any, int, Any]] = [(data, 0, None)]
    while stack:
        node, depth, trail = stack.pop()
        if depth > MAX_NESTING:
            parts: list[str] = []
            while trail is not None:
                trail, key = trail
                parts.append(f"[{key}]" if isinstance(key, int) else f".{key}")
            where = "".join(reversed(parts)).lstrip(".")
            where = where if len(where) <= 60 else where[:57] + "..."
            raise RecipeError(f"{source}: {where}: arrays or tables nested more than {MAX_NESTING} levels deep")
        if isinstance(node, dict):
            stack.extend((v, depth + 1, (trail, k)) for k, v in node.items() if isinstance(v, (dict, list)))
        elif isinstance(node, list):
            stack.extend((v, depth + 1, (trail, i)) for i, v in enumerate(node) if isinstance(v, (dict, list)))


# -- overrides -----------------------------------------------------------------------------------
def parse_override(text: str) -> tuple[list[str], Any]:
    """``steps.2.params.speed=0.7`` -> (['steps', '2', 'params', 'speed'], 0.7)."""
    if "=" not in text:
        raise RecipeError(f"--set {text!r}: expected KEY=VALUE, e.g. steps.1.params.r=0.005")
    key, raw = text.split("=", 1)
    parts = [p for p in key.strip().split(".")]
    if not all(parts):
        raise RecipeError(f"--set {text!r}: empty part in key {key!r}")
    if len(parts) > MAX_NESTING:
        raise RecipeError(f"--set {key[:60]!r}...: more than {MAX_NESTING} parts in the key")
    try:
        value = tomllib.loads(f"v = {raw.strip()}")["v"]
    except tomllib.TOMLDecodeError:
        value = raw.strip()  # a bare word is taken as a string, as a shell user would expect
    except ValueError:
        raise RecipeError(f"--set {key}: an integer with thousands of digits") from None
    except RecursionError:
        raise RecipeError(f"--set {key}: value nested more than {MAX_NESTING} levels deep") from None
    check_nesting(value, f"--set {key}")
    return parts, value


def _list_position(items: list[Any], part: str, here: str, source: str) -> int:
    """Where ``part`` points in a list: a position (``steps.2``) or a table's id (``steps.erode``).

    Ids survive inserting a step; a position silently moves to whatever step is there now.
    """
    if part.isdigit():
        if int(part) >= len(items):
            raise RecipeError(f"{source}: --set {here}: no such index (there are {len(items)})")
        return int(part)
    ids = [x.get("id") if isinstance(x, dict) else None for x in items]
    hits = [k for k, x in enumerate(ids) if x == part]
    if not hits:
        known = [x for x in ids if isinstance(x, str)]
        raise RecipeError(f"{source}: --set {here}: no step with id {part!r}{did_you_mean(part, known)}"
                          f" (ids: {', '.join(known) or 'none'}; or give a position 0..{len(items) - 1})")
    if len(hits) > 1:
        raise RecipeError(f"{source}: --set {here}: id {part!r} is used by {len(hits)} steps "
                          f"({', '.join(map(str, hits))}); ids must be unique")
    return hits[0]


def apply_overrides(data: dict[str, Any], overrides: list[str], source: str) -> dict[str, Any]:
    """Apply ``KEY=VALUE`` overrides; a list element is addressed by position or by its ``id``."""
    out = copy.deepcopy(data)
    for text in overrides:
        parts, value = parse_override(text)
        node: Any = out
        for i, part in enumerate(parts):
            last = i == len(parts) - 1
            here = ".".join(parts[: i + 1])
            if isinstance(node, list):
                k = _list_position(node, part, here, source)
                if last:
                    node[k] = value
                else:
                    node = node[k]
            elif isinstance(node, dict):
                if last:
                    node[part] = value
                else:
                    if part not in node:
                        node[part] = {}
                    node = node[part]
            else:
                raise RecipeError(f"{source}: --set {here}: cannot index into a {type(node).__name__}")
    return out


# -- the static check ----------------------------------------------------------------------------
def _require_table(value: Any, where: str) -> dict[str, Any]:
    if not isinstance(value, dict):
        raise RecipeError(f"{where}: must be a table, got {type(value).__name__}")
    return value


def _check_keys(table: dict[str, Any], allowed: tuple[str, ...], where: str) -> None:
    for k in table:
        if k not in allowed:
            raise RecipeError(f"{where}: unknown key {k!r}{did_you_mean(k, allowed)}")


def _check_finite(value: Any, where: str) -> None:
    if isinstance(value, float) and not math.isfinite(value):
        raise RecipeError(f"{where}: must be a finite number, got {value}")
    if isinstance(value, dict):
        for k, v in value.items():
            _check_finite(v, f"{where}.{k}")
    if isinstance(value, list):
        for i, v in enumerate(value):
            _check_finite(v, f"{where}[{i}]")


def _positive_int(value: Any, where: str, most: int = MAX_ITERATIONS) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or value < 1:
        raise RecipeError(f"{where}: expected a positive integer, got {value!r}")
    if value > most:
        raise RecipeError(f"{where}: {value} is more than the {most:,} allowed")
    return value


def _kind_fits(made: str, wanted: str) -> bool:
    if made == wanted:
        return True
    cls = DOMAIN_KINDS.get(made)
    return cls is not None and kind_accepts(cls, wanted)


def _check_exporter_options(fmt: str, options: dict[str, Any], host: "PluginHost", where: str) -> None:
    exporter = host.exporter(fmt)
    sig = inspect.signature(exporter.func)
    accepts_any = any(p.kind is p.VAR_KEYWORD for p in sig.parameters.values())
    allowed = [n for n, p in sig.parameters.items() if p.kind is p.KEYWORD_ONLY and n not in ("stem", "provenance")]
    for k in options:
        if k in ("stem", "provenance") or (not accepts_any and k not in allowed):
            raise RecipeError(f"{where}: format {fmt!r} has no option {k!r}{did_you_mean(k, allowed)}"
                              f"; options: {', '.join(allowed) or 'none'}")
    try:
        hints = typing.get_type_hints(exporter.func, include_extras=True)
    except (NameError, TypeError):   # unresolvable annotations: leave the types to the exporter
        hints = {}
    for k, v in options.items():
        hint, info = hints.get(k), ParamInfo()
        if typing.get_origin(hint) is typing.Annotated:   # Annotated[int, ParamInfo(ge=1)]: a range
            hint, *extras = typing.get_args(hint)
            info = next((e for e in extras if isinstance(e, ParamInfo)), info)
        try:
            if hint is not None:
                coerce(v, hint, f"option {k!r}")
            check_range(v, info, f"option {k!r}")   # no option takes 2^63 or 1e300 either
        except ValueError as exc:
            raise RecipeError(f"{where}: format {fmt!r}: {exc}") from None


class _Flow:
    """Domains (name -> kind) and fields ((domain, field)) available so far."""

    def __init__(self) -> None:
        self.domains: dict[str, str] = {}
        self.fields: set[tuple[str, str]] = set()
        self.units = UnitsLedger()

    def check_output(self, domain: str, fmt: str, options: dict[str, Any], host: "PluginHost", where: str) -> None:
        if domain not in self.domains:
            raise RecipeError(f"{where}: no step creates domain {domain!r}"
                              f"{did_you_mean(domain, self.domains)} (domains: {', '.join(self.domains) or 'none'})")
        try:
            exporter = host.exporter(fmt)
        except PluginError as exc:
            raise RecipeError(f"{where}: {exc}") from None
        kind = self.domains[domain]
        if not any(_kind_fits(kind, k) for k in exporter.kinds):
            raise RecipeError(f"{where}: format {fmt!r} writes {'/'.join(exporter.kinds)}, "
                              f"but domain {domain!r} is a {kind}")
        _check_exporter_options(fmt, options, host, where)
        named = {k: "" for k in options if k.endswith("field")} | field_options(exporter.func)
        for key, default in named.items():
            value = options.get(key, default)     # the exporter's default field must exist too
            if isinstance(value, str) and value and (domain, value) not in self.fields:
                have = sorted(f for d, f in self.fields if d == domain)
                raise RecipeError(f"{where}: option {key}={value!r}: domain {domain!r} has no field "
                                  f"{value!r}{did_you_mean(value, have)}")


def check_recipe(data: Any, host: "PluginHost", source: str = "<recipe>",
                 base_dir: Path | None = None) -> Recipe:
    """Validate a parsed recipe completely; return runnable steps. Raises RecipeError."""
    data = _require_table(data, source)
    _check_keys(data, TOP_KEYS, source)
    meta = _require_table(data.get("recipe", {}), f"{source}: [recipe]")
    _check_keys(meta, META_KEYS, f"{source}: [recipe]")
    if "seed" in meta and (isinstance(meta["seed"], bool) or not isinstance(meta["seed"], int)
                           or not 0 <= meta["seed"] <= MAX_SEED):
        raise RecipeError(f"{source}: [recipe] seed: expected an integer in [0, 2^63 - 1], got {meta['seed']!r}")
    raw_steps = data.get("steps")
    if not isinstance(raw_steps, list) or not raw_steps:
        raise RecipeError(f"{source}: needs at least one [[steps]] table")
    if len(raw_steps) > MAX_STEPS:
        raise RecipeError(f"{source}: {len(raw_steps)} steps, more than the {MAX_STEPS} a recipe may have")
    check_nesting(data, source)
    flow = _Flow()
    steps: list[Step] = []
    earlier: list[RuleBase] = []      # the rules of ``steps``, handed to check_chain (a copy each is O(n^2))
    budget = Budget(source, memory_limit_bytes())   # memory, charged step by step, then outputs
    ids: dict[str, int] = {}
    for i, raw in enumerate(raw_steps):
        where = f"{source}: steps[{i}]"
        raw = _require_table(raw, where)
        _check_keys(raw, STEP_KEYS, where)
        step_id = raw.get("id", "")
        if "id" in raw:
            if not isinstance(step_id, str) or not STEP_ID.fullmatch(step_id):
                raise RecipeError(f"{where}: id must be a name (letters, digits, '_' or '-', not "
                                  f"starting with a digit), got {step_id!r}")
            if step_id in ids:
                raise RecipeError(f"{where}: id {step_id!r} is already used by steps[{ids[step_id]}]")
            ids[step_id] = i
        rule_name = raw.get("rule")
        if not isinstance(rule_name, str):
            raise RecipeError(f"{where}: missing 'rule' (a rule name such as 'points.poisson_disk')")
        try:
            cls = host.rule(rule_name)
        except PluginError as exc:
            raise RecipeError(f"{where}: {exc}") from None
        where = f"{source}: steps[{i}] ({rule_name})"
        params = _require_table(raw.get("params", {}), f"{where}: params")
        rule = cls.from_params(params, where, base_dir)
        until = raw.get("until")
        if until is not None and until != "stable":
            raise RecipeError(f"{where}: until: only \"stable\" is supported, got {until!r}")
        if until is not None and "iterations" in raw:
            raise RecipeError(f"{where}: give either 'iterations' or 'until', not both")
        if until is not None:
            iterations = _positive_int(raw.get("max_iterations", DEFAULT_MAX_ITERATIONS), f"{where}: max_iterations")
        else:
            if "max_iterations" in raw:
                raise RecipeError(f"{where}: 'max_iterations' only goes with until = \"stable\"")
            iterations = _positive_int(raw.get("iterations", cls.default_iterations), f"{where}: iterations")
        # data flow: what this rule needs must exist already
        for dname, kind in rule.domains_used().items():
            if dname not in flow.domains:
                raise RecipeError(f"{where}: needs a {kind_text(kind, ' domain')} {dname!r} that no earlier step creates"
                                  f" (domains so far: {', '.join(flow.domains) or 'none'})")
            if not _kind_fits(flow.domains[dname], kind):
                raise RecipeError(f"{where}: needs domain {dname!r} to be a {kind_text(kind)}, "
                                  f"but an earlier step made it a {flow.domains[dname]}")
        try:
            rule.check_chain(earlier)
        except (ValueError, ProcgenError) as exc:
            raise RecipeError(f"{where}: {exc}") from None
        try:
            specs = rule.field_specs()
        except ValueError as exc:          # a field name a parameter gives (FieldSpec checks it)
            raise RecipeError(f"{where}: {exc}") from None
        for spec in specs:
            clash = flow.units.conflict(spec, where)
            if clash:
                raise RecipeError(f"{where}: {clash}")
            if spec.intent in ("in", "inout") and (spec.domain, spec.name) not in flow.fields:
                raise RecipeError(f"{where}: needs field {spec.name!r} on domain {spec.domain!r}, "
                                  "which no earlier step produces")
        passes = getattr(rule, "passes_fields", {}) or {}
        values = rule.param_values()
        for dname, kind in rule.domains_created().items():
            flow.domains[dname] = kind
            flow.fields = {(d, f) for d, f in flow.fields if d != dname}
        for out_t, in_t in passes.items():
            out_d, in_d = out_t.format(**values), in_t.format(**values)
            flow.fields |= {(out_d, f) for d, f in list(flow.fields) if d == in_d}
        for spec in specs:
            if spec.intent in ("out", "inout"):
                flow.fields.add((spec.domain, spec.name))
        frames = None
        if "frames" in raw:
            fr = _require_table(raw["frames"], f"{where}: frames")
            _check_keys(fr, FRAME_KEYS, f"{where}: frames")
            for key in ("every", "domain", "format"):
                if key not in fr:
                    raise RecipeError(f"{where}: frames: missing {key!r}")
            every = _positive_int(fr["every"], f"{where}: frames.every")
            fopts = _require_table(fr.get("options", {}), f"{where}: frames.options")
            _check_finite(fopts, f"{where}: frames.options")
            flow.check_output(str(fr["domain"]), str(fr["format"]), fopts, host, f"{where}: frames")
            frames = FrameSpec(every, str(fr["domain"]), str(fr["format"]), fopts)
        label = raw.get("label", "")
        if not isinstance(label, str):
            raise RecipeError(f"{where}: label must be a string")
        steps.append(Step(i, rule, params, iterations, until == "stable", frames, label, step_id))
        earlier.append(rule)
        budget.step(steps[-1])
        if frames is not None:
            budget.frame_series(steps[-1], host.exporter(frames.format))
    outputs: list[OutputSpec] = []
    raw_outputs = data.get("outputs", [])
    if not isinstance(raw_outputs, list):
        raise RecipeError(f"{source}: 'outputs' must be an array of tables ([[outputs]])")
    if len(raw_outputs) > MAX_OUTPUTS:
        raise RecipeError(f"{source}: {len(raw_outputs)} outputs, more than the {MAX_OUTPUTS} a recipe may have")
    seen_files: set[str] = set()
    for j, raw in enumerate(raw_outputs):
        where = f"{source}: outputs[{j}]"
        raw = _require_table(raw, where)
        _check_keys(raw, OUTPUT_KEYS, where)
        for key in ("domain", "format"):
            if not isinstance(raw.get(key), str):
                raise RecipeError(f"{where}: missing {key!r} (a string)")
        opts = _require_table(raw.get("options", {}), f"{where}: options")
        _check_finite(opts, f"{where}: options")
        flow.check_output(raw["domain"], raw["format"], opts, host, where)
        exporter = host.exporter(raw["format"])
        fname = raw.get("file", f"{raw['domain']}{exporter.suffix}")
        if not isinstance(fname, str) or not fname:
            raise RecipeError(f"{where}: file must be a non-empty relative path")
        pp = PurePosixPath(fname)
        if pp.is_absolute() or ".." in pp.parts or fname.startswith(("/", "\\")):
            raise RecipeError(f"{where}: file {fname!r} must stay inside the output folder")
        if pp.name in ("", ".") or fname.endswith(("/", "\\")) or not fname.isprintable():
            raise RecipeError(f"{where}: file {fname!r} must name a file (printable characters, not a folder)")
        if fname in RESERVED_FILES or pp.parts[0] == "frames":
            raise RecipeError(f"{where}: file {fname!r} is where the run writes its own record; choose another name")
        if fname in seen_files:
            raise RecipeError(f"{where}: file {fname!r} is written by an earlier output too")
        seen_files.add(fname)
        budget.output(where, fname, exporter, raw["domain"], opts)
        outputs.append(OutputSpec(raw["domain"], raw["format"], fname, opts))
    return Recipe(source, data, steps, outputs, dict(meta), base_dir)


def memory_limit_bytes() -> int:
    """80% of physical memory, or less under an address-space limit (``ulimit -v``, a batch
    system's): the room left below it. A recipe estimated above this is refused before it starts."""
    import os
    import resource

    try:
        page = os.sysconf("SC_PAGE_SIZE")
        limit = int(0.8 * page * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        page, limit = 4096, 8 * 2**30
    soft = resource.getrlimit(resource.RLIMIT_AS)[0]
    if soft != resource.RLIM_INFINITY:
        try:
            with open("/proc/self/statm") as fh:
                used = int(fh.read().split()[0]) * page
        except (OSError, ValueError, IndexError):
            used = 0
        limit = min(limit, max(0, int(0.8 * (soft - used))))
    return limit


def load_recipe(ref: str | Path, host: "PluginHost", overrides: list[str] | None = None) -> Recipe:
    """Find, read, override and check a recipe. Every failure is a one-line RecipeError."""
    path = find_recipe(ref, host)
    # A recipe named by a plugin's name (``demo/basics``) is called by that name in every message,
    # not by where its plugin happens to be installed; a file is called by the path the user gave.
    source = str(path) if path == Path(ref) else str(ref).removesuffix(".toml")
    data = read_toml(path)
    if overrides:
        data = apply_overrides(data, overrides, source)
    try:
        return check_recipe(data, host, source, path.parent)
    except ProcgenError:
        raise
    except (TypeError, ValueError, KeyError, AttributeError, IndexError) as exc:
        raise RecipeError(f"{source}: malformed recipe ({exc})") from None
