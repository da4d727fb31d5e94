"""Shared test fixtures: the read-only real data in ../shared/data (skipped when absent)."""
from __future__ import annotations

from pathlib import Path

import pytest

SHARED_DATA = Path(__file__).resolve().parents[1].parent / "shared" / "data"


def shared_file(relative: str) -> Path:
    """A file of ../shared/data, or skip the test when it is not there (a user's machine)."""
    path = SHARED_DATA / relative
    if not path.exists():
        pytest.skip(f"shared test data {relative} not available")
    return path
