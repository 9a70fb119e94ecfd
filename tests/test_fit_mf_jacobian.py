"""Exact derivatives of the MF stages (identify.fit.mf_jacobian) and the subsample search
(identify.fit.mf_search.search).

* The JAX Jacobian of every stage equals central differences of the numpy stage model (the
  same equations, identify.model with ``xp``) at a point away from the truth.
* A stage solved with the exact Jacobian and with finite differences ends at the same optimum
  (noisy data, so the optimum is not the truth).
* Without JAX or with MFID_JACOBIAN=fd the stage problems have no Jacobian (finite
  differences); the auto mode uses JAX only where the work pays for the compile.
* The search keeps one candidate per optimum; the subsample is evenly spaced.
"""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from identify.fit import mf_data, mf_jacobian
from identify.fit.mf_search import SUBSAMPLE, search, start_points, subsample
from identify.fit.mf_stage_defs import STAGES, stage_inputs, stage_predict
from identify.fit.mf_stages import DEFAULT_STAGES, fit_mf, stage_problem
from identify.fit.optimize import fit
from tests.test_fit_calibration_mf import add_noise
from tests import test_fit_mf_stages as _stages
from tests.test_fit_mf_stages import _perturb

HAVE_JAX = mf_jacobian._jax() is not None
needs_jax = pytest.mark.skipif(not HAVE_JAX, reason="JAX not installed (pip install .[fast])")


# the stage tests' fixtures: the truth and its simulated sweeps (module scope: built once here)
truth, data = _stages.truth, _stages.data


@pytest.fixture()
def exact(monkeypatch):
    monkeypatch.setenv(mf_jacobian.ENV, "jax")


@needs_jax
@pytest.mark.parametrize("stage", DEFAULT_STAGES)
def test_exact_jacobian_equals_central_differences(stage, truth, data, exact):
    start = _perturb(truth, STAGES[stage].coefficients, seed=7)
    sp = stage_problem(stage, data, start, screen=False)
    p = sp.problem
    assert p.jacobian is not None
    x = p.x0()
    J = p.model_jacobian(x)
    f0 = p.predict(x)
    for j, name in enumerate(p.free):
        h = 1e-5 * max(abs(x[j]), 0.1)
        xp, xm = x.copy(), x.copy()
        xp[j] += h
        xm[j] -= h
        cd = (p.predict(xp) - p.predict(xm)) / (2 * h)
        # truncation ~h^2 f''' and round-off ~1e-16 |f| / h of the central difference
        tol = 1e-6 * np.max(np.abs(cd)) + 1e-13 * np.max(np.abs(f0)) / h
        assert np.max(np.abs(J[:, j] - cd)) <= tol, (name, np.max(np.abs(J[:, j] - cd)), tol)


@needs_jax
def test_jax_equations_equal_numpy(truth, data):
    """stage_predict with jax.numpy gives the numpy values (the one copy of the equations)."""
    _, jnp = mf_jacobian._jax()
    for stage in DEFAULT_STAGES:
        sp = stage_problem(stage, data, truth, screen=False)
        inputs = stage_inputs(stage, truth, sp.state, sp.omega)
        ref = sp.problem.predict()
        got = np.asarray(stage_predict(stage, truth, sp.state, inputs, xp=jnp))
        np.testing.assert_allclose(got, ref, rtol=1e-13, atol=1e-9 * np.max(np.abs(ref)))


@needs_jax
@pytest.mark.parametrize("stage", ["Fy0", "Mz0", "Fx"])
def test_exact_and_finite_differences_reach_the_same_optimum(stage, truth, data, exact):
    noisy = add_noise(data, 11)
    sp = stage_problem(stage, noisy, _perturb(truth, STAGES[stage].coefficients, seed=3))
    with_jac = sp.problem
    without = dataclasses.replace(with_jac, jacobian=None)
    a = fit(with_jac, starts=with_jac.x0()[None, :])
    b = fit(without, starts=without.x0()[None, :])
    assert a.converged and b.converged
    assert abs(a.wls - b.wls) <= 1e-9 * b.wls
    for n in a.free:
        assert abs(a.parameters[n] - b.parameters[n]) <= 1e-3 * b.stderr[n], n
    assert a.nfev < b.nfev  # the exact Jacobian costs no model evaluations


def test_finite_differences_without_jax_or_when_switched_off(truth, data, monkeypatch):
    monkeypatch.setenv(mf_jacobian.ENV, "fd")
    assert stage_problem("Fy0", data, truth).problem.jacobian is None
    monkeypatch.setenv(mf_jacobian.ENV, "auto")
    small = stage_problem("Mz", data, truth)  # 4 coefficients on a few thousand points
    assert small.problem.measured.size * 5 < mf_jacobian.MIN_WORK
    assert small.problem.jacobian is None
    assert mf_jacobian.use_exact(10 * mf_jacobian.MIN_WORK, 10) == HAVE_JAX


def test_search_keeps_one_candidate_per_optimum(truth, data):
    sp = stage_problem("Fx0", data, _perturb(truth, STAGES["Fx0"].coefficients, seed=1))
    starts = start_points(sp.problem, 2, 0)
    found = search(sp.problem, np.vstack([starts, starts[:1]]))  # a start twice
    assert found.n_starts == len(starts) + 1
    assert found.starts_at_best >= 2
    objs = [sp.problem.objective_value(x) for x in found.candidates]
    assert len(set(np.round(np.log(objs), 5))) == len(objs)
    assert found.nfev > 0 and found.points == sp.problem.measured.size


def test_subsample_is_evenly_spaced():
    assert subsample(SUBSAMPLE) is None
    idx = subsample(10 * SUBSAMPLE + 3)
    assert idx.size == SUBSAMPLE and idx[0] == 0 and idx[-1] == 10 * SUBSAMPLE + 2
    assert np.all(np.diff(idx) >= 10) and np.all(np.diff(idx) <= 11)


def test_pressure_levels_of_a_continuous_channel():
    rng = np.random.default_rng(0)
    p = np.concatenate([v + 300 * rng.standard_normal(500) for v in (2.0e5, 2.5e5, 3.0e5)])
    levels = mf_data.level_values(p, mf_data.PRESSURE_RESOLUTION)
    np.testing.assert_allclose(levels, [2.0e5, 2.5e5, 3.0e5], atol=100)


def test_progress_reports_every_stage_with_its_time(truth, data):
    lines: list[str] = []
    stages = ("Fx0", "Mz")
    fit_mf(data, truth, stages=stages, progress=lines.append)
    for stage in stages:
        mine = [t for t in lines if t.startswith(f"MF {stage}:")]
        assert any("search" in t for t in mine) and any("solve on all" in t for t in mine)
        assert " s, " in mine[-1] and "converged" in mine[-1]


def test_noise_stop_ends_within_a_small_fraction_of_a_standard_error(truth, data):
    """MF_SOLVE stops once chi^2 no longer moves; the optimum is STRICT's to < 0.05 sd."""
    from identify.fit.engine import MF_SOLVE, STRICT

    noisy = add_noise(data, 5)
    sp = stage_problem("Mz0", noisy, _perturb(truth, STAGES["Mz0"].coefficients, seed=2))
    strict = fit(sp.problem, starts=sp.problem.x0()[None, :], tol=STRICT, max_nfev=400)
    noise = fit(sp.problem, starts=sp.problem.x0()[None, :], tol=MF_SOLVE, max_nfev=400)
    assert strict.converged and noise.converged
    assert noise.nfev <= strict.nfev
    for n in strict.free:
        assert abs(noise.parameters[n] - strict.parameters[n]) <= 0.05 * strict.stderr[n], n


def test_ladder_drops_candidates_worse_beyond_doubt(truth, data):
    from identify.fit.mf_search import prune

    noisy = add_noise(data, 4)
    p = stage_problem("Fx0", noisy, truth).problem
    best = fit(p, starts=p.x0()[None, :]).parameters
    x = np.array([best[n] for n in p.free])
    far = x * 1.05
    kept = prune(p, [far, x])
    assert len(kept) == 1 and np.array_equal(kept[0], x)
    near = x + 1e-9 * np.maximum(np.abs(x), 1e-3)
    assert len(prune(p, [x, near])) == 2

