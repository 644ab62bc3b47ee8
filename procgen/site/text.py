"""Card and page text whose numbers come from the run, never from the keyboard.

A gallery entry's title, caption and "how ours differs" line name numbers as placeholders that
are filled from the run's run.json when the page is written, so a quick run, a thesis-scale run
and a re-tuned recipe each print their own numbers and a card cannot contradict its run:

- ``{KEY}``: the run's report KEY (``{cells.n_cells}``), read as :func:`inline_number` reads it;
- ``{steps.ID.params.NAME}`` / ``{steps.ID.iterations}``: a step's parameter after the entry's
  overrides, from the resolved recipe;
- ``{thesis.KEY}``: the entry's own ``thesis`` table (the thesis's number for report KEY);
- text in backticks is a formula or a constant (`` `P = sqrt(2)/2 - 1/2` ``), shown as code.

A placeholder the run cannot fill prints "?" and is returned as missing, so the gallery can say so.
"""
from __future__ import annotations

import html
import re
from typing import Any

from .numbers import format_number, inline_number

PLACEHOLDER = re.compile(r"\{([A-Za-z_][\w.\-]*)\}")
CODE = re.compile(r"`([^`]*)`")

#: references and words whose digits are not results: figure and section numbers, dimensions
REFERENCE = re.compile(
    r"\b(?:Plates?|Figs?\.?|Figures?|Tables?|[Ss]ections?|[Cc]hapters?|[Ee]qs?\.|[Ee]quations?|"
    r"[Aa]ppendix|§)\s*[A-D]?[-.]?\d+(?:[.\-]\d+)*(?:\s*\([a-z](?:\)?\s*(?:-|to|,|and)\s*\(?[a-z])*\))?[a-z]?"
    r"(?:\s*(?:/|,|-|to|and|&)\s*[A-D]?[-.]?\d+(?:[.\-]\d+)*(?:\([a-z]\))?[a-z]?)*"
    r"|\b[123](?:\.5)?-D\b")


def _step(info: dict[str, Any], step_id: str) -> dict[str, Any] | None:
    """The step ``step_id`` (its recipe id, or its position) as it ran: every parameter, the
    defaults included, and its iterations."""
    steps = info.get("resolved_recipe", {}).get("steps", [])
    ran = info.get("steps", [])
    for i, st in enumerate(steps):
        if str(st.get("id", "")) == step_id or str(i) == step_id:
            done = ran[i] if i < len(ran) and isinstance(ran[i], dict) else {}
            return {"iterations": done.get("iterations", st.get("iterations", 1)),
                    "params": {**st.get("params", {}), **done.get("params", {})},
                    "frames": st.get("frames", {})}
    return None


def lookup(key: str, info: dict[str, Any], thesis: dict[str, float]) -> str | None:
    """The text a placeholder stands for, or None when this run cannot fill it."""
    if key.startswith("thesis."):
        k = key[len("thesis."):]
        return inline_number(k, thesis[k]) if k in thesis else None
    if key.startswith("steps."):
        parts = key.split(".")
        st = _step(info, parts[1]) if len(parts) >= 3 else None
        if st is None:
            return None
        if parts[2:] == ["iterations"]:
            return format_number(st.get("iterations", 1))
        if parts[2:] == ["frames", "every"] and "every" in st["frames"]:
            return format_number(st["frames"]["every"])
        if len(parts) == 4 and parts[2] == "params" and parts[3] in st.get("params", {}):
            v = st["params"][parts[3]]
            return ", ".join(format_number(x) for x in v) if isinstance(v, list) else format_number(v)
        return None
    value = info.get("reports", {}).get(key)
    if value is None or isinstance(value, dict):
        return None
    return inline_number(key, value)


def fill(text: str, info: dict[str, Any], thesis: dict[str, float]) -> tuple[str, list[str]]:
    """(HTML, placeholders this run could not fill) for an entry's ``text``."""
    missing: list[str] = []
    out: list[str] = []
    pos = 0
    for m in CODE.finditer(text):
        out.append(_fill_plain(text[pos:m.start()], info, thesis, missing))
        out.append(f"<code>{html.escape(m.group(1))}</code>")
        pos = m.end()
    out.append(_fill_plain(text[pos:], info, thesis, missing))
    return "".join(out), missing


def _fill_plain(text: str, info: dict[str, Any], thesis: dict[str, float], missing: list[str]) -> str:
    parts: list[str] = []
    pos = 0
    for m in PLACEHOLDER.finditer(text):
        parts.append(html.escape(text[pos:m.start()]))
        value = lookup(m.group(1), info, thesis)
        if value is None:
            missing.append(m.group(1))
            value = "?"
        parts.append(f'<span class="num" title="{html.escape(m.group(1))}">{html.escape(value)}</span>')
        pos = m.end()
    parts.append(html.escape(text[pos:]))
    return "".join(parts)


def plain(text: str, info: dict[str, Any], thesis: dict[str, float]) -> str:
    """The filled text without markup (for a page title)."""
    return html.unescape(re.sub(r"<[^>]+>", "", fill(text, info, thesis)[0])) if text else ""


def typed_numbers(text: str) -> list[str]:
    """Digits in ``text`` that are neither a placeholder, a formula in backticks nor a reference:
    numbers typed by hand, which a card must not have."""
    rest = REFERENCE.sub(" ", CODE.sub(" ", PLACEHOLDER.sub(" ", text)))
    return re.findall(r"[^\s]*\d[^\s]*", rest)
