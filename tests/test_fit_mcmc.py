"""MCMC uncertainty (emcee): seeded, converged by the 50-tau rule, honest intervals."""
from __future__ import annotations

import h5py
import lmfit
import numpy as np
import pytest

from identify.fit.mcmc import _Posterior, run_mcmc
from identify.fit.mf_stages import stage_problem
from identify.fit.optimize import fit
from identify.fit.problem import FitProblem
from tests.test_fit_engine import PRESSURES, _params, stiffness

TRUTH = {"nom": 1.43e5, "p1": 0.17, "p2": 0.0, "p3": 0.47}


def _problem(seed: int, noise: float = 0.01, sweeps=None):
    rng = np.random.default_rng(seed)
    data = stiffness(TRUTH) * (1 + noise * rng.standard_normal(PRESSURES.size))
    return FitProblem("CFy", "linear_load", _params(TRUTH, vary_p2=False), stiffness, data,
                      PRESSURES, sweeps=sweeps)


def test_mcmc_summary_is_seeded_converged_and_kept_apart(tmp_path):
    problem = _problem(0)
    result = fit(problem)
    a = run_mcmc(problem, result, seed=5, chain_file=tmp_path / "chain.h5")
    b = run_mcmc(problem, result, seed=5)
    m = a.mcmc
    assert m.median == b.mcmc.median                      # same seed, same chain
    assert m.converged and m.n_steps > 50 * max(m.tau.values())
    assert 0.2 <= m.acceptance <= 0.8                     # emcee's healthy range
    assert m.n_walkers >= 32
    assert a.parameters == result.parameters              # optimum is not overwritten
    for name in ("nom", "p1", "p3"):
        assert m.q025[name] < m.q16[name] < m.median[name] < m.q84[name] < m.q975[name]
        # posterior sd within a factor of 2 of the Jacobian standard error
        sd = (m.q84[name] - m.q16[name]) / 2
        assert 0.5 < sd / result.stderr[name] < 2.0, name
    with h5py.File(tmp_path / "chain.h5") as f:
        assert f["mcmc"]["chain"].shape[1:] == (m.n_walkers, 4)


def test_mcmc_ar1_noise_model_runs_and_estimates_phi():
    sweeps = np.repeat(np.arange(5), 3)
    problem = _problem(1, sweeps=sweeps)
    m = run_mcmc(problem, fit(problem), seed=2, ar1=True).mcmc
    assert "phi" in m.noise and -0.99 < m.noise["phi"] < 0.99
    assert m.converged


def test_posterior_width_is_exact_on_a_linear_problem():
    """A linear model in 19 coefficients with known noise: the posterior is Gaussian with
    covariance s^2 (J'J)^-1 (s the noise level, well determined by 400 points), so the sampled
    standard deviations must match sqrt(diag) -- a sampler that does not sample the target
    (emcee 3.1.6's DESnookerMove gives ~0.85 of it here) fails."""
    k, n, noise = 19, 400, 0.01
    rng = np.random.default_rng(7)
    J = rng.standard_normal((n, k))
    truth = rng.standard_normal(k)
    data = J @ truth + noise * rng.standard_normal(n)
    P = lmfit.Parameters()
    for i in range(k):
        P.add(f"c{i}", value=0.0, min=-10.0, max=10.0)

    def model(v):
        return sum(v[f"c{i}"] * J[:, i] for i in range(k))
    problem = FitProblem("linear", "test", P, model, data, np.ones(n), objective="wls",
                         sigma=np.ones(n))
    m = run_mcmc(problem, fit(problem, n_starts=1), seed=3).mcmc
    assert m.converged
    exact = noise * np.sqrt(np.diag(np.linalg.inv(J.T @ J)))
    sampled = np.array([(m.q84[f"c{i}"] - m.q16[f"c{i}"]) / 2 for i in range(k)])
    ratio = float(np.mean(sampled / exact))
    assert 0.95 < ratio < 1.05, ratio


def test_mf_stage_posterior_is_the_exact_one_of_a_linear_stage():
    """The combined Mz stage is linear in SSZ1..4 (the moment arm s of Fx; Fx and Fy held):
    with flat priors its posterior is Gaussian and known exactly (exact_linear_posterior,
    n = 1440 points). stage_mcmc -- stage problem, sweep-relative noise weights, walkers in
    one call -- must reproduce it: medians within 0.15 posterior sd (Monte Carlo error ~0.03 sd
    for ~2000 effective samples), 68 % half widths within 8 % (~3 % Monte Carlo error)."""
    from identify.fit.mf_stages import fit_mf, stage_mcmc
    from tests.test_fit_calibration_mf import (add_noise, design, exact_linear_posterior,
                                               simulate)
    from tests.test_fit_mf_stages import _truth

    truth = _truth()
    noisy = add_noise(simulate(truth, design()), 2000)
    problem = stage_problem("Mz", noisy, truth).problem
    names = list(problem.free)
    mean, sd = exact_linear_posterior(problem, np.array([truth[n] for n in names]))

    mf = fit_mf(noisy, truth, stages=("Mz",))
    m = stage_mcmc(noisy, mf, "Mz", seed=0).mcmc
    assert m.converged
    median = np.array([m.median[n] for n in names])
    half = np.array([(m.q84[n] - m.q16[n]) / 2 for n in names])
    print("median offset [sd]", np.round((median - mean) / sd, 3), "half width ratio",
          np.round(half / sd, 3))
    np.testing.assert_array_less(np.abs(median - mean) / sd, 0.15)
    np.testing.assert_allclose(half / sd, 1.0, atol=0.08)


def _walker_problems():
    """Every relation and MF stage the calibration trials sample (tests/test_fit_calibration*)."""
    from tests.test_fit_calibration import CASES
    from tests.test_fit_calibration_mf import SLIP_STAGES
    from tests.test_fit_mf_stages import _simulate, _sweeps, _truth

    for case in CASES:
        yield case.name, case.trial(np.random.default_rng(0))[0]
    truth = _truth()
    data = _simulate(truth, _sweeps(pressures=(1.9, 3.0), loads=(3000.0, 7000.0)))
    for stage in SLIP_STAGES:
        yield f"MF-{stage}", stage_problem(stage, data, truth).problem


WALKER_PROBLEMS = dict(_walker_problems())


@pytest.mark.parametrize("name", list(WALKER_PROBLEMS))
def test_walkers_in_one_call_give_the_per_walker_log_probabilities(name):
    """The posterior evaluates all walkers in one vectorised model call (no fallback to the
    per-walker loop) and gets exactly the loop's log-probabilities."""
    problem = WALKER_PROBLEMS[name]
    rng = np.random.default_rng(4)
    x0 = problem.x0()
    lo, hi = problem.bounds()
    step = 1e-3 * np.where(x0 != 0, np.abs(x0), 1e-2)
    x = np.clip(x0 + step * rng.standard_normal((7, x0.size)), lo, hi)
    theta = np.column_stack([x, np.log(0.01) + 0.1 * rng.standard_normal(7)])
    fast = _Posterior(problem, ar1=False)
    lp = fast(theta)
    assert fast.vectorised, "the model did not broadcast over walkers"
    assert np.all(np.isfinite(lp))
    slow = _Posterior(problem, ar1=False)
    slow.vectorised = False
    np.testing.assert_array_equal(lp, slow(theta))


@pytest.mark.trials
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
