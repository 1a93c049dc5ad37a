"""Fixtures of the compiler's tests."""

from __future__ import annotations

from pathlib import Path

import pytest


@pytest.fixture
def folder(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """The cache's folder for this test alone (``MCL_CACHE_DIR``), not made yet."""
    place = tmp_path / "cache"
    monkeypatch.setenv("MCL_CACHE_DIR", str(place))
    return place
