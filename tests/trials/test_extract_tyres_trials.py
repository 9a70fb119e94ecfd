"""The long trials of tests/unit/test_extract_tyres.py, whose helpers and fixtures
they import; tests/trials marks them ``trials`` (``make trials`` runs them)."""
from __future__ import annotations

import pandas as pd

from tests.unit.test_extract_tyres import (
    TYRES,
    check,
    extract_against_truth,
    worst_by_quantity,
)


def test_three_tyres_three_seeds(tmp_path):
    """All three tyres x seeds 1, 2, 3 on the full grid; prints the worst cell per tyre and
    quantity over the seeds."""
    failures = []
    for tyre, tir in TYRES.items():
        tables = []
        for seed in (1, 2, 3):
            table = extract_against_truth(tir, tmp_path / f"{tyre}_s{seed}", seed)
            try:
                check(table)
            except AssertionError as exc:
                failures.append(f"{tyre} seed {seed}: {exc}")
            tables.append(table.assign(seed=seed))
        worst_by_quantity(pd.concat(tables, ignore_index=True), f"{tyre}, seeds 1-3")
    assert not failures, "\n".join(failures)
