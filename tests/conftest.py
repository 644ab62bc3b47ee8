"""Shared fixtures: one plugin host per session (building it loads every entry point)."""
from __future__ import annotations

import pytest

from procgen import get_plugin_manager


@pytest.fixture(scope="session")
def host():
    h = get_plugin_manager()
    assert not h.broken, f"broken plugins: {[(b.name, b.error) for b in h.broken]}"
    return h
