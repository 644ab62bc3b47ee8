"""Paths the tests share (the repository root and the shared real meshes beside it)."""
from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
SHARED_MESHES = ROOT.parent / "shared" / "meshes"
