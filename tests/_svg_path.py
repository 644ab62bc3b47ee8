"""Path data read back as points by svgelements (what vpype and procgen's SVG loader use), so
tests check coordinates, not the text's form (relative moves, implicit commands: issue 34)."""
from __future__ import annotations

import numpy as np
import svgelements


def decode(d: str) -> list[tuple[np.ndarray, bool]]:
    """Each subpath of ``d`` as (absolute points (k, 2), closed); a closing "z" adds no point."""
    out: list[tuple[list, bool]] = []
    for seg in svgelements.Path(d):
        if isinstance(seg, svgelements.Move):
            out.append(([(seg.end.x, seg.end.y)], False))
        elif isinstance(seg, svgelements.Close):
            out[-1] = (out[-1][0], True)
        elif isinstance(seg, svgelements.Line):
            out[-1][0].append((seg.end.x, seg.end.y))
    return [(np.array(p, float).reshape(-1, 2), c) for p, c in out]


def d_points(d: str) -> np.ndarray:
    """Every point of ``d`` (all subpaths, in order) as one (n, 2) array."""
    lines = decode(d)
    return np.vstack([p for p, _ in lines]) if lines else np.zeros((0, 2))
