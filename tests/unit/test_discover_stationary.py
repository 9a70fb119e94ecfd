"""When a discovery solve is at its minimum: the Gauss-Newton gain within the bounds (a
parameter on its bound pulled outwards is at its minimum there, not stalled)."""
from __future__ import annotations

import lmfit
import numpy as np
import pytest

from identify.discover.objective import STATIONARY_GAIN, Objective, bounded_gauss_newton
from identify.fit.solve.problem import FitProblem


def test_bounded_gauss_newton_closed_form():
    """J = [1, 1]^T, r = [1, 1]: the free step is -1 and takes all of r^T r = 2 off; with
    the step held to >= -0.1 the residuals become 0.9 each, a gain of 2 - 2 x 0.81."""
    J, r = np.ones((2, 1)), np.ones(2)
    step, gain = bounded_gauss_newton(J, r, np.array([-np.inf]), np.array([np.inf]))
    assert step == pytest.approx([-1.0]) and gain == pytest.approx(2.0)
    step, gain = bounded_gauss_newton(J, r, np.array([-0.1]), np.array([np.inf]))
    assert step == pytest.approx([-0.1]) and gain == pytest.approx(2.0 - 2 * 0.81)
    step, gain = bounded_gauss_newton(J, r, np.array([0.0]), np.array([1.0]))
    assert step == pytest.approx([0.0], abs=1e-12) and gain == pytest.approx(0.0, abs=1e-12)


def _slope_problem(upper: float) -> FitProblem:
    """y = exp(a t) + noise with a = 2, fitted with a <= ``upper``."""
    t = np.linspace(0.0, 1.0, 200)
    y = np.exp(2.0 * t) + 0.01 * np.random.default_rng(0).standard_normal(t.size)
    P = lmfit.Parameters()
    P.add("a", value=0.5, min=0.0, max=upper)
    return FitProblem("x", "slope", P, lambda v: np.exp(v["a"] * t), y, np.ones(t.size),
                      objective="wls", sigma=np.full(t.size, 0.01))


def test_a_parameter_on_its_bound_is_at_its_minimum():
    """The rate capped at 1 against data of rate 2: the unbounded Gauss-Newton step would
    take thousands of residual variances off, yet the capped fit is the minimum."""
    obj = Objective(_slope_problem(1.0), [np.arange(200)])
    sol = obj.solve(np.array([0.5]))
    assert sol.x[0] == pytest.approx(1.0, abs=1e-6)
    s2 = sol.rss / (sol.r.size - 1)
    _, free_gain = bounded_gauss_newton(sol.jac, sol.r, np.array([-np.inf]),
                                        np.array([np.inf]))
    assert free_gain > 100 * s2 > STATIONARY_GAIN * s2  # the case
    assert sol.stationary


def test_a_solve_stopped_short_is_not_stationary():
    """Stopped at a budget of two evaluations far from the rate 2: not a minimum; with the
    default budget it reaches one."""
    obj = Objective(_slope_problem(5.0), [np.arange(200)])
    short = obj.solve(np.array([0.5]), max_nfev=2)
    assert abs(short.x[0] - 2.0) > 0.1 and not short.stationary
    full = obj.solve(np.array([0.5]))
    assert full.x[0] == pytest.approx(2.0, abs=1e-3) and full.stationary
