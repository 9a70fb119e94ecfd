"""The long trials of tests/unit/test_extract_flags.py, whose helpers and fixtures
they import; tests/trials marks them ``trials`` (``make trials`` runs them)."""
from __future__ import annotations

import pytest

from tests.unit.test_extract_flags import (  # noqa: F401 - fixtures, used by name
    STICK_SLIP_TESTS,
    check_off,
    check_on,
    run_case,
    stick_slip_rate,
    tir,
)


@pytest.mark.parametrize("on", [True, False], ids=["injected", "absent"])
def test_flag_trials_20_seeds_full_grid(tir, tmp_path, on):  # noqa: F811
    """Acceptance 3 as stated: 20 seeds each, full grid; prints the flag counts per seed."""
    failures = []
    for seed in range(100, 120):
        extraction, truth = run_case(tir, tmp_path / f"s{seed}", seed, on, "full")
        counts: dict[str, int] = {}
        for f in extraction.flags:
            counts[f["flag"]] = counts.get(f["flag"], 0) + 1
        rates = {t: [round(stick_slip_rate(extraction, t, p), 2) for p in (1.9, 3.0)]
                 for t in STICK_SLIP_TESTS}
        print(f"seed {seed} {'on' if on else 'off'}: {counts}; stick-slip rate at 1.9 and "
              f"3.0 bar: {rates}")
        try:
            check_on(extraction, truth) if on else check_off(extraction)
        except AssertionError as exc:
            failures.append(f"seed {seed}: {exc}")
    assert not failures, failures
