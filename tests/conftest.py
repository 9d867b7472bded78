"""Shared test fixtures: where the real-server captures live."""
from __future__ import annotations

from pathlib import Path

import pytest

#: Real traffic captured from rcssserver3d 0.7.3 lives beside the repository, in ../shared/.
FIXTURES = Path(__file__).resolve().parents[1].parent / "shared" / "fixtures" / "rcssserver3d"


@pytest.fixture(scope="session")
def fixtures_dir() -> Path:
    if not FIXTURES.is_dir():
        pytest.fail(f"real-server fixtures not found at {FIXTURES}")
    return FIXTURES
