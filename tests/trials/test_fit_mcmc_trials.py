"""The long trials of tests/integration/test_fit_mcmc.py, whose helpers and fixtures
they import; tests/trials marks them ``trials`` (``make trials`` runs them)."""
from __future__ import annotations

from identify.fit.mcmc.chains import run_mcmc
from identify.fit.optimize import fit
from tests.integration.test_fit_mcmc import (
    TRUTH,
    _problem,
)


def test_credible_intervals_are_calibrated():
    """90 % credible intervals contain the truth in >= 85 % of 40 seeded trials at 1 % noise."""
    hits, total = 0, 0
    for seed in range(40):
        problem = _problem(100 + seed)
        m = run_mcmc(problem, fit(problem), seed=seed).mcmc
        for name in ("nom", "p1", "p3"):
            lo, hi = m.interval(name, 0.90)
            hits += lo <= TRUTH[name] <= hi
            total += 1
    print(f"calibration: {hits}/{total} = {hits / total:.1%} inside the 90 % interval")
    assert hits / total >= 0.85
