"""The global constrained fitting engine on problems with known answers."""
from __future__ import annotations

import lmfit
import numpy as np
import pytest

from identify.fit.metric import group_weights, thesis_error, thesis_total
from identify.fit.optimize import fit
from identify.fit.problem import Constraint, FitProblem

PRESSURES = np.repeat([1.9, 2.2, 2.5, 2.7, 3.0], 3)
LOADS = np.tile([3000.0, 5000.0, 7000.0], 5)
DFZ = (LOADS - 5000) / 5000
DPI = (PRESSURES - 2.5) / 2.5


def stiffness(v):
    """C = C_nom (1 + p1 dfz + p2 dfz^2)(1 + p3 dpi) [N/m] (the CFx/CFy relation form)."""
    return v["nom"] * (1 + v["p1"] * DFZ + v["p2"] * DFZ ** 2) * (1 + v["p3"] * DPI)


def _params(start, vary_p2=True):
    P = lmfit.Parameters()
    P.add("nom", value=start["nom"], min=1e4, max=1e6)
    P.add("p1", value=start["p1"], min=-1, max=1)
    P.add("p2", value=start["p2"], min=-0.6, max=0.6, vary=vary_p2)
    P.add("p3", value=start["p3"], min=0, max=1)
    return P


def test_thesis_metric_by_hand():
    # 100*sqrt(((1-1)^2 + (3-2)^2)/(1^2 + 2^2)) = 100/sqrt(5)
    assert thesis_error([1.0, 3.0], [1.0, 2.0]) == pytest.approx(100 / np.sqrt(5), rel=1e-15)
    # total = mean over pressures: (0 + 100/sqrt(5))/2
    assert thesis_total([1, 1, 1, 3], [1, 1, 1, 2], [1, 1, 2, 2]) == pytest.approx(
        50 / np.sqrt(5), rel=1e-15)
    w = group_weights(np.array([3.0, 4.0, 1.0]), np.array([1, 1, 2]))
    np.testing.assert_allclose(w, [0.2, 0.2, 1.0], rtol=1e-15)


@pytest.mark.parametrize("objective", ["thesis", "wls"])
@pytest.mark.parametrize("sign", [-1, 1])
def test_recovery_without_noise_from_perturbed_start(objective, sign):
    truth = {"nom": 1.43e5, "p1": 0.17, "p2": -0.25, "p3": 0.47}
    data = stiffness(truth)
    start = {k: v * (1 + sign * 0.2) for k, v in truth.items()}
    result = fit(FitProblem("CFy", "quadratic_load", _params(start), stiffness, data, PRESSURES,
                            objective=objective), seed=1)
    assert result.converged
    for k, v in truth.items():
        # exact data: 1e-6 relative is the recovery level; the solvers stop at
        # ftol/xtol far below it
        assert result.parameters[k] == pytest.approx(v, rel=1e-6), k
    assert result.error_total_pct < 1e-6
    assert result.starts_at_best >= 0.5 * result.n_starts


def test_constraint_is_respected_and_reported():
    """Data whose unconstrained optimum has p2 > 0; with p2 <= 0 enforced as a general
    constraint the fit sits on it and says so."""
    truth = {"nom": 1.4e5, "p1": 0.17, "p2": 0.3, "p3": 0.47}
    data = stiffness(truth)
    P = _params({"nom": 1.5e5, "p1": 0.1, "p2": 0.0, "p3": 0.4})
    free_fit = fit(FitProblem("CFy", "quadratic_load", P, stiffness, data, PRESSURES))
    assert free_fit.parameters["p2"] == pytest.approx(0.3, rel=1e-6)
    constrained = fit(FitProblem("CFy", "quadratic_load", P, stiffness, data, PRESSURES,
                                 constraints=(Constraint("pCFy2 <= 0",
                                                         lambda v: np.array([-v["p2"]])),)))
    assert constrained.converged
    assert constrained.parameters["p2"] <= 1e-9
    assert constrained.active_constraints == ("pCFy2 <= 0",)
    assert constrained.error_total_pct > free_fit.error_total_pct


def test_bound_activity_is_reported():
    truth = {"nom": 1.4e5, "p1": 0.17, "p2": 0.3, "p3": 0.47}
    P = _params({"nom": 1.5e5, "p1": 0.1, "p2": -0.1, "p3": 0.4})
    P["p2"].set(max=0.0)
    result = fit(FitProblem("CFy", "quadratic_load", P, stiffness, stiffness(truth), PRESSURES))
    assert result.at_bound == ("p2",)
    assert result.parameters["p2"] == 0.0


def test_result_to_dict_is_json_safe():
    import json

    truth = {"nom": 1.43e5, "p1": 0.17, "p2": 0.0, "p3": 0.47}
    rng = np.random.default_rng(0)
    data = stiffness(truth) * (1 + 0.01 * rng.standard_normal(PRESSURES.size))
    result = fit(FitProblem("CFy", "linear_load", _params(truth, vary_p2=False), stiffness,
                            data, PRESSURES))
    d = json.loads(json.dumps(result.to_dict()))
    assert set(d["parameters"]) == {"nom", "p1", "p3"} and d["fixed"] == {"p2": 0.0}
    assert set(d["error_by_pressure_pct"]) == {"1.9", "2.2", "2.5", "2.7", "3"}
    assert d["stderr"]["p1"] > 0
    assert "CFy [linear_load]" in result.report()
