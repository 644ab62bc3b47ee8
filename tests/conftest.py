"""Shared fixtures: one plugin host per session (building it loads every entry point)."""
from __future__ import annotations

from pathlib import Path

import pytest

from procgen import get_plugin_manager

ROOT = Path(__file__).resolve().parent.parent
SHARED_MESHES = ROOT.parent / "shared" / "meshes"


@pytest.fixture(scope="session")
def host():
    h = get_plugin_manager()
    assert not h.broken, f"broken plugins: {[(b.name, b.error) for b in h.broken]}"
    return h
