"""How a report's number reads on a page: its unit from its key, 3 significant figures.

One place decides this, so a card's title, an entry page's table and ``procgen run``'s summary
print the same number the same way.
"""
from __future__ import annotations

from typing import Any

#: how a report reads, by the end of its key: (unit, factor); fractions are shown as percentages
_REPORT_UNITS = (("_pct", "%", 1.0), ("completion_r", "%", 100.0), ("_fraction", "%", 100.0),
                 ("start_share", "%", 100.0), ("saturation_ratio", "x", 1.0), ("steps_to_", "steps", 1.0),
                 ("n_cells", "cells", 1.0), ("n_faces", "triangles", 1.0))


def report_unit(key: str) -> tuple[str, float]:
    """(unit, factor) a report is read in, from its key (e.g. a completion 0.962 -> 96.2 %)."""
    leaf = key.rsplit(".", 1)[-1]
    for end, unit, factor in _REPORT_UNITS:
        if end in leaf:
            return unit, factor
    return "", 1.0


def format_number(value: Any, unit: str = "", factor: float = 1.0) -> str:
    """A number as people read it: integers whole (thousands separated), others to 3
    significant figures; ``None`` as a dash; the unit after a space ("96.2 %")."""
    if value is None:
        return "-"
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        return str(value)
    v = value * factor
    if abs(v) < 1e15 and float(v).is_integer():
        text = f"{int(v):,}"
    elif 1000 <= abs(v) < 1e15:
        text = f"{int(float(f'{v:.3g}')):,}"           # 3 significant figures, no exponent
    else:
        text = f"{v:.3g}"
    return f"{text} {unit}".rstrip() if unit not in ("x",) else f"{text}x"


def report_text(key: str, value: Any, thesis: dict[str, float]) -> str:
    """``key = measured`` with the thesis's figure beside it when the entry names one."""
    unit, factor = report_unit(key)
    text = f"{key} = {format_number(value, unit, factor)}"
    if key in thesis:
        text += f" (thesis: {format_number(thesis[key], unit, factor)})"
    return text


def inline_number(key: str, value: Any) -> str:
    """A report's number inside a sentence: percentages keep their sign ("96.2 %"), ratios
    their "x"; word units (cells, steps) are left for the sentence to say."""
    unit, factor = report_unit(key)
    if isinstance(value, (list, tuple)):
        return ", ".join(inline_number(key, v) for v in value)
    return format_number(value, unit if unit in ("%", "x") else "", factor)
