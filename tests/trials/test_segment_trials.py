"""Segmentation acceptance over 20 seeds (``make trials``): on every simulated TTC session the
levels found are the set points (all, none extra), every programmed sweep is found once at its
levels, and no warm-up or cold-tread sample is kept (tests/segment_cases.py)."""
from __future__ import annotations

import pytest

from tests.segment_cases import check
from tests.ttc_cases import session

pytestmark = pytest.mark.trials


@pytest.mark.parametrize("seed", range(100, 120))
def test_segmentation_finds_the_set_points(tmp_path, seed):
    check(session(tmp_path / "s", seed=seed))
