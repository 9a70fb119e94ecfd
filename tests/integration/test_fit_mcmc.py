"""MCMC uncertainty (emcee): seeded, converged by the 50-tau rule, honest intervals."""
from __future__ import annotations

import dataclasses

import emcee
import h5py
import lmfit
import numpy as np
import pytest

from identify.fit.mcmc.chains import _Posterior, run_mcmc
from identify.fit.mf.stages import stage_problem
from identify.fit.optimize import fit
from identify.fit.solve.engine import problem_covariance
from identify.fit.solve.problem import PRIOR_POINTS, FitProblem
from tests.unit.test_fit_engine import PRESSURES, _params, stiffness

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
    # emcee reads the file (written once, at the end) as the chain the summary came from
    saved = emcee.backends.HDFBackend(str(tmp_path / "chain.h5"), name="mcmc", read_only=True)
    assert saved.iteration == m.n_steps
    flat = saved.get_chain(discard=m.n_discard, thin=m.n_thin, flat=True)
    np.testing.assert_array_equal(np.quantile(flat[:, :3], 0.5, axis=0),
                                  [m.median[n] for n in problem.free])


def test_budget_stops_the_chain_and_progress_follows_it():
    """A time budget stops a chain short of 50 tau (converged False, stopped "budget"), the
    progress callback sees it run and stop; without a budget the same chain converges."""
    problem = _problem(0)
    result = fit(problem)
    calls = []
    m = run_mcmc(problem, result, seed=5, budget=0.02, progress=calls.append).mcmc
    assert not m.converged and m.stopped == "budget" and m.n_steps < 500
    assert calls[-1].stop == "budget" and calls[-1].steps == m.n_steps
    assert calls[-1].budget == 0.02 and calls[-1].elapsed >= 0.02
    assert all(not c.stop for c in calls[:-1])
    calls.clear()
    m = run_mcmc(problem, result, seed=5, progress=calls.append).mcmc
    assert m.converged and m.stopped == "" and calls[-1].stop == "converged"
    assert calls[-1].target == min(40000, int(np.ceil(50 * calls[-1].tau)) + 1)
    # differential evolution alone from a small ball needs more than 500 steps here (the
    # default's Laplace proposals converge within them)
    m = run_mcmc(problem, result, seed=5, max_steps=500, moves="de").mcmc
    assert not m.converged and m.stopped == "max_steps" and m.n_steps == 500


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


def test_sweep_residual_noise_levels_are_the_fits_own_per_sweep():
    """noise="sweep-residual": each sweep's level is the RMS of its least-squares residuals,
    shrunk towards the pooled one by PRIOR_POINTS; a sweep of small values with the same
    additive noise gets the same level (the "sweep" model gave it one 20 times smaller than a
    sweep of 20 times larger values); a one-point sweep takes nearly the pooled level."""
    rng = np.random.default_rng(4)
    x = np.linspace(-1.0, 1.0, 400)
    sweeps = np.repeat([0, 1], 200)
    scale = np.where(sweeps == 0, 20.0, 1.0)  # sweep 0 measures values 20 x larger
    p = lmfit.Parameters()
    p.add("a", value=1.0)

    def model(v):
        return v["a"] * scale * x

    data = scale * x + 0.05 * rng.standard_normal(x.size)  # one additive noise level
    sweep = FitProblem("t", "line", p, model, data, np.ones(x.size), sweeps=sweeps,
                       noise="sweep")
    resid = dataclasses.replace(sweep, noise="sweep-residual")
    with pytest.raises(ValueError, match="needs the optimum"):
        resid.noise_weights()
    xb = np.array([1.0])
    level = 1.0 / resid.noise_weights(xb)
    r = model({"a": 1.0}) - data
    own = [np.sqrt(np.mean(r[sweeps == s] ** 2)) for s in (0, 1)]
    pooled = np.sqrt(np.mean(r ** 2))
    for s in (0, 1):
        want = np.sqrt((200 * own[s] ** 2 + PRIOR_POINTS * pooled ** 2) / (200 + PRIOR_POINTS))
        assert level[sweeps == s] == pytest.approx(want, rel=1e-12)
        assert want == pytest.approx(0.05, rel=0.15)
    by_sweep = 1.0 / sweep.noise_weights()
    assert by_sweep[0] / by_sweep[-1] == pytest.approx(20.0, rel=0.01)
    one = dataclasses.replace(resid, sweeps=np.r_[np.zeros(399), 1.0])
    lone = 1.0 / one.noise_weights(xb)[-1]
    assert abs(lone - pooled) < 0.1 * abs(abs(r[-1]) - pooled) + 1e-12


def test_mf_stage_posterior_is_the_exact_one_of_a_linear_stage():
    """The combined Mz stage is linear in SSZ1..4 (the moment arm s of Fx; Fx and Fy held):
    with flat priors its posterior is Gaussian and known exactly (exact_linear_posterior,
    n = 1440 points). stage_mcmc -- stage problem, sweep-relative noise weights, walkers in
    one call -- must reproduce it: medians within 0.15 posterior sd (Monte Carlo error ~0.03 sd
    for ~2000 effective samples), 68 % half widths within 8 % (~3 % Monte Carlo error)."""
    from identify.fit.mf.stages import fit_mf, stage_mcmc
    from tests.unit.test_fit_calibration_mf import (
        add_noise,
        design,
        exact_linear_posterior,
        simulate,
    )
    from tests.unit.test_fit_mf_stages import _truth

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
    from tests.unit.test_fit_calibration import CASES
    from tests.unit.test_fit_calibration_mf import SLIP_STAGES
    from tests.unit.test_fit_mf_stages import _simulate, _sweeps, _truth

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
    fast = _Posterior(problem, ar1=False, xb=x0)
    lp = fast(theta)
    assert fast.vectorised, "the model did not broadcast over walkers"
    assert np.all(np.isfinite(lp))
    slow = _Posterior(problem, ar1=False, xb=x0)
    slow.vectorised = False
    np.testing.assert_array_equal(lp, slow(theta))


def _weighted_quantiles(v, w, qs):
    order = np.argsort(v)
    c = np.cumsum(w[order])
    return np.interp(qs, c / c[-1], v[order])


def _log_posterior_in_logs(problem, lu, sign, w):
    """The exact flat-prior log posterior of a 3-coefficient problem at rows ``lu`` = log
    |coefficients| (signs ``sign``), the noise level marginalised (flat prior in log sigma:
    posterior ~ SSR^(-n/2)), as a density in ``lu`` (the Jacobian of x = sign exp(lu) is
    prod |x|: analytic, none of the code under test enters). ``w``: the noise weights the
    MCMC uses (FitProblem.noise_weights at the least-squares optimum)."""
    x = sign * np.exp(lu)
    n_pts = problem.measured.size
    ssr = np.empty(len(x))
    for a in range(0, len(x), 4000):
        xs = x[a:a + 4000]
        vals = dict(problem.values(), **{m: xs[:, i:i + 1] for i, m in enumerate(problem.free)})
        ssr[a:a + 4000] = np.sum(((np.asarray(problem.model(vals)) - problem.measured) * w) ** 2,
                                 axis=1)
    lo, hi = problem.bounds()
    inside = np.all((x >= lo) & (x <= hi), axis=1)
    return x, np.where(inside, -0.5 * n_pts * np.log(ssr) + np.sum(lu, axis=1), -np.inf)


def _exact_posterior(problem, xb, n_draws=120_000, seed=11):
    """Draws (N, 3) and importance weights of the exact flat-prior posterior of PKY1, PKY2,
    PKY4. In log |coefficient| the curved ridge below the stiffness peak is nearly straight
    (Kya ~ PKY1 PKY4 / PKY2 there), so a coarse grid in logs (41^3 points, +/- 9 standard
    errors) gives the mean and covariance of a Student t proposal (4 degrees of freedom, 1.5x
    wider) from which the posterior is importance-sampled. (A grid in the coefficients
    themselves, as first used here, cut off the posterior's long tail at its edges -- 24 % of
    the peak weight on its faces at +/- 5 sd -- which put the exact 16 % quantiles too high by
    0.1-0.2 sd.)"""
    sign = np.sign(xb)
    c0 = np.log(np.abs(xb))
    cov0 = problem_covariance(problem, xb) / np.outer(xb, xb)
    g = np.linspace(-9.0, 9.0, 41)
    u = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    lu = c0 + u @ np.linalg.cholesky(cov0).T
    weights = problem.noise_weights(xb)
    _, lp = _log_posterior_in_logs(problem, lu, sign, weights)
    w = np.exp(lp - lp.max())
    mean = w @ lu / w.sum()
    cov = ((lu - mean).T * w) @ (lu - mean) / w.sum()
    rng, df = np.random.default_rng(seed), 4.0
    chol = np.linalg.cholesky(1.5 ** 2 * cov)
    z = rng.standard_normal((n_draws, 3))
    lu = mean + (z @ chol.T) / np.sqrt(rng.chisquare(df, n_draws) / df)[:, None]
    d = np.linalg.solve(chol, (lu - mean).T)
    log_q = -0.5 * (df + 3) * np.log1p(np.sum(d * d, axis=0) / df)
    x, lp = _log_posterior_in_logs(problem, lu, sign, weights)
    logw = lp - log_q
    return x, np.exp(logw - logw[np.isfinite(logw)].max())


def test_kya_reparametrisation_samples_the_exact_fy0_posterior():
    """Fy0 with PKY1, PKY2, PKY4 free on loads of 3-9 kN (below the stiffness peak: a curved,
    skewed, long-tailed posterior) sampled as Kya at three loads (identify.fit.mcmc.reparam):
    the 16/50/84 % quantiles match the exact flat-prior posterior (importance-sampled,
    _exact_posterior) within 0.1 posterior sd (Monte Carlo error of 64 walkers ~0.03 sd;
    measured 0.005-0.05 sd). The exact draws also show the test's power: a prior flat in Kya
    instead (the Jacobian left out) moves the quantiles by more than 1 sd."""
    from identify.fit.mcmc.reparam import kya_ridge
    from identify.fit.mf.stages import fit_mf, stage_mcmc
    from tests.unit.test_fit_calibration_mf import add_noise, design, simulate
    from tests.unit.test_fit_mf_stages import _truth

    truth = _truth()
    pts = design(pressures=(2.5,), loads=(3000.0, 6000.0, 9000.0))
    noisy = add_noise(simulate(truth, pts[pts["run"].str.startswith("lat")]), 1)
    free = {"Fy0": ["PKY1", "PKY2", "PKY4"]}
    mf = fit_mf(noisy, truth, stages=("Fy0",), free=free)
    sp = stage_problem("Fy0", noisy, mf.params, free=free, hold={})
    problem = sp.problem
    assert problem.free == ("PKY1", "PKY2", "PKY4")
    xb = np.array([mf.params[n] for n in problem.free])
    x, w = _exact_posterior(problem, xb)
    ess = w.sum() ** 2 / (w ** 2).sum()
    assert ess > 10_000, ess  # Monte Carlo error of the exact quantiles ~0.01 sd
    ridge = kya_ridge(problem.free, xb, sp.state.fz, mf.params)
    assert ridge is not None and ridge.loads == (3000.0, 6000.0, 9000.0)
    m = stage_mcmc(noisy, mf, "Fy0", seed=0, n_walkers=64).mcmc
    assert m.converged and m.reparametrised == ("Kya@3000N", "Kya@6000N", "Kya@9000N")
    log_jac = ridge.inverse(ridge.forward(x))[1]
    ok = np.isfinite(log_jac)
    w_kya = w * np.exp(-(np.where(ok, log_jac, np.inf) - log_jac[ok].max()))  # flat in Kya
    qs = [0.16, 0.5, 0.84]
    for i, name in enumerate(problem.free):
        exact = _weighted_quantiles(x[:, i], w, qs)
        sd = (exact[2] - exact[0]) / 2
        got = np.array([m.q16[name], m.median[name], m.q84[name]])
        flat_kya = _weighted_quantiles(x[:, i], w_kya, qs)
        print(name, "exact", exact, "mcmc - exact [sd]", np.round((got - exact) / sd, 3),
              "flat-in-Kya - exact [sd]", np.round((flat_kya - exact) / sd, 3))
        np.testing.assert_array_less(np.abs(got - exact) / sd, 0.1)
        assert np.max(np.abs(flat_kya - exact) / sd) > 0.2, name


def test_the_budget_of_the_whole_run_is_shared_out_between_the_chains(tmp_path):
    """``mfid fit``'s --mcmc-budget is the whole MCMC run's: the chains run after the fits,
    cheapest first, each with the budget left divided by the chains left, so the time a chain
    that converges early does not use goes to the ones after it; the results get their
    summaries and nothing else changes."""
    from functools import partial

    from identify.fit.run import FitSettings
    from identify.workflows.fit import _Chains

    problems = [_problem(0), _problem(1), _problem(2, noise=0.02)]
    results = [fit(p) for p in problems]
    budget, seen = 60.0, []
    settings = FitSettings(mcmc=True, mcmc_budget_s=budget, seed=5)
    with _Chains(settings, tmp_path, lambda name, p: seen.append((name, p))) as chains:
        for i, (p, r) in enumerate(zip(problems, results)):
            chains.queue(i, f"chain{i}", f"mcmc: chain{i}", r, partial(run_mcmc, p, r))
        lines = []
        done = list(results)
        chains.run_all(done, lines.append)
    assert lines == ["mcmc: chain0", "mcmc: chain1", "mcmc: chain2"]  # equal cost: in order
    shares = {name: p.budget for name, p in seen if p.stop}
    assert shares["chain0"] == pytest.approx(budget / 3, rel=1e-3)
    spent = sum(d.mcmc.seconds for d in done[:1])
    assert shares["chain1"] == pytest.approx((budget - spent) / 2, rel=0.05)
    assert shares["chain1"] > budget / 3 and shares["chain2"] > shares["chain1"]
    for d, r in zip(done, results):
        assert d.mcmc.converged and d.parameters == r.parameters and d.mcmc.chain_file is None


def test_laplace_move_samples_the_target_even_from_a_wrong_approximation():
    """The independence proposals carry their density ratio, so a wrong approximation only
    lowers the acceptance: a correlated Gaussian in 6 dimensions sampled as run_mcmc does
    (half differential evolution, half Laplace proposals) from an approximation shifted by 1
    sd in every coefficient and half as wide still gives the exact mean and sd (Monte Carlo
    error ~0.02 sd; measured <= 0.02 sd and sd ratios 0.99-1.00). The test has power: the same
    run without the density ratio comes out 0.45 sd off with sd ratios of 0.73."""
    from identify.fit.mcmc.chains import LaplaceMove

    rng = np.random.default_rng(1)
    k = 6
    a = rng.standard_normal((k, k))
    cov = a @ a.T + k * np.eye(k)
    mean = rng.standard_normal(k)
    prec = np.linalg.inv(cov)
    sd = np.sqrt(np.diag(cov))

    def log_prob(x):
        d = np.atleast_2d(x) - mean
        return -0.5 * np.einsum("ij,jk,ik->i", d, prec, d)

    wrong = LaplaceMove(mean + sd, cov / 4, scale=1.0, df=5.0)
    sampler = emcee.EnsembleSampler(32, k, log_prob, vectorize=True,
                                    moves=[(emcee.moves.DEMove(), 0.5), (wrong, 0.5)])
    sampler.random_state = np.random.RandomState(2).get_state()
    sampler.run_mcmc(mean + 0.1 * rng.standard_normal((32, k)), 4000)
    flat = sampler.get_chain(discard=200, flat=True)
    np.testing.assert_allclose((flat.mean(axis=0) - mean) / sd, 0.0, atol=0.06)
    np.testing.assert_allclose(flat.std(axis=0) / sd, 1.0, atol=0.05)


def test_a_chain_stopped_by_the_budget_continues_in_its_session():
    """run_mcmc(session=...) keeps a chain the budget stopped; passed again it continues the
    same chain (steps and seconds count on) to 50 tau, as mfid fit does with the time the
    other chains left."""
    from identify.fit.mcmc.chains import ChainSession

    problem = _problem(0)
    result = fit(problem)
    session = ChainSession()
    first = run_mcmc(problem, result, seed=5, budget=0.02, moves="de", session=session).mcmc
    assert first.stopped == "budget" and 0 < first.n_steps < 500
    more = run_mcmc(problem, result, seed=5, moves="de", session=session).mcmc
    assert more.converged and more.n_steps > first.n_steps
    assert more.seconds > first.seconds
    assert session.sampler.iteration == more.n_steps  # one chain, not a new one


def test_a_chain_that_has_not_moved_gives_no_runtime_warning():
    """Every proposal off the walkers' start has zero density, so no walker moves: each
    coordinate's autocorrelation is 0/0. The chain's tau is then unknown (NaN), and no
    RuntimeWarning reaches the user's screen (one showed in the test suite's summary when a
    budget stopped a chain after a few steps)."""
    import warnings

    import emcee

    from identify.fit.mcmc.steps import run_chain

    p0 = np.random.default_rng(0).standard_normal((16, 2))
    starts = {tuple(p) for p in p0}
    sampler = emcee.EnsembleSampler(
        16, 2, lambda x: 0.0 if tuple(x) in starts else -np.inf)
    sampler.random_state = np.random.RandomState(0).get_state()
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        _, steps, tau, stop = run_chain(sampler, p0, 300, None, None, 0.0,
                                        lambda: sampler.get_autocorr_time(tol=0))
    assert steps == 300 and stop == "max_steps" and np.isnan(tau).all()
