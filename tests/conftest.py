"""Shared test fixtures: the test-data folder."""
from __future__ import annotations

from pathlib import Path

import pytest

#: Test data shipped with the tests.
DATA = Path(__file__).resolve().parent / "data"


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """tests/data."""
    return DATA
