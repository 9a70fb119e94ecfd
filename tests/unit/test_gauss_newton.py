"""The Gauss-Newton phase of the MF stages' least-squares solves (identify.fit.solve.gauss_newton,
Tolerances.gauss_newton in identify.fit.solve.engine): the same optimum in fewer evaluations where
the optimum is inside the bounds, and the trust-region solver's result where it is not or
where there is no noise to stop at."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from test_fit_engine import _magic_sine

from identify.fit.solve.engine import MF_SOLVE, NOISE_STATUS, STRICT, least_squares
from identify.fit.solve.gauss_newton import interior_steps
from identify.fit.solve.problem import PENALTY, penalised

TRF_ONLY = dataclasses.replace(MF_SOLVE, gauss_newton=False)


def _standard_errors(jacobian, est):
    J = jacobian(est.x)
    s2 = 2 * est.cost / (J.shape[0] - J.shape[1])
    return np.sqrt(np.diag(s2 * np.linalg.inv(J.T @ J)))


@pytest.mark.parametrize("x0", [[9.0, 1.35, 1.0, -0.4], [8.0, 1.4, 0.9, -0.2]])
def test_full_steps_end_a_noisy_solve_at_its_optimum_in_fewer_evaluations(x0):
    """From a start in the optimum's basin (as the MF stages' solves on all points start from
    a search candidate) the phase ends by the decrement in fewer evaluations than trf alone
    (4 against 6-7 here), within 0.01 standard errors of the round-off optimum (STRICT)."""
    residuals, jacobian, box = _magic_sine()
    x0 = np.array(x0)
    exact = least_squares(residuals, x0, box, STRICT, jac=jacobian)
    fast = least_squares(residuals, x0, box, MF_SOLVE, jac=jacobian)
    slow = least_squares(residuals, x0, box, TRF_ONLY, jac=jacobian)
    assert fast.status == NOISE_STATUS and "Gauss-Newton step" in fast.message
    assert fast.nfev < slow.nfev
    se = _standard_errors(jacobian, exact)
    assert np.all(np.abs(fast.x - exact.x) / se < 0.01)
    assert 0 <= fast.cost - exact.cost < 1e-4 * 2 * exact.cost / (400 - 4)
    # what the Estimate carries is the residuals and Jacobian at its x (covariance, polish)
    np.testing.assert_array_equal(fast.fun, residuals(fast.x))
    np.testing.assert_allclose(fast.jac, jacobian(fast.x), rtol=0, atol=0)
    assert not fast.active_mask.any()


def test_the_step_and_its_decrement_are_the_least_squares_ones():
    """The phase's first step is numpy's least-squares Gauss-Newton step, its decrement 0.5
    ||J p||^2: one step from the start lands where lstsq says."""
    residuals, jacobian, box = _magic_sine()
    x0 = np.array([9.0, 1.35, 1.0, -0.4])
    p, *_ = np.linalg.lstsq(jacobian(x0), -residuals(x0), rcond=None)
    seen = []
    interior_steps(residuals, jacobian, x0, *box, noise_ftol=1e-4, max_nfev=100,
                   stop=lambda x, cost: seen.append(x) or "first step")
    np.testing.assert_allclose(seen[0], x0 + p, rtol=1e-12)


def test_an_optimum_on_a_bound_is_left_to_the_trust_region_solver():
    """With E's upper bound below its unbounded optimum (-0.5 + noise) the full step leaves
    the box: the phase hands over and trf ends on the bound, as without the phase."""
    residuals, jacobian, (lo, hi) = _magic_sine()
    hi = hi.copy()
    hi[3] = -0.7
    x0 = np.array([9.0, 1.35, 1.0, -0.8])
    steps = interior_steps(residuals, jacobian, x0, lo, hi, noise_ftol=1e-4, max_nfev=100)
    assert not steps.converged and steps.reason == "a full step leaves the bounds"
    est = least_squares(residuals, x0, (lo, hi), MF_SOLVE, jac=jacobian)
    ref = least_squares(residuals, x0, (lo, hi), TRF_ONLY, jac=jacobian)
    assert est.x[3] == pytest.approx(-0.7, abs=1e-9) and est.active_mask[3] == 1
    assert est.success and est.cost == pytest.approx(ref.cost, rel=1e-9)
    assert est.nfev == ref.nfev + steps.nfev  # the phase's evaluations are counted


def test_without_noise_the_solve_still_reaches_the_truth():
    """Noise-free data: the decrement never falls below noise_ftol x s^2 (s^2 -> 0 with it),
    the phase hands over when no step lowers the cost at round-off, and the solve recovers
    the curve's coefficients to 1e-8."""
    residuals, jacobian, box = _magic_sine()
    truth = np.array([10.0, 1.3, 1.0, -0.5])
    noisy = residuals(truth)  # this curve's noise: subtract it to get the exact curve

    def exact(p):
        return residuals(p) - noisy
    est = least_squares(exact, np.array([9.0, 1.35, 1.0, -0.4]), box, MF_SOLVE, jac=jacobian)
    assert est.success
    np.testing.assert_allclose(est.x, truth, rtol=1e-8)


def test_a_point_where_the_model_is_not_finite_is_never_taken_for_converged():
    """Points where the model is not finite get the residual PENALTY and a zero derivative
    (identify.fit.solve.problem.FitProblem.residuals / residual_jacobian), as a trial point outside
    a model's domain does on a real file. The residual variance there is the penalty's: a
    decrement or a five-iteration fall that is small against it says nothing about the noise.
    From a start where a tenth of the points are so penalised (E above -0.45) the phase
    stopped at once, "converged", at a cost of 2e13, and trf alone was ended by the decrement
    stop at another penalised point. Now the phase steps out of the penalised region (the
    clean points' Gauss-Newton step) and trf alone ends by scipy's own step test where it got
    stuck (a local minimum of the penalised cost), not by a noise stop."""
    residuals, jacobian, box = _magic_sine()
    bad = np.arange(400) % 10 == 0

    def penalised_residuals(p):
        r = residuals(p)
        return np.where(bad, PENALTY, r) if p[3] > -0.45 else r

    def penalised_jacobian(p):
        J = jacobian(p)
        return np.where(bad[:, None], 0.0, J) if p[3] > -0.45 else J
    x0 = np.array([9.0, 1.35, 1.0, -0.4])
    assert penalised(penalised_residuals(x0))
    steps = interior_steps(penalised_residuals, penalised_jacobian, x0, *box, noise_ftol=1e-4,
                           max_nfev=100)
    assert not steps.converged
    est = least_squares(penalised_residuals, x0, box, MF_SOLVE, jac=penalised_jacobian)
    assert est.success and not penalised(est.fun)
    assert est.cost < 1e-12 * 0.5 * np.sum(penalised_residuals(x0) ** 2)
    alone = least_squares(penalised_residuals, x0, box, TRF_ONLY, jac=penalised_jacobian)
    assert alone.status != NOISE_STATUS
