"""Fixtures of the logic tests: a private DFA cache for every test."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture(autouse=True)
def private_cache(
    tmp_path_factory: pytest.TempPathFactory, monkeypatch: pytest.MonkeyPatch
) -> Path:
    """Never touch ~/.cache: every logic test caches under a temporary directory."""
    directory = tmp_path_factory.getbasetemp() / "dfa-cache"
    monkeypatch.setenv("NOISYBOLT_CACHE_DIR", str(directory))
    return directory
