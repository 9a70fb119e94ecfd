"""Exact derivatives of the MF stages (identify.fit.mf.jacobian) and the subsample search
(identify.fit.mf.search.search).

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
import json

import numpy as np
import pytest
from scipy.optimize import approx_fprime

from identify.fit.mf import jacobian as mf_jacobian
from identify.fit.mf import jax_cache as mf_jax_cache
from identify.fit.mf import search as mf_search
from identify.fit.mf import stage_data as mf_data
from identify.fit.mf.search import SUBSAMPLE, prune, search, start_points, subsample
from identify.fit.mf.stage_specs import (
    STAGES,
    names_read,
    stage_inputs,
    stage_model,
    stage_predict,
    subset_state,
)
from identify.fit.mf.stages import DEFAULT_STAGES, fit_mf, stage_problem
from identify.fit.mf.uncertainty import _upstream_jacobian
from identify.fit.optimize import _sharing_residuals, fit
from identify.fit.solve import engine
from identify.model.symmetries import sign_patterns
from tests.unit import test_fit_mf_stages as _stages
from tests.unit.test_fit_calibration_mf import add_noise
from tests.unit.test_fit_mf_stages import _perturb

HAVE_JAX = mf_jacobian._jax() is not None
needs_jax = pytest.mark.skipif(not HAVE_JAX, reason="JAX not installed (pip install .[fast])")
# engine.least_squares's ``stop`` runs in scipy's callback (scipy >= 1.16; ignored before)
needs_stop = pytest.mark.skipif(not engine._HAS_CALLBACK,
                                reason="scipy < 1.16: least_squares has no callback")


# the stage tests' fixtures: the truth and its simulated sweeps (module scope: built once here)
truth, data = _stages.truth, _stages.data


@pytest.fixture()
def exact(monkeypatch):
    monkeypatch.setenv(mf_jacobian.ENV, "jax")


EXACT_STAGES = [s for s in DEFAULT_STAGES if s not in mf_jacobian.NUMPY_ONLY]


def test_numpy_only_stages_keep_finite_differences(truth, data, exact):
    """The vertical stage (MF 6.2's secant solve for the loaded radius) has no JAX program:
    finite differences even where exact derivatives are asked for."""
    assert mf_jacobian.NUMPY_ONLY == ("vertical",)
    assert stage_problem("vertical", data, truth, screen=False).problem.jacobian is None


@needs_jax
@pytest.mark.parametrize("stage", EXACT_STAGES)
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
def test_jacobian_of_some_coefficients_in_any_order_is_those_columns(truth, data, exact):
    """stage_jacobian(values, names): the columns of ``names`` of the whole stage's Jacobian,
    in their order (copied as runs of consecutive columns, mf_jacobian._runs), whatever
    names are left out or reordered."""
    sp = stage_problem("Fy", data, truth, screen=False)
    fn = sp.problem.jacobian
    every = STAGES["Fy"].coefficients
    whole = fn(truth, every)
    for names in (every[:3] + every[4:], every[::-1], every[2:3], every[5:] + every[:2]):
        part = fn(truth, names)
        np.testing.assert_array_equal(part, whole[:, [every.index(n) for n in names]])
    assert mf_jacobian._runs([0, 1, 2, 4, 5, 7]) == [(0, 3, 0), (4, 6, 3), (7, 8, 5)]
    assert mf_jacobian._runs([3, 1, 2]) == [(3, 4, 0), (1, 3, 1)]


@needs_jax
def test_fy0_at_pure_slip_has_its_own_program_with_the_same_jacobian(truth, data, exact):
    """An Fy0 stage whose points are all at kappa == 0 uses the program without the
    combined-slip expression (mf_jacobian.PURE_FY0); its Jacobian is the combined program's
    (which selects Fy0 there) to round-off, and at kappa != 0 the combined one is used."""
    jax, jnp = mf_jacobian._jax()
    sp = stage_problem("Fy0", data, truth, screen=False)
    pure_points = np.flatnonzero(sp.state.kappa == 0)
    assert pure_points.size > 100
    s = subset_state(sp.state, pure_points)
    names = STAGES["Fy0"].coefficients
    theta = np.array([truth[n] for n in names])

    def jac(pure):
        return np.asarray(jax.jacfwd(lambda th: stage_predict(
            "Fy0", {**truth, **dict(zip(names, th))}, s, {}, xp=jnp, pure_slip=pure))(theta))
    np.testing.assert_allclose(jac(True), jac(False), rtol=1e-13, atol=1e-12)
    mf_jacobian._EXECUTABLES.clear()
    got = mf_jacobian.stage_jacobian("Fy0", truth, s)(truth, names)
    assert [json.loads(k)["stage"] for k in mf_jacobian._EXECUTABLES] == [mf_jacobian.PURE_FY0]
    # compiled (XLA fuses and reorders) against op by op: round-off
    np.testing.assert_allclose(got, jac(False), rtol=1e-9, atol=1e-9)
    mixed = subset_state(sp.state, np.arange(sp.state.kappa.size))
    mixed = dataclasses.replace(mixed, kappa=np.where(np.arange(mixed.kappa.size) == 0, 0.01,
                                                      mixed.kappa))
    mf_jacobian._EXECUTABLES.clear()
    mf_jacobian.stage_jacobian("Fy0", truth, mixed)(truth, names)
    assert [json.loads(k)["stage"] for k in mf_jacobian._EXECUTABLES] == ["Fy0"]


@needs_jax
def test_polish_gradient_takes_the_objectives_residuals(truth, data, exact):
    """The constrained polish's objective and gradient (optimize._sharing_residuals) are the
    problem's objective_value and objective_gradient bit for bit, and the gradient at the
    objective's last x evaluates no model."""
    problem, counter = engine.counted(stage_problem("Fy", data, truth).problem)
    objective, gradient = _sharing_residuals(problem)
    x = problem.x0() * 1.01
    assert objective(x) == problem.objective_value(x)
    before = counter.calls
    np.testing.assert_array_equal(gradient(x), problem.objective_gradient(x))
    assert counter.calls == before + 1  # objective_gradient's own evaluation only
    y = x * 1.01  # another x: its own residuals
    np.testing.assert_array_equal(gradient(y), problem.objective_gradient(y))


@needs_jax
def test_jax_equations_equal_numpy(truth, data):
    """stage_predict with jax.numpy gives the numpy values (the one copy of the equations)."""
    _, jnp = mf_jacobian._jax()
    for stage in EXACT_STAGES:
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


def test_search_keeps_one_of_two_mirror_images(truth, data, monkeypatch):
    """Mz0's (QBZ9, QBZ10) and (-QBZ9, -QBZ10) predict the same: a start and the mirror image
    of a start near it end at one candidate. Their ends' objectives agree to round-off here
    (1530 points converge tightly; on a TTC session's subsample they were 0.06 apart in
    chi^2): without the objective test only the mirror test finds them the same optimum.
    The starts' stop test is off (on scipy >= 1.16 it would merge the second start first, as
    before 1.16 nothing did), so that each start is solved to its own end and the candidates'
    mirror test is what merges them; starts_at_best counts the start at the mirror image."""
    monkeypatch.setattr(mf_search, "BEST_RTOL", 0.0)

    def record_only(self, x, cost):  # the path for later starts, never a stop
        self.path.append((np.array(x, dtype=float), cost))

    monkeypatch.setattr(mf_search._Reached, "__call__", record_only)
    noisy = add_noise(data, 6)
    sp = stage_problem("Mz0", noisy, _perturb(truth, STAGES["Mz0"].coefficients, seed=3),
                       screen=False)
    p = sp.problem
    x0 = p.x0()
    signs = sign_patterns(p.free)
    assert len(signs) == 2  # Mz0: (QBZ9, QBZ10) -> (-QBZ9, -QBZ10) alone
    flipped = signs[1] * x0
    assert not np.allclose(flipped, x0)
    np.testing.assert_array_equal(p.predict(flipped), p.predict(x0))
    near = signs[1] * x0 * (1 + 0.05 * np.random.default_rng(0).standard_normal(x0.size))
    found = search(p, np.vstack([x0, near]))
    assert found.n_starts == 2 and len(found.candidates) == 1 and found.starts_at_best == 2


@needs_stop
def test_search_stops_a_start_at_the_mirror_image_of_an_end(truth, data):
    """A start at the mirror image of an earlier start is stopped after one iteration (it has
    reached the mirror image of that start's path: the same prediction), not solved along
    the mirror of that path to the mirror image of its end."""
    noisy = add_noise(data, 6)
    p = stage_problem("Mz0", noisy, _perturb(truth, STAGES["Mz0"].coefficients, seed=3),
                      screen=False).problem
    one = search(p, p.x0()[None, :])
    two = search(p, np.vstack([p.x0(), sign_patterns(p.free)[1] * p.x0()]))
    assert len(two.candidates) == 1 and two.starts_at_best == 2
    # the second start costs at most 3 evaluations, under the 6 of solving it (the first
    # start's, measured with the search's Gauss-Newton steps; 7 and more before them)
    assert two.nfev - one.nfev <= 3 < one.nfev


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


def test_noise_stop_ends_within_a_small_fraction_of_a_standard_error(truth, data,
                                                                     monkeypatch):
    """MF_SOLVE stops once chi^2 no longer moves; the optimum is STRICT's to < 0.05 sd. With
    finite differences, as written (the exact Jacobian, since MIN_WORK is 30_000, converges
    STRICT within the noise stop's window: nothing to save)."""
    monkeypatch.setenv(mf_jacobian.ENV, "fd")
    noisy = add_noise(data, 5)
    sp = stage_problem("Mz0", noisy, _perturb(truth, STAGES["Mz0"].coefficients, seed=2))
    strict = fit(sp.problem, starts=sp.problem.x0()[None, :], tol=engine.STRICT, max_nfev=400)
    noise = fit(sp.problem, starts=sp.problem.x0()[None, :], tol=engine.MF_SOLVE, max_nfev=400)
    assert strict.converged and noise.converged
    assert noise.nfev <= strict.nfev
    for n in strict.free:
        assert abs(noise.parameters[n] - strict.parameters[n]) <= 0.05 * strict.stderr[n], n


def test_ladder_drops_candidates_worse_beyond_doubt(truth, data):
    noisy = add_noise(data, 4)
    p = stage_problem("Fx0", noisy, truth).problem
    best = fit(p, starts=p.x0()[None, :]).parameters
    x = np.array([best[n] for n in p.free])
    far = x * 1.05
    kept = prune(p, [far, x])
    assert len(kept) == 1 and np.array_equal(kept[0], x)
    near = x + 1e-9 * np.maximum(np.abs(x), 1e-3)
    assert len(prune(p, [x, near])) == 2



@needs_stop
def test_a_start_that_reaches_an_earlier_end_point_stops_there(truth, data):
    """mf_search.MERGE_CHI2: a second start at the first one's end point stops after one
    iteration and ends at it (one candidate, both starts at the best value)."""
    noisy = add_noise(data, 6)
    p = stage_problem("Fx0", noisy,
                      _perturb(truth, STAGES["Fx0"].coefficients, seed=4)).problem
    one = search(p, p.x0()[None, :])
    end = one.candidates[0]
    both = search(p, np.vstack([p.x0(), end * (1 + 1e-7)]))
    assert both.n_starts == 2 and both.starts_at_best == 2 and len(both.candidates) == 1
    np.testing.assert_array_equal(both.candidates[0], end)
    # the second start: one iteration (finite-difference Jacobians here: k + 1 evaluations
    # each), not a solve
    assert both.nfev <= one.nfev + 3 * (len(p.free) + 1)


def test_a_start_far_below_an_earlier_end_point_has_not_reached_it():
    """mf_search.MERGE_CHI2: an end point on a plateau (a coefficient run off to where its
    column of the Jacobian is zero) is no minimum, and its Jacobian's metric does not say how
    far a point is from it. A start's iterate in that metric but far below its cost has not
    reached it; one at its cost has. Before, only a cost above the end's was checked: on a
    TTC session of the golden tyre (tests/data/tir/testA_61.tir, inputs without noise, seed
    1) the Fy stage's re-fit stopped its start from the defaults at 2.7e-4 as having reached
    a plateau at 1.5e-2 (RBY4 -> -5e22), and Fy ended 19.7 % off the truth.

    Here y = A tanh(B x) through tanh(2 x): from B = 1e5 the solve stops at once (d/dB = 0 at
    every point), A the mean of |y|, about 700 times the optimum's cost."""
    x = np.linspace(-1.0, 1.0, 201)
    y = np.tanh(2.0 * x) + 0.01 * np.random.default_rng(3).standard_normal(x.size)

    def residuals(v):
        return v[0] * np.tanh(v[1] * x) - y

    bounds = (np.array([0.0, 0.0]), np.array([10.0, 1e6]))
    plateau = engine.least_squares(residuals, np.array([1.0, 1e5]), bounds, engine.SEARCH)
    assert plateau.success and plateau.x[1] == 1e5 and not plateau.jac[:, 1].any()
    signs = sign_patterns(["A", "B"])
    below = np.array([plateau.x[0], 3.0])  # in the plateau's metric: the same A
    cost = 0.5 * float(residuals(below) @ residuals(below))
    assert cost < 0.5 * plateau.cost
    reached = mf_search._Reached([plateau], [[]], signs)
    assert reached(below, cost) is None and reached.into is None
    # at the plateau's own cost, within its metric: the same end point
    at = plateau.x + np.array([1e-6, 0.0])
    assert reached(at, 0.5 * float(residuals(at) @ residuals(at))) is not None
    assert reached.into == 0


@needs_stop
def test_least_squares_stop_callable_ends_the_solve():
    seen = []

    def stop(x, cost):
        seen.append(cost)
        return "enough" if len(seen) == 2 else None

    est = engine.least_squares(lambda x: np.array([x[0] - 1.0, 10 * (x[1] - x[0] ** 2)]),
                               np.array([-1.2, 1.0]), (np.full(2, -5.0), np.full(2, 5.0)),
                               stop=stop)
    assert est.status == engine.STOP_STATUS and est.message == "enough" and est.success
    assert len(seen) == 2 and est.cost == seen[-1]


@pytest.mark.parametrize("stage", ["Fy0", "Mz0", "Fx0"])
def test_constraint_jacobian_near_the_minimum_equals_the_whole_grid(stage, truth):
    """Constraint.local: the polish's forward differences of the validity margins on the grid
    points near each load's minimum are those on the whole grid."""
    from scipy.optimize import approx_fprime

    from identify.fit.mf.constraints import stage_constraints

    start = _perturb(truth, STAGES[stage].coefficients, seed=5)
    names = [n for n in STAGES[stage].coefficients if n in start]
    cons = stage_constraints(stage, start, lambda v: {**start, **v}, [2.0e5, 2.5e5])
    assert cons and all(c.local is not None for c in cons)
    x = np.array([start[n] for n in names])

    def whole(x1):
        v = dict(zip(names, x1))
        return np.concatenate([c.fun(v) for c in cons])
    near = [c.local(dict(zip(names, x))) for c in cons]
    assert any(f is not c.fun for f, c in zip(near, cons))  # a subset of the grid, not all

    def local(x1):
        v = dict(zip(names, x1))
        return np.concatenate([f(v) for f in near])
    np.testing.assert_array_equal(local(x), whole(x))
    # steps of 1e-8 relative, as SLSQP's in its whitened variables
    eps = 1e-8 * np.maximum(np.abs(x), 1e-3)
    np.testing.assert_array_equal(approx_fprime(x, local, eps), approx_fprime(x, whole, eps))


@pytest.mark.parametrize("stage", ["Fy0", "Mz0", "Fx0", "Fx"])
def test_batched_constraint_jacobian_is_approx_fprime_to_the_last_bit(stage, truth, data):
    """The polish's forward differences of the validity margins with every step evaluated in
    one batched call (Constraint.batched, engine._forward_differences) are scipy's
    approx_fprime point by point, bit for bit: the fitted numbers do not depend on it. In the
    polish's whitened variables (x = x1 + T z), at a point off the truth."""
    start = _perturb(truth, STAGES[stage].coefficients, seed=5)
    if stage == "Fx":  # its conditions are on only with a combined-slip term
        start.update(RBX1=12.0, RBX3=0.5)
    p = stage_problem(stage, data, start, screen=False).problem
    assert p.constraints and all(c.batched for c in p.constraints)
    x1 = p.x0()
    T = np.diag(np.maximum(np.abs(x1), 1e-3)) @ np.linalg.qr(
        np.random.default_rng(2).normal(size=(x1.size, x1.size)))[0]

    def to_x(z):
        return x1 + T @ z
    z = np.random.default_rng(3).normal(scale=0.05, size=x1.size)
    near = p.local_constraints(to_x(z))
    assert callable(getattr(near, "batch", None))

    def fun(z1):
        return near(to_x(z1))
    got = engine._forward_differences(fun, z, near.batch, to_x)
    ref = np.atleast_2d(approx_fprime(z, fun, engine._SLSQP_STEP))
    assert got.shape == ref.shape and np.any(ref != 0)
    np.testing.assert_array_equal(got, ref)


def test_upstream_jacobian_equals_central_differences_one_name_at_a_time(truth, data):
    """The staged jackknife's d residuals / d (earlier stages' coefficients): batched, and
    exactly zero for names the stage does not read (Mx reads no longitudinal coefficient)."""
    sp = stage_problem("Mx", data, truth)
    p = sp.problem
    x = p.x0()
    names = [n for n in STAGES["Fy0"].coefficients + STAGES["Fx0"].coefficients
             if n in truth][:40]
    read = names_read("Mx", {**truth, **p.values(x)}, sp.state, sp.omega)
    assert "PKY1" in read and "PKX1" not in read

    def residuals(phi):
        base = {**truth, **dict(zip(names, (float(v) for v in phi)))}
        model = stage_model("Mx", base, sp.state, sp.omega)
        return (np.asarray(model(p.values(x))) - p.measured) * p.weights()
    ref = engine.fd_jacobian(residuals, np.array([float(truth[n]) for n in names]))
    got = _upstream_jacobian(sp, x, truth, names)
    np.testing.assert_allclose(got, ref, rtol=1e-12, atol=1e-12 * np.max(np.abs(ref)))
    assert np.all(got[:, [j for j, n in enumerate(names) if n not in read]] == 0)


@needs_jax
def test_jacobian_traces_only_the_held_values_it_reads(truth, data, exact, monkeypatch,
                                                       tmp_path):
    """stage_jacobian passes the held values the equations read (Fy0 under JAX: the
    combined-slip ones too); a set that misses one falls back to every value."""
    # traced here: no stored executables (identify.fit.mf.jax_cache), none of this process
    monkeypatch.setenv(mf_jax_cache.CACHE_ENV, str(tmp_path))
    monkeypatch.setattr(mf_jacobian, "_EXECUTABLES", {})
    compiled, traced = mf_jacobian._compiled, []

    def recording(stage, coefficients, held):
        traced.append(held)
        return compiled(stage, coefficients, held)
    monkeypatch.setattr(mf_jacobian, "_compiled", recording)
    sp = stage_problem("Fy0", data, truth, screen=False)
    others = mf_jacobian._read_others("Fy0", truth, sp.state, sp.omega)
    assert "RVY1" in others and "QSX1" not in others and "PKY1" not in others
    J = sp.problem.model_jacobian()
    assert traced == [others]
    monkeypatch.setattr(mf_jacobian, "_read_others", lambda *a: ("FNOMIN",))
    again = stage_problem("Fy0", data, truth, screen=False).problem.model_jacobian()
    np.testing.assert_allclose(again, J, rtol=1e-13, atol=0)
    assert traced[1] == ("FNOMIN",) and set(others) < set(traced[2])  # the fallback ran


@needs_jax
@needs_stop
def test_a_start_on_an_earlier_path_stops_there(truth, data, exact):
    """With the exact Jacobian a start that joins an earlier start's path (here: the same
    start again, whose first iterate is the earlier one's) ends at that start's end point."""
    noisy = add_noise(data, 8)
    p = stage_problem("Fy0", noisy, _perturb(truth, STAGES["Fy0"].coefficients, seed=6),
                      screen=False).problem
    assert p.jacobian is not None
    one = search(p, p.x0()[None, :])
    twice = search(p, np.vstack([p.x0(), p.x0()]))
    assert twice.starts_at_best == 2 and len(twice.candidates) == 1
    np.testing.assert_array_equal(twice.candidates[0], one.candidates[0])
    assert twice.nfev <= one.nfev + 3
