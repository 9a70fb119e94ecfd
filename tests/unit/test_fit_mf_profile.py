"""Profile intervals (identify.fit.mf.profile): equal to the linearised interval where the cost is
quadratic, the exact profile's end where it is flatter than the quadratic approximation, a
bound where the interval would pass it."""
from __future__ import annotations

import dataclasses
import json
import math

import lmfit
import numpy as np
import pytest
from scipy.optimize import brentq

from identify.fit.identifiability import unidentified
from identify.fit.mf.profile import MAX_REFITS, TOLERANCE, profile_ends
from identify.fit.optimize import fit
from identify.fit.result import FitResult
from identify.fit.solve.covariance import t_quantile
from identify.fit.solve.problem import FitProblem

T_S = np.linspace(0.0, 2.0, 12)
"""Sample times [s] of the decay test."""


def _decay(v):
    return v["A"] * np.exp(-v["k"] * T_S)


def _line(v):
    return v["A"] + v["k"] * T_S


def _problem(model, y, start, k_max=50.0, sigma=0.06):
    """Weighted least squares with the noise's standard deviation known (the standard errors
    are then (J^T J)^-1 of the weighted residuals, their quantile the normal's)."""
    P = lmfit.Parameters()
    P.add("A", value=start[0], min=-100.0, max=100.0)
    P.add("k", value=start[1], min=0.0, max=k_max)
    return FitProblem("test", "decay", P, model, y, np.full(y.size, 2.0), objective="wls",
                      sigma=np.full(y.size, sigma))


def _decay_data(seed: int, noise: float = 0.06) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return _decay({"A": 1.0, "k": 3.0}) + noise * rng.standard_normal(T_S.size)


def _profile_cost_k(y: np.ndarray, k: float) -> float:
    """The decay's least-squares cost at rate k with A at its optimum (A enters linearly:
    closed form, independent of the code under test)."""
    e = np.exp(-k * T_S)
    return float(y @ y - (y @ e) ** 2 / (e @ e))


def _found(result: FitResult, problem: FitProblem, names=("A", "k"), **kw):
    x = np.array([result.parameters[n] for n in problem.free])
    return profile_ends(problem, x, list(names), dict(result.stderr),
                        {n: result.quantile(n) for n in names}, **kw)


def _ends(result: FitResult, problem: FitProblem, names=("A", "k")):
    found = _found(result, problem, names)
    return found.ends, found.unconverged


def test_a_quadratic_cost_keeps_the_linearised_interval():
    """A model linear in its coefficients: the cost is exactly quadratic, so the profile
    interval is value +/- t standard errors (to rounding), without a refit changing it."""
    rng = np.random.default_rng(3)
    y = _line({"A": 1.0, "k": 0.4}) + 0.05 * rng.standard_normal(T_S.size)
    problem = _problem(_line, y, (0.5, 0.5), sigma=0.05)
    result = fit(problem)
    assert not result.at_bound
    ends, linear = _ends(result, problem)
    assert linear == 0
    for n in ("A", "k"):
        assert ends[n] == pytest.approx(result.wald_interval(n), rel=1e-12, abs=1e-12), n


def test_a_curved_cost_moves_the_flatter_end_to_the_profile():
    """y = A exp(-k t), 12 points, noise 10 % of the start value: the profile of k is
    lopsided, flatter than the quadratic approximation above the optimum and steeper below.
    The upper end, found by refits, agrees with the closed-form profile (A optimal for each
    k) within the search tolerance, where the linearised end is off by more than it; the lower
    end stays linearised (an end only moves outwards)."""
    y = _decay_data(seed=1, noise=0.1)
    problem = _problem(_decay, y, (0.8, 2.0), sigma=0.1)
    result = fit(problem)
    assert result.converged and result.covariance == "iid-known-sigma"
    ends, linear = _ends(result, problem)
    assert linear == 0
    k_hat = result.parameters["k"]
    # known sigma: T = q^2 in the weighted cost, q^2 sigma^2 in the plain one
    rise = t_quantile(result.dof.get("k", math.inf)) ** 2 * 0.1 ** 2
    base = _profile_cost_k(y, k_hat)
    f = lambda k: _profile_cost_k(y, k) - base - rise  # noqa: E731
    half = result.quantile("k") * result.stderr["k"]
    ref_lo = brentq(f, k_hat - 10 * half, k_hat)
    ref_hi = brentq(f, k_hat, k_hat + 10 * half)
    wald_lo, wald_hi = result.wald_interval("k")
    lo, hi = ends["k"]
    # the test means something: the profile is lopsided, flatter above, steeper below
    assert (ref_hi - k_hat) / (k_hat - ref_lo) > 1.2
    assert ref_hi - wald_hi > 2 * TOLERANCE * (ref_hi - k_hat)
    assert ref_lo > wald_lo
    # an end found by refits: sqrt(rise / T) within TOLERANCE of 1, i.e. its distance from the
    # optimum within ~TOLERANCE of the exact one (1 % margin for the curvature)
    assert hi == pytest.approx(ref_hi, abs=(TOLERANCE + 0.01) * (ref_hi - k_hat))
    assert lo == wald_lo


def test_the_refit_budget_goes_to_the_flattest_ends_and_the_rest_stay_linearised():
    """The budget bounds the work on a real session whose costs are flat along many
    coefficients. With no refits allowed, the flatter end of the decay's k keeps its
    linearised end and is counted over budget; with enough for one end, that end gets them.
    Where two ends are flatter (a saturation curve), the budget for one goes to the flatter
    and the other keeps its linearised end."""
    y = _decay_data(seed=1, noise=0.1)
    problem = _problem(_decay, y, (0.8, 2.0), sigma=0.1)
    result = fit(problem)
    full = _found(result, problem)
    assert full.refits > 0 and full.over_budget == 0
    none = _found(result, problem, budget=0)
    assert none.refits == 0 and none.over_budget >= 1
    for n in ("A", "k"):
        assert none.ends[n] == pytest.approx(result.wald_interval(n), rel=1e-12), n
    one = _found(result, problem, budget=MAX_REFITS)
    assert one.ends["k"][1] == full.ends["k"][1] > result.wald_interval("k")[1]
    # one flatter end refitted, every other flatter end over budget
    assert 0 < one.refits <= MAX_REFITS and one.over_budget == none.over_budget - 1

    # two flatter ends, the flattest first: a saturation curve (the trials' set-up, draw 0),
    # whose screen puts k's upper end at 0.72 of its threshold and A's at 0.77 (measured)
    rng = np.random.default_rng(1000)
    y = _saturation({"A": 1.0, "k": 1.0}) + 0.1 * rng.standard_normal(X_MM.size)
    problem = _problem(_saturation, y, (1.0, 1.0), k_max=1e3, sigma=0.1)
    result = fit(problem, n_starts=4, seed=0)
    full, one = _found(result, problem), _found(result, problem, budget=MAX_REFITS)
    assert full.over_budget == 0 and one.over_budget == 1
    assert one.ends["k"][1] == full.ends["k"][1] > result.wald_interval("k")[1]
    assert one.ends["A"][1] == result.wald_interval("A")[1] < full.ends["A"][1]


def test_an_interval_that_would_pass_a_bound_stops_there():
    y = _decay_data(seed=7)
    result = fit(_problem(_decay, y, (0.8, 2.0)))
    k_hat = result.parameters["k"]
    half = result.quantile("k") * result.stderr["k"]
    bounded = _problem(_decay, y, (result.parameters["A"], k_hat), k_max=k_hat + 0.5 * half)
    ends, _ = _ends(result, bounded, names=("k",))
    assert ends["k"][1] == k_hat + 0.5 * half


def _result_with_profile(profile):
    rng = np.random.default_rng(3)
    y = _line({"A": 1.0, "k": 0.4}) + 0.05 * rng.standard_normal(T_S.size)
    result = fit(_problem(_line, y, (0.5, 0.5), sigma=0.05))
    return dataclasses.replace(result, profile=profile)


def test_the_interval_is_the_profile_where_there_is_one_and_round_trips():
    r = _result_with_profile({"k": (-0.9, 0.1)})
    assert r.interval("k") == (-0.9, 0.1)
    assert r.interval("A") == r.wald_interval("A")
    assert r.interval("k", level=0.68) == r.wald_interval("k", level=0.68)
    back = FitResult.from_dict(json.loads(json.dumps(r.to_dict())))
    assert back.profile == {"k": (-0.9, 0.1)} and back.interval("k") == (-0.9, 0.1)
    assert FitResult.from_dict({k: v for k, v in r.to_dict().items()
                                if k != "profile"}).profile == {}


def test_a_profile_wider_than_the_bounds_is_not_identifiable():
    """The identifiability rule "interval wider than its bounds" reads the profile interval."""
    r = _result_with_profile({"k": (-1e3, 1e3)})
    assert unidentified(r)["k"] == "95 % interval wider than its bounds"
    assert "k" not in unidentified(_result_with_profile({}))


X_MM = np.linspace(0.1, 2.0, 8)
"""Substrate levels of the saturation test (Michaelis-Menten: y = A x / (k + x))."""


def _saturation(v):
    return v["A"] * X_MM / (v["k"] + X_MM)
