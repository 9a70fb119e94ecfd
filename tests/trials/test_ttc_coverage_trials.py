"""Issue 14, acceptance 3, on ten generated TTC sessions (run with ``make trials`` or
``pytest -m trials tests/trials/test_ttc_coverage_trials.py``; about 2-4 minutes a seed on two
loaded cores).

Per seed ``bench/ttc_truth.py``'s trial: ``simulate_ttc`` with the generator's defaults (1 %
noise, AR(1) 0.7, drift, warm-ups, logging quirks), ``mfid import``, ``mfid fit`` without MCMC.

1. Fx, Fy, Mz of the fitted .tir within 2 % of the truth .tir in every seed.
2. "Every identifiable coefficient within its 95 % interval in 9 of 10 seeds", both readings
   (bench/ttc_truth.py ``coverage_tables``): (a) every coefficient's interval holds the truth in
   >= 9 of the 10 seeds (>= 90 % of the seeds where it is identifiable); (b) in >= 9 of the 10
   seeds every identifiable coefficient's interval holds the truth.

Neither reading of 2 is met (bench/ttc_truth.py prints the numbers, docs/intervals.md says how
to read them): the tests are marked
xfail(strict) so that the day they pass is seen. Reading (b) cannot be met by calibrated 95 %
intervals at all (a seed holds ~90 identifiable ones, all inside with probability
0.95^90 = 1 %); reading (a) fails for more than a dozen of ~100 coefficients by chance alone
(the sum bench/ttc_truth.py prints). What the intervals do
achieve is asserted as well: the pooled coverage of the identifiable coefficient-seeds is at
least :data:`POOLED_MIN` (0.93-0.94 measured; the iid standard errors held 0.47), and reading
(c): no coefficient misses beyond chance at family-wise 5 %.
"""
from __future__ import annotations

import json

import pytest

from tests.bench_modules import load_bench

SEEDS = tuple(range(10))
POOLED_MIN = 0.90
"""Pooled coverage on seeds 0-9 with the staged sweep jackknife and the twiced revolution
average (846/910 = 0.93 in time, 817/879 = 0.93 over the wheel's angle) less three times its
binomial spread (0.0085); before the twiced filter 0.89, with iid standard errors 0.47."""


@pytest.fixture(scope="module")
def tables(tmp_path_factory):
    bench = load_bench("ttc_truth")
    base = tmp_path_factory.mktemp("ttc-coverage")
    records = []
    for seed in SEEDS:
        where = base / f"seed{seed}"
        where.mkdir()
        records.append(bench.trial(seed, str(where)))
    (base / "records.json").write_text(json.dumps(records, indent=1))
    return records, bench.coverage_tables(records), bench


@pytest.mark.trials
def test_forces_within_two_percent_and_pooled_coverage(tables, capsys):
    records, t, bench = tables
    with capsys.disabled():
        bench.print_tables(t)
    for r in records:
        assert r["forces_ok"], (r["seed"], r["forces_pct"])
    inside, n = t["pooled"]
    assert n >= 80 * len(SEEDS) and inside / n >= POOLED_MIN, t["pooled"]  # ~91 a seed


@pytest.mark.trials
@pytest.mark.xfail(strict=True, reason="not met: 17-28 of ~100 coefficients below 9/10 "
                   "(12.7-19.3 expected by chance); Fx0 PCX1/PEX1 spread 3.5-4.6 SE: two minima "
                   "the noise cannot tell apart, bench/stage_valleys.py, docs/intervals.md")
def test_every_identifiable_coefficient_inside_in_9_of_10_seeds(tables):
    _, t, _ = tables
    assert t["a_met"], sorted(t["failing"])


@pytest.mark.trials
@pytest.mark.xfail(strict=True, reason="not met, and not reachable by calibrated 95 % "
                   "intervals: ~90 of them per seed are all inside with probability 1 %")
def test_9_of_10_seeds_with_every_identifiable_coefficient_inside(tables):
    _, t, _ = tables
    assert t["b_met"], t["seeds_all_inside"]


@pytest.mark.trials
def test_no_coefficient_misses_beyond_chance(tables):
    """Reading (c) (bench/ttc_truth.py ``beyond_chance``, docs/intervals.md): no coefficient's
    misses exceed what calibrated 95 % intervals would give, one-sided binomial p-values with
    Holm's step-down at family-wise 5 %, and the pooled coverage within its binomial band of
    95 %. Calibrated intervals pass this at least 95 % of the time; PVX1 at 20 of 30 seeds
    (before the score test, identify.fit.mf.score_test) failed it. Met on seeds 0-9 at 74df16e
    (pooled 891 / 934); over 60 seeds it names Fx0's PCX1 and PEX1 (two basins) and Q_FCY
    (its gate's false positives)."""
    _, t, _ = tables
    assert t["c_met"], (t["beyond_chance"], t["pooled"])
