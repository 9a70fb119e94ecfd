"""Shared test fixtures: the specification folder (reference data) and the test-data folder."""
from __future__ import annotations

from pathlib import Path

import pytest

#: The read-only specification next to the repository (../shared/spec).
SPEC = Path(__file__).resolve().parents[1].parent / "shared" / "spec"
#: Test data shipped with the tests.
DATA = Path(__file__).resolve().parent / "data"

_NO_SPEC = f"specification folder not found at {SPEC} (tests marked 'spec' need ../shared/spec)"


def pytest_collection_modifyitems(config, items):
    """Skip every test marked ``spec`` when the specification folder is absent."""
    if SPEC.is_dir():
        return
    skip = pytest.mark.skip(reason=_NO_SPEC)
    for item in items:
        if "spec" in item.keywords:
            item.add_marker(skip)


@pytest.fixture(scope="session")
def spec_dir() -> Path:
    """The specification folder; skips the test if it is absent."""
    if not SPEC.is_dir():
        pytest.skip(_NO_SPEC)
    return SPEC


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """tests/data."""
    return DATA
