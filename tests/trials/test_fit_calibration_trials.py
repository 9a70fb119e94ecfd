"""The long trials of tests/unit/test_fit_calibration.py, whose helpers and fixtures
they import; tests/trials marks them ``trials`` (``make trials`` runs them)."""
from __future__ import annotations

import pytest

from tests.unit.test_fit_calibration import (
    CASES,
    MIN_RATE,
    calibrate,
)


@pytest.mark.parametrize("case", CASES, ids=lambda c: c.name)
def test_credible_intervals_cover_the_truth(case):
    s = calibrate(case)
    assert s["converged"] == s["trials"], "a chain stopped before 50 autocorrelation times"
    assert s["rate"] >= MIN_RATE
