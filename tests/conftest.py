"""Shared test fixtures."""

from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
ROBOBALL = REPO.parent / "shared" / "data" / "roboball"


@pytest.fixture(scope="session")
def roboball_dir() -> Path:
    """The real robot logs, read from ../shared (never copied into the repo)."""
    if not ROBOBALL.is_dir():
        pytest.skip(f"real robot logs not found at {ROBOBALL}")
    return ROBOBALL
