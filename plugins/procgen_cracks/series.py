"""Time series of the crack and peeling runs, as data and as plots (3DSCA thesis Figures 5.19, 5.28).

Figure 5.19 plots, for the run of plate 5.9(g), the number of crack modules (CMs) alive at each
CM step (at most about 7,300, a local minimum of 790) and the share of the stress released so
far, with the released share of run (e) beside it.  Figure 5.28 plots the convergence of the
peeling-group determination: the share of the cells that hold their group after each pass
(99.9 % after 28 passes for about 1.8 M cells).

:class:`StepLog` is what ``cracks.propagate`` feeds at each CM step (a count and the running
total of the release, nothing per cell); at the end it publishes the series as a Polylines domain
``<lines>_series`` and the run's own numbers under ``<lines>.*`` report keys, so that several
crack runs in one recipe (plate 5.9's (e), (f), (g)) keep their own reports.
``cracks.peel_convergence`` turns the peeling levels of ``cracks.peel`` into the convergence
curve; ``crack_series_png`` plots either series with matplotlib.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, ClassVar

import numpy as np

from procgen import Exporter, FieldSpec, InputError, Polylines, RuleBase, State, param

#: line names of the crack series domain, in line order (a line field carries the index)
CRACK_LINES = ("modules alive", "stress released (%)", "unstable cells (%)")
PEEL_LINES = ("cells with their group (%)",)


class StepLog:
    """Per CM step: CMs alive and the share of the initial stress released so far.

    ``spec`` is the (n, L, 4) spectrum at the start; ``active`` the (n, L) cells carrying
    stressed material.  The released share is (stress released so far) / (stress at the
    start), over the four axes of every active cell (the thesis's 'stress release percentage',
    Figure 5.19's blue curve).  The release is the only thing that changes the spectrum during
    a run, and it only ever lowers it, so :meth:`record` is given the running total of what
    the modules released (``Modules.released``, kept by the release itself) instead of summing
    the whole spectrum at every CM step (O(cells) per step: about 5 ms on 95,000 cells, which
    over plate 5.9(g)'s thousands of steps was a sizeable part of the run).
    """

    def __init__(self, spec: np.ndarray, active: np.ndarray) -> None:
        self._active = np.asarray(active, bool)
        self._total0 = float(np.asarray(spec)[self._active].sum())
        self.step: list[int] = []
        self.alive: list[int] = []
        self.released: list[float] = []
        self.series_end: list[int] = []
        self.unstable: list[float] = []

    def record(self, n_live: int, released: float) -> None:
        """One CM step: called after ``Modules.step`` with the CMs still alive and the stress
        released since the start of the run (summed over the active cells)."""
        self.step.append(len(self.step) + 1)
        self.alive.append(int(n_live))
        self.released.append(100.0 * float(released) / self._total0 if self._total0 > 0 else 0.0)

    def end_series(self, unstable_fraction: float) -> None:
        """One series (one iteration of the rule) ended: the unstable share at that CM step."""
        self.series_end.append(len(self.step))
        self.unstable.append(100.0 * float(unstable_fraction))

    def polylines(self) -> Polylines:
        """Line 0: (CM step, CMs alive); 1: (step, % released); 2: (step, % unstable) per series."""
        s = np.asarray(self.step, float)
        lines = [np.column_stack([s, self.alive]), np.column_stack([s, self.released]),
                 np.column_stack([np.asarray(self.series_end, float), self.unstable])]
        lines = [ln if len(ln) else np.zeros((1, 2)) for ln in lines]
        offsets = np.cumsum([0] + [len(ln) for ln in lines])
        pl = Polylines(np.concatenate(lines), offsets)
        pl.add_field("series__line", np.arange(len(lines)), at="line", doc="0 CMs, 1 released %, 2 unstable %")
        return pl

    def publish(self, state: State, key: str, *, start_unstable: float, unstable: float,
                active_cells: int, cracks: int) -> None:
        """The series as domain ``<key>_series``; this run's numbers as ``<key>.*`` reports."""
        state.add_domain(f"{key}_series", self.polylines())
        alive = np.asarray(self.alive, np.int64)
        state.report(f"{key}.unstable_start_fraction", float(start_unstable))
        state.report(f"{key}.unstable_start_cells", int(round(start_unstable * active_cells)))
        state.report(f"{key}.unstable_fraction", float(unstable))
        state.report(f"{key}.active_cells", int(active_cells))
        state.report(f"{key}.cracks", int(cracks))
        state.report(f"{key}.cm_steps", int(len(alive)))
        state.report(f"{key}.max_modules", int(alive.max(initial=0)))
        state.report(f"{key}.series", int(len(self.series_end)))
        state.report(f"{key}.stress_released_pct", float(self.released[-1]) if self.released else 0.0)


def convergence_curve(level: np.ndarray, counted: np.ndarray) -> np.ndarray:
    """Share of the ``counted`` cells that hold a group after pass k = 0..D (Figure 5.28).

    ``level``: ``peel__level`` (0 cracked, k reached at pass k, -1 never).  Cracked cells count
    from pass 0; cells no pass reaches (a group with no border) never count, so the curve may
    stop short of 1.
    """
    lv = np.asarray(level)[np.asarray(counted, bool)]
    n = max(len(lv), 1)
    reached = lv[lv >= 0]
    hist = np.bincount(reached, minlength=1) if len(reached) else np.zeros(1, np.int64)
    return np.cumsum(hist) / n


@dataclass(kw_only=True)
class PeelConvergence(RuleBase):
    """The convergence of the peeling groups pass by pass (thesis Figure 5.28), from ``cracks.peel``.

    Reads ``peel__level`` (run ``cracks.peel`` with ``grow = false`` or to the end of its growth,
    so every level is written) and creates a Polylines ``{series}`` with one line (pass, % of
    the layer's cells that hold their group); reports ``peel.passes``, the passes to reach
    ``target`` and the share converged at the end.
    """

    name: ClassVar[str] = "cracks.peel_convergence"
    uses: ClassVar[dict[str, str]] = {"{cells}": "SurfaceCells"}
    creates: ClassVar[dict[str, str]] = {"{series}": "Polylines"}
    default_iterations: ClassVar[int] = 1
    fields: ClassVar[tuple[FieldSpec, ...]] = (
        FieldSpec("peel__level", "{cells}", "cell", "in", doc="cells from the crack border"),
        FieldSpec("layers__thickness", "{cells}", "cell", "in", units="length", doc="thickness per layer"),
        FieldSpec("series__line", "{series}", "line", "out", dtype="int64", doc="0 converged %"),)
    example: ClassVar[tuple[dict, ...]] = (
        {"rule": "mesh.primitive", "params": {"shape": "cube", "subdivisions": 0}},
        {"rule": "surface.cells", "params": {"target_cells": 1500}},
        {"rule": "layers.stack", "params": {"layers": ["copper", {"preset": "patina", "thickness": 0.5}]}},
        {"rule": "cracks.imposed", "params": {"seeds": 8}},
        {"rule": "cracks.peel", "params": {"grow": False, "peel_share": 0.0}},
        {"rule": "cracks.peel_convergence"},
    )
    cells: str = param("cells", doc="SurfaceCells domain peeled by cracks.peel")
    series: str = param("peel_convergence", doc="name of the Polylines series to create")
    layer: str = param("", doc="material name of the peeling layer ('' = the top layer), as cracks.peel")
    target: float = param(0.999, gt=0.0, le=1.0, doc="share whose pass count is reported (thesis 0.999)")

    def step(self, state: State) -> bool:
        dom = state.get(self.cells)
        if "peel__level" not in dom:
            raise InputError(f"{self.name}: {self.cells!r} has no peel__level (run cracks.peel first)")
        from .peel import layer_index

        level = np.asarray(dom["peel__level"]).reshape(-1)
        # the peeling layer's cells: those that reached a level, and those that still hold the
        # layer (a group no pass reaches counts against the convergence, a bare cell does not)
        thick = np.asarray(dom["layers__thickness"], float)[:, layer_index(dom, self.layer, self.name)]
        counted = (level >= 0) | (thick > 0)
        if hasattr(dom, "alive"):
            counted &= np.asarray(dom.alive(), bool)
        curve = convergence_curve(level, counted)
        k = np.arange(len(curve), dtype=float)
        pl = Polylines(np.column_stack([k, 100.0 * curve]), np.array([0, len(curve)]))
        pl.add_field("series__line", np.array([0]), at="line", doc="0 converged %")
        state.add_domain(self.series, pl)
        hit = np.nonzero(curve >= self.target - 1e-12)[0]
        state.report("peel.passes", int(len(curve) - 1))
        state.report("peel.passes_to_target", int(hit[0]) if len(hit) else -1)
        state.report("peel.converged_share", float(curve[-1]))
        return True


def crack_series_png(domain: Any, *, stem: str = "", provenance: dict | None = None,
                     title: str = "", kind: str = "cracks", width: float = 6.4, height: float = 3.8,
                     target: float = 99.9) -> bytes:
    """Plot of a crack series (CMs alive on the left axis, % released and % unstable on the
    right, as Figure 5.19) or of a peeling convergence (``kind = "peel"``, Figure 5.28)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from procgen.exchange import png_bytes

    if not isinstance(domain, Polylines) or "series__line" not in domain:
        raise InputError("crack_series_png: expected a series Polylines (cracks.propagate's "
                         "<lines>_series or cracks.peel_convergence)")
    if kind not in ("cracks", "peel"):
        raise InputError(f"crack_series_png: kind must be cracks or peel, got {kind!r}")
    fig, ax = plt.subplots(figsize=(width, height), dpi=100)
    if kind == "peel":
        c = domain.line(0)
        ax.plot(c[:, 0], c[:, 1], "o-", color="#2a5db0", lw=2, ms=3, label=PEEL_LINES[0])
        ax.axhline(target, color="#999999", lw=0.8, ls="--", label=f"{target:g} %")
        ax.set_xlabel("pass")
        ax.xaxis.get_major_locator().set_params(integer=True)
        ax.set_ylabel("% of cells")
        ax.set_ylim(0, 102)
        ax.legend(loc="lower right", fontsize=8)
    else:
        cm = domain.line(0)
        ax.plot(cm[:, 0], cm[:, 1], color="#b03a2e", lw=1.2, label=CRACK_LINES[0])
        ax.set_xlabel("CM step")
        ax.set_ylabel("crack modules alive", color="#b03a2e")
        ax2 = ax.twinx()
        rel = domain.line(1)
        ax2.plot(rel[:, 0], rel[:, 1], color="#2a5db0", lw=1.6, label=CRACK_LINES[1])
        if domain.n_lines > 2:
            un = domain.line(2)
            ax2.plot(un[:, 0], un[:, 1], ".--", color="#6c6c6c", lw=0.8, ms=3, label=CRACK_LINES[2])
        ax2.set_ylim(0, 102)
        ax2.set_ylabel("% of the stress / of the cells")
        h1, l1 = ax.get_legend_handles_labels()
        h2, l2 = ax2.get_legend_handles_labels()
        ax.legend(h1 + h2, l1 + l2, loc="upper left", fontsize=8, framealpha=0.85)
    ax.grid(alpha=0.3)
    if title:
        ax.set_title(title)
    fig.tight_layout()
    fig.canvas.draw()
    rgb = np.asarray(fig.canvas.buffer_rgba())[..., :3].copy()
    plt.close(fig)
    return png_bytes(rgb, provenance)


RULES = [PeelConvergence]
EXPORTERS = [
    Exporter(name="crack_series_png", kinds=("Polylines",), suffix=".png", func=crack_series_png,
             doc="plot of a crack run's series (CMs alive, stress released; Figure 5.19) or of the "
                 "peeling convergence (Figure 5.28)"),
]
