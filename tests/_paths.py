"""Paths the tests share: the repository root and the meshes shipped inside it.

Tests never read the shared folder beside the repository: the real meshes they need (spot, the teapot, the decimated bunny)
ship in procgen/data/meshes, and the other cases are built procedurally in ``_meshes.py``.
"""
from __future__ import annotations

from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
MESHES = ROOT / "procgen" / "data" / "meshes"
