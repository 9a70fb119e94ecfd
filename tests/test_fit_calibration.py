"""Calibration of the MCMC credible intervals (issue 5, acceptance 3), behind the trials marker.

For every relation: 40 seeded data sets with 1 % noise from known coefficients; the 90 %
credible interval must contain the true coefficient in >= 85 % of (trials x coefficients).
Run with ``make trials`` (or ``pytest -m trials tests/test_fit_calibration.py -s``).
"""
from __future__ import annotations

import numpy as np
import pytest

from identify.fit.mcmc import run_mcmc
from identify.fit.optimize import fit
from tests.test_fit_relations import CTX, _cases

N_TRIALS = 40
NOISE = 0.01


@pytest.mark.trials
@pytest.mark.parametrize("case", list(_cases()), ids=lambda c: f"{c[0]}-{c[1]}")
def test_credible_intervals_cover_the_truth(case):
    relation, form, data, truth, builder = case
    hits = total = 0
    for seed in range(N_TRIALS):
        rng = np.random.default_rng(1000 + seed)
        noisy = data.copy()
        noisy["value"] = data["value"] * (1 + NOISE * rng.standard_normal(len(data)))
        problem = builder(noisy, CTX, form=form)
        if relation == "CMz" and form == "T2":
            problem.parameters["YAW_STIFFNESS"].set(value=5000.0)
        result = run_mcmc(problem, fit(problem, seed=seed), seed=seed)
        for name in problem.free:
            if name not in truth:
                continue
            lo, hi = result.mcmc.interval(name, 0.90)
            hits += lo <= truth[name] <= hi
            total += 1
    rate = hits / total
    print(f"\n{relation} [{form}]: {hits}/{total} = {rate:.1%} of 90 % intervals hold the truth")
    assert rate >= 0.85
