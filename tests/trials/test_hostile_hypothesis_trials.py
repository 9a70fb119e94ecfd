"""The long trials of tests/unit/test_hostile_hypothesis.py, whose helpers and fixtures
they import; tests/trials marks them ``trials`` (``make trials`` runs them)."""
from __future__ import annotations

import pytest

from tests.unit.test_hostile_hypothesis import (
    READERS,
    _test,
)


@pytest.mark.parametrize("kind", list(READERS))
def test_reader_10000_cases(kind):
    _test(kind, 10_000)()
