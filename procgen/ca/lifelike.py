"""Outer-totalistic binary automata ("Life-like"): the next state from (live neighbours, own state).

A rule is a lookup table C' = T(N, C) over the live-neighbour count N and the cell's state C
(the wood-weathering thesis 2.4: 9 x 2 rows for the Moore neighbourhood), given as

* a B/S string, letters in either order: ``B3/S23`` (Life), ``B3/S234`` (maze), ``B3/S45678``;
* the thesis's S/B notation without letters (MCell's): ``23/3`` (Life), ``25/357``, ``45678/3``
  (Coral, thesis Table 2.3);
* a lookup-table code, the integer sum of T(N, C) * 2^(2N + C) (thesis Tables 2.1-2.2: Life is
  224).

The wood thesis's Tables 3.1-3.2 do not match the standard reading of their names: ``25/357``
tabulates survival at {2, 3, 5, 7}, i.e. C' = 1 if N in B, C' = C if N in S, else 0.  So a B/S
string is read with ``semantics``: ``literal`` (the standard reading: survive exactly at S) or
``table`` (the thesis tables: survive at S and B).  They agree whenever B is inside S (Life).
Counts above 8 (a cell network may have more links) are never in B or S.

``birth_field`` (off by default) names a cell field p in [0, 1]: a birth the table calls for
happens only where a uniform draw is below p, so a weathering model can make sheltered cells
come alive less often (the wood thesis ages every cell alike; its 2.2 names sunlight and
moisture as the causes). Survival is untouched, and with the field off no random numbers are
drawn, so results stay those of the plain rule.
"""
from __future__ import annotations

import re
from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from ..accel import MIN_CELLS, kernels
from ..errors import InputError
from ..fields import FieldSpec
from ..params import param
from ..state import State
from .automaton import StateAutomaton
from .cells import cell_values, put_cell_values
from .graph import CellGraph

SEMANTICS = ("literal", "table")
MAX_CODE = 2 ** 18 - 1
_LETTERED = (re.compile(r"^B(?P<b>\d*)/?S(?P<s>\d*)$", re.I), re.compile(r"^S(?P<s>\d*)/?B(?P<b>\d*)$", re.I))
_PLAIN = re.compile(r"^(?P<s>\d*)/(?P<b>\d*)$")


@dataclass(frozen=True)
class LifeTable:
    """Birth and survival counts after semantics: C' = 1 iff N in (survive if C else born)."""

    born: frozenset[int]
    survive: frozenset[int]

    @property
    def code(self) -> int:
        """The thesis's lookup-table code: sum of C'(N, C) * 2^(2N + C)."""
        return sum(1 << (2 * n) for n in self.born) + sum(1 << (2 * n + 1) for n in self.survive)

    @property
    def bs(self) -> str:
        return "B" + "".join(map(str, sorted(self.born))) + "/S" + "".join(map(str, sorted(self.survive)))

    def lut(self, max_count: int = 8) -> np.ndarray:
        """(max(max_count, 8) + 1, 2) bool table indexed [N, C]."""
        t = np.zeros((max(max_count, 8) + 1, 2), bool)
        t[sorted(self.born), 0] = True
        t[sorted(self.survive), 1] = True
        return t


def _counts(digits: str, text: str) -> frozenset[int]:
    if any(d not in "012345678" for d in digits) or len(set(digits)) != len(digits):
        raise InputError(f"rule {text!r}: neighbour counts must be distinct digits 0-8, got {digits!r}")
    return frozenset(int(d) for d in digits)


def parse_rule(text: str, semantics: str = "literal") -> LifeTable:
    """The table of a B/S string, an S/B string or a lookup-table code (see the module doc)."""
    if semantics not in SEMANTICS:
        raise InputError(f"rule semantics must be one of {SEMANTICS}, got {semantics!r}")
    s = str(text).strip().replace(" ", "")
    if s.isdigit():
        code = int(s)
        if code > MAX_CODE:
            raise InputError(f"rule {text!r}: a lookup-table code is 0..{MAX_CODE} (18 bits)")
        return LifeTable(frozenset(n for n in range(9) if code >> (2 * n) & 1),
                         frozenset(n for n in range(9) if code >> (2 * n + 1) & 1))
    m = next((p.match(s) for p in (*_LETTERED, _PLAIN) if p.match(s)), None)
    if m is None:
        raise InputError(f"rule {text!r} is not a B/S string (B3/S23), an S/B string (23/3) "
                         f"or a lookup-table code (0..{MAX_CODE})")
    born, survive = _counts(m["b"], text), _counts(m["s"], text)
    return LifeTable(born, survive | born if semantics == "table" else survive)


def life_step(graph: CellGraph, alive: np.ndarray, lut: np.ndarray, out: np.ndarray | None = None,
              accelerate: bool | None = None) -> np.ndarray:
    """One synchronous generation: the next state from the previous one only (a new array).
    ``accelerate``: the numba kernel of procgen.ca.kernels (same result, written into ``out``
    when given), see procgen.accel."""
    kern = kernels("procgen.ca.kernels", accelerate, graph.n_cells, MIN_CELLS)
    if kern is not None:
        return kern.life_step(graph, alive, lut, out)
    n = graph.count(alive)
    return lut[np.minimum(n, len(lut) - 1), alive.astype(np.intp)]


AGE_MODES = ("cumulative", "consecutive", "since_first")


def next_age(age: np.ndarray, alive: np.ndarray, ever: np.ndarray, mode: str) -> np.ndarray:
    """Per-cell step counter after a step whose new state is ``alive`` (``ever``: been alive).

    cumulative: +1 per step alive; consecutive: +1 per step alive, 0 on death; since_first: +1
    per step once the cell has ever been alive (the wood thesis 4.3.3's "value", three readings).
    """
    if mode == "cumulative":
        return age + alive
    if mode == "consecutive":
        return np.where(alive, age + 1, 0).astype(age.dtype)
    return age + ever


@dataclass(kw_only=True)
class LifeLike(StateAutomaton):
    """Outer-totalistic binary automaton from a B/S string (Life, maze, Coral, 25/357 ...).

    Runs on any cell domain.  Each step every present cell counts its live neighbours N and
    takes T(N, own state) from the rule's table (synchronous).  ``age_field`` counts steps alive.
    On the compiled path (procgen.accel) a step is one fused kernel on buffers made in setup,
    and the published fields are those buffers (copy one to keep a past step's state).
    """

    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "grid.noise", "params": {"nx": 24, "ny": 16, "grid": "cells"}},
        {"rule": "ca.life", "iterations": 5, "params": {"density": 0.3}},)
    name: ClassVar[str] = "ca.life"
    default_iterations: ClassVar[int] = 100
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("{field}", domain="{cells}", at="cell", intent="out", dtype="bool", doc="live cells"),
        FieldSpec("{age_field}", domain="{cells}", at="cell", intent="out", dtype="int32",
                  units="steps", doc="step counter of the live cells (age_mode)"),)
    rule: str = param("B3/S23", doc="B/S string (B3/S23), S/B string (23/3) or lookup-table code (224)")
    semantics: str = param("literal", choices=SEMANTICS,
                           doc="read a B/S string as written (literal) or as the wood thesis's tables (table: survive at S and B)")
    age_field: str = param("ca__age", doc="cell field counting steps alive")
    age_mode: str = param("cumulative", choices=AGE_MODES,
                          doc="age: steps alive, consecutive steps alive, or steps since first alive")
    initial_age: int = param(0, ge=0, doc="live cells start with an age uniform in 1..this (0: age 0)")
    birth_field: str = param("", doc="cell field in [0, 1]: probability that a birth the rule calls for "
                                     "happens ('' = always: the plain rule)")

    @property
    def table(self) -> LifeTable:
        return parse_rule(self.rule, self.semantics)

    def validate(self) -> None:
        super().validate()
        try:
            self.table
        except InputError as exc:
            raise ValueError(str(exc)) from None

    def field_specs(self) -> list[FieldSpec]:
        specs = super().field_specs()
        if self.birth_field:
            specs.append(FieldSpec(self.birth_field, self.cells, "cell", "in", doc="birth probability"))
        return specs

    def birth_probability(self, dom) -> np.ndarray:
        """The ``birth_field`` as a flat (n,) array, checked to lie in [0, 1]."""
        if self.birth_field not in dom:
            raise InputError(f"{self.name}: {self.cells!r} has no birth_field {self.birth_field!r}")
        p = np.asarray(cell_values(dom, self.birth_field), dtype=np.float64).reshape(-1)
        if p.shape != self._alive.shape or not np.all((p >= 0) & (p <= 1)):
            raise InputError(f"{self.name}: birth_field {self.birth_field!r} must be one value in [0, 1] per cell")
        return p

    def setup(self, state: State) -> None:
        dom, self._graph, self._present = self.cell_domain(state)
        rng = state.rng()
        self._alive = self.start(dom, self._present, rng).astype(bool) & self._present
        self._lut = self.table.lut(int(self._graph.degree.max(initial=0)))
        self._bs = self.table.bs
        self._ever = self._alive.copy()
        self._age = np.zeros(len(self._present), np.int32)
        if self.initial_age > 0:
            k = int(self._alive.sum())
            self._age[self._alive] = rng.integers(1, self.initial_age + 1, k)
        kern = kernels("procgen.ca.kernels", None, len(self._present), MIN_CELLS)
        self._run = None if kern is None else kern.LifeRun(
            self._graph, self._present, self._lut, self.age_mode, self._alive, self._ever, self._age)
        self._write(dom)
        # read and checked once: a missing or out-of-range field fails now, and no other rule
        # writes it between this rule's iterations (procgen.runner.run)
        self._p = self.birth_probability(dom) if self.birth_field else None

    def _write(self, dom) -> None:
        put_cell_values(dom, self.field, self._alive, doc=f"live cells of {self._bs}")
        put_cell_values(dom, self.age_field, self._age, units="steps", doc=f"{self.age_mode} steps alive")

    def step(self, state: State) -> bool:
        dom = state.get(self.cells)
        if self._run is not None:                    # compiled: one fused kernel, no temporaries
            run = self._run
            if self._p is not None:
                state.rng().random(out=run.draws())
            changed = run.step(self._p)
            self._alive, self._age = run.alive, run.age     # (run.ever: read at the end only)
            self._write(dom)
            return changed
        new = life_step(self._graph, self._alive, self._lut) & self._present
        if self._p is not None:                      # a birth happens with probability p
            new &= self._alive | (state.rng().random(len(new)) < self._p)
        changed = bool(np.any(new != self._alive))
        self._ever |= new
        self._age = next_age(self._age, new, self._ever, self.age_mode)
        self._alive = new
        self._write(dom)
        return changed

    def finish(self, state: State) -> None:
        n = max(len(self._alive), 1)
        ever = self._ever if self._run is None else self._run.ever
        state.report(f"{self.cells}.{self.field}.live_fraction", float(self._alive.sum() / n))
        state.report(f"{self.cells}.{self.field}.ever_alive_fraction", float(ever.sum() / n))
