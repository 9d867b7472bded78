"""Shared test fixtures: where the real-server captures live."""

from __future__ import annotations

import os
from pathlib import Path
from typing import NoReturn

import pytest

#: Real traffic captured from rcssserver3d 0.7.3 (its README says how): data from the real server,
#: kept with the tests so that a plain clone passes them.
FIXTURES = Path(__file__).resolve().parent / "data" / "rcssserver3d"


@pytest.fixture(scope="session")
def fixtures_dir() -> Path:
    if not FIXTURES.is_dir():
        pytest.fail(f"real-server fixtures not found at {FIXTURES}")
    return FIXTURES


#: Set to 1 where a real server must be there (CI builds one): its tests then fail instead of skipping.
REQUIRE_REAL_SERVER_ENV = "GALA_REQUIRE_REAL_SERVER"


@pytest.fixture(scope="session")
def rcssserver3d() -> str:
    """The real server's command (``RCSSSERVER3D``, else ``rcssserver3d`` on PATH); tests that need
    one are skipped, with the reason, where none is configured."""
    from optimizer.episode.real_server import RealServerError, find_rcssserver3d

    try:
        return find_rcssserver3d()
    except RealServerError as exc:
        missing_real_server_part(f"a real server: {exc}")


def missing_real_server_part(what: str) -> NoReturn:
    """Skip the test for lack of ``what`` (the real server or what its build installs), with the
    reason; fail instead where a real server must be there (``GALA_REQUIRE_REAL_SERVER=1``)."""
    if os.environ.get(REQUIRE_REAL_SERVER_ENV) == "1":
        pytest.fail(f"{REQUIRE_REAL_SERVER_ENV}=1 but this test needs {what}")
    pytest.skip(f"needs {what}")
