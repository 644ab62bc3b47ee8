"""The memory a run will need, estimated by ``procgen check`` from the recipe alone.

Why: what cannot fit must be refused in one line naming the step or output, with the estimate
and the limit, before any compute; not after minutes of it by MemoryError or the kernel's OOM
killer. At its peak a run holds

- what every step allocates: ``RuleBase.memory_estimate``, which may use the sizes of the
  domains it works on; ``RuleBase.domain_sizes`` lets those sizes flow like the data;
- the bytes of every frame and output file, which the runner keeps until all of them succeeded
  and then writes at once (a run folder is written whole or not at all);
- the working memory of the one export being rendered.

An export's cost is known here for the core exporters and, for any exporter with integer options
``width`` and ``height``, from its pixel count (a raster renderer); other exporters count as
small. The figures are measured peaks (tracemalloc) rounded up; they are estimates, made to catch
``scale = 100000`` or 20,000 kept frames, not to tune a recipe to the last megabyte.
"""
from __future__ import annotations

import inspect
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Mapping

from .errors import ProcgenError, RecipeError

if TYPE_CHECKING:
    from .exchange.registry import Exporter
    from .recipes import Step
    from .rules import RuleBase

GiB = 2**30
#: frames one run may write: each is a file kept in memory until the run is written
MAX_FRAMES = 10_000
#: preview_png's peak per pixel (face ids, colours, barycentrics, PNG): 430-465 bytes measured
RENDER_BYTES_PER_PIXEL = 480
#: image_png: the repeated RGB rows and the PNG, per output pixel; the colour mapping per cell
IMAGE_BYTES_PER_PIXEL = 6
IMAGE_BYTES_PER_CELL = 128
#: per element of the exported domain (grid cell, mesh face): (working bytes, file bytes), measured
PER_ELEMENT = {"heightmap_png16": (24, 2), "npy": (32, 8), "geotiff": (32, 4),
               "glb": (200, 40), "obj": (260, 64)}
#: the least a field a step writes costs per element (one float64)
FIELD_BYTES = 8


def rule_memory(rule: "RuleBase", sizes: Mapping[str, int]) -> int:
    """The rule's own estimate (passed ``sizes`` when it takes them), never less than one float64
    per element of every field it writes on a domain of known size."""
    estimate = rule.memory_estimate
    need = int(estimate(sizes) if inspect.signature(estimate).parameters else estimate())
    floor = sum(FIELD_BYTES * sizes.get(spec.domain, 0) for spec in rule.field_specs()
                if spec.intent in ("out", "inout"))
    return max(need, floor)


def export_cost(exporter: "Exporter", options: Mapping[str, Any], n: int | None) -> tuple[int, int, str, str]:
    """(working bytes, file bytes, what makes them so, what to lower) of one export of a domain of
    ``n`` elements (None: unknown size)."""
    given = {k: p.default for k, p in inspect.signature(exporter.func).parameters.items()
             if p.default is not inspect.Parameter.empty} | dict(options)
    if exporter.name == "image_png":
        scale = given.get("scale", 1)
        cells = max(n or 1, 1)
        pixels = cells * scale * scale
        return (IMAGE_BYTES_PER_PIXEL * pixels + IMAGE_BYTES_PER_CELL * cells, 3 * pixels,
                f"scale = {scale} on {cells:,} cells: {pixels:.3g} pixels", "lower option 'scale'")
    width, height = given.get("width"), given.get("height")
    if all(isinstance(v, int) and not isinstance(v, bool) for v in (width, height)):
        pixels = width * height
        return (RENDER_BYTES_PER_PIXEL * pixels, 3 * pixels, f"width x height = {width} x {height} pixels",
                "lower options 'width' and 'height'")
    per = PER_ELEMENT.get(exporter.name)
    if per is not None and n:
        return per[0] * n, per[1] * n, f"{n:,} elements", "export a smaller domain"
    return 0, 0, "", ""


@dataclass
class Budget:
    """The running estimate of one recipe's check: charge steps, frames and outputs in order."""

    source: str
    limit: int
    sizes: dict[str, int] = field(default_factory=dict)
    held: int = 0          # steps' memory and the file bytes kept until the run is written
    working: int = 0       # the largest export's working memory (one export runs at a time)
    frames: int = 0

    def step(self, step: "Step") -> None:
        where = f"{self.source}: {step_name(step)}"
        rule = step.rule
        try:
            self.sizes.update(rule.domain_sizes(self.sizes))
            need = rule_memory(rule, self.sizes)
        except ProcgenError:
            raise
        except (ValueError, ArithmeticError) as exc:
            raise RecipeError(f"{where}: cannot estimate its memory ({exc})") from None
        self._charge(where, need, 0, "", "reduce its size")

    def frame_series(self, step: "Step", exporter: "Exporter") -> None:
        """The frames of ``step``: every ``every``-th of at most ``iterations`` iterations."""
        fr = step.frames
        assert fr is not None
        where = f"{self.source}: {step_name(step)}: frames"
        count = step.iterations // fr.every
        self.frames += count
        if self.frames > MAX_FRAMES:
            upto = "up to " if step.until_stable else ""
            raise RecipeError(f"{where}: {upto}{count:,} frames (every {fr.every} of {step.iterations:,} "
                              f"iterations), more than the {MAX_FRAMES:,} a run may write; raise 'every'")
        working, files, why, lower = export_cost(exporter, fr.options, self.sizes.get(fr.domain))
        detail = f"{count:,} frames of {why}" if why else f"{count:,} frames"
        self._charge(where, files * count, working, detail, "raise 'every'" + (f" or {lower}" if lower else ""))

    def output(self, where: str, file: str, exporter: "Exporter", domain: str, options: Mapping[str, Any]) -> None:
        working, files, why, lower = export_cost(exporter, options, self.sizes.get(domain))
        self._charge(f"{where} {file!r} ({exporter.name})", files, working, why, lower)

    def _charge(self, where: str, held: int, working: int, why: str, hint: str) -> None:
        item = held + working
        total = self.held + held + max(self.working, working)
        detail = f" ({why})" if why else ""
        limit = f"more than the {_size(self.limit)} this machine can give; {hint}"
        if item > self.limit:
            raise RecipeError(f"{where}: needs about {_size(item)}{detail}, {limit}")
        if total > self.limit:
            raise RecipeError(f"{where}: brings the run to about {_size(total)} (this part "
                              f"{_size(item)}{'; ' + why if why else ''}), {limit}")
        self.held += held
        self.working = max(self.working, working)


def _size(nbytes: int) -> str:
    return f"{nbytes / GiB:,.1f} GiB" if nbytes >= GiB else f"{nbytes / 2**20:,.1f} MiB"


def step_name(step: "Step") -> str:
    """``steps[3] 'erode' (water.drops)``: position, id when it has one, rule."""
    return f"steps[{step.index}]" + (f" {step.id!r}" if step.id else "") + f" ({step.rule.name})"
