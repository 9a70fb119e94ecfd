"""Coefficients that take effect only after the fit are kept only when they improve it
significantly (identify.fit.mf.stages._refine, rule 3 of identify.fit.mf.screen).

The kappa-induced side force SVyk = DVyk sin(RVY5 atan(RVY6 kappa)), DVyk ~ muy Fz (RVY1 +
RVY2 dfz + RVY3 gamma) cos(atan(RVY4 alpha)): RVY4..6 shape a term whose size RVY1..3 set, and
at RVY1..3 = 0 they have no effect, so the screen holds them. Once the fit moves RVY1..3, they
have one and the stage is fitted again with them. On generated TTC sessions of the bundled
tyre (RVY1..3 = 0) that happened in 4 of 30 seeds, and RVY4..6 were fitted to the noise and
reported identifiable (seed 10: RVY6 = 219 +- 14, truth 10, of no effect in the truth). Now
the re-fit is taken only when it lowers chi^2, on the scale of the stage's intervals, by more
than the 95 % quantile of chi^2 with as many degrees of freedom as coefficients it adds (7.81
for 3): a likelihood-ratio test.

The table: noise-free Fy and Fx of the bundled tyre with RVY1 set, plus 1 % iid noise, on
drive/brake sweeps (|kappa| <= 0.15) at 3 loads x 5 slip angles x 2 cambers; the Fy stage
alone from the truth with RVY1..3 at 0.
"""
from __future__ import annotations

import lmfit
import numpy as np
import pandas as pd
import pytest
from scipy.stats import chi2

from identify.fit.mf.stages import _chi2_gain, fit_mf
from identify.fit.optimize import fit
from identify.fit.solve.problem import FitProblem
from identify.io.tir import read_tir
from identify.model.evaluate import evaluate
from identify.model.modes import FIT_MODE
from identify.model.parameters import defaults
from identify.simulate import default_tir_path


def _table(truth: dict, seed: int, noise: float = 0.01) -> pd.DataFrame:
    kappa = np.linspace(-0.15, 0.15, 61)
    rows = [pd.DataFrame({"run": f"db{lf}_{a}_{g}", "Fz": lf * truth["FNOMIN"],
                          "p": truth["NOMPRES"], "Vx": 11.1, "kappa": kappa,
                          "alpha": np.deg2rad(a), "gamma": np.deg2rad(g)})
            for lf in (0.6, 1.0, 1.4) for a in (-6, -3, 0, 3, 6) for g in (0, 2)]
    t = pd.concat(rows, ignore_index=True)
    out = evaluate(truth, *(t[c].to_numpy() for c in ("Fz", "kappa", "alpha", "gamma", "Vx")),
                   p=t["p"].to_numpy(), mode=FIT_MODE)
    rng = np.random.default_rng(seed)
    noisy = {q: np.asarray(out[q]) for q in ("Fx", "Fy")}
    for q, v in noisy.items():
        noisy[q] = v + noise * np.sqrt(np.mean(v ** 2)) * rng.standard_normal(v.size)
    return t.assign(**noisy)


def _case(rvy1: float, shape_start: dict | None = None) -> tuple[dict, dict]:
    truth = read_tir(default_tir_path()).params()
    truth.update(RVY1=rvy1)
    start = {k: float(v) for k, v in defaults().items() if not isinstance(v, str)}
    start.update({k: float(v) for k, v in truth.items() if not isinstance(v, str)})
    start.update(RVY1=0.0, RVY2=0.0, RVY3=0.0, KPUMIN=-0.15, KPUMAX=0.15, **(shape_start or {}))
    return truth, start


SEEDS = range(12)
"""Noise seeds of the held-shape test: enough for a statement about a 5 % test's rate."""


def test_a_shape_that_does_not_improve_the_fit_stays_held():
    """RVY1 = 0.003 (about 10 of its standard errors) gives RVY4..6 an effect; the truth's
    values are their start, so freeing them can lower chi^2 only by fitting noise, and the
    likelihood-ratio test at 5 % (7.81, chi^2 with 3 degrees of freedom) should take the
    re-fit in about 1 seed of 20. Measured over seeds 0-39 (2026-11-28, numpy 2.4, scipy
    1.17): taken in 2 (seeds 0 and 16, gains 8.38 and 8.62: RVY6 = 477 in seed 0, a step at
    kappa = 0 fitted to the noise), held in 38 (gains 0.19-7.14, mean 2.4 against chi^2(3)'s
    3). Until that date the test asked for seeds 0-3 all held (seed 0's gain was 4.33 with
    the packages of then): a 5 % test passes that only 81 % of the time, and seed 0 moved with
    scipy's solver path. Here at most 2 of seeds 0-11 may be taken (a calibrated test exceeds
    that with probability 2.0 %); without the test every re-fit that lowers the objective would
    be taken, all 12. Every held seed says why in fit.json, with its gain below 7.81."""
    truth, start = _case(0.003)
    taken = []
    for seed in SEEDS:
        lines: list[str] = []
        mf = fit_mf(_table(truth, seed), start, stages=("Fy",), seed=0, progress=lines.append)
        r = mf.result("Fy")
        assert r.converged and "RVY1" in r.free
        assert abs(r.parameters["RVY1"] - 0.003) < 3 * r.stderr["RVY1"]
        assert any("re-fit with RVY4, RVY5, RVY6" in line for line in lines)
        if "RVY4" in r.free:
            taken.append(seed)
            continue
        for name in ("RVY4", "RVY5", "RVY6"):
            assert name not in r.free and r.parameters[name] == truth[name]
            why = mf.held["Fy"][name]
            assert "freeing RVY4, RVY5, RVY6 lowered chi^2 by" in why
            gain = float(why.split("lowered chi^2 by ")[1].split()[0])
            assert 0 <= gain < chi2.ppf(0.95, 3)
    assert len(taken) <= 2, taken


def test_a_shape_the_data_need_is_freed_and_recovered():
    """RVY1 = 0.05 with RVY4..6 started at the parameter table's defaults (20, 2, 10; truth 10,
    1.9, 10): the re-fit lowers chi^2 far beyond 7.81 and is taken; each comes back within 3
    of its standard errors (RVY1 and RVY5 by their sign-symmetric pair where the fit ends at
    RVY1 < 0; RVY4 acts through cos(atan(RVY4 alpha)), even in it)."""
    truth, start = _case(0.05, {"RVY4": 20.0, "RVY5": 2.0, "RVY6": 10.0})
    mf = fit_mf(_table(truth, 2), start, stages=("Fy",), seed=0)
    r = mf.result("Fy")
    assert r.converged and {"RVY4", "RVY5", "RVY6"} <= set(r.free)
    assert "RVY4" not in mf.held.get("Fy", {})
    sign = np.sign(r.parameters["RVY1"])
    for name, s in (("RVY1", sign), ("RVY4", np.sign(r.parameters["RVY4"])), ("RVY5", sign),
                    ("RVY6", 1.0)):
        assert abs(s * r.parameters[name] - truth[name]) < 3 * r.stderr[name], name


def test_the_gain_is_counted_on_the_larger_models_variance():
    """The F test of nested models: the objective's fall divided by the residual variance of
    the model with the added coefficients, not of the one without them. A misfit that only
    the added coefficients remove inflates the smaller model's variance, and on its scale
    the fall can never exceed n - k: on a generated TTC session of the golden test tyre (seed
    5, raw samples) the Fy stage without RVY4..6 ended 22 % off the data, and a re-fit that
    lowered its objective 290-fold counted as chi^2 5.8, "not significant". Here a line's
    slope b is the added coefficient (iid weights, so the intervals' scale is s^2 itself):
    the gain must be (wls_0 - wls_1) (n - 2) / wls_1, about 7e6, where the smaller model's
    scale gives less than n = 200."""
    x = np.linspace(-1.0, 1.0, 200)
    y = 1.0 + 3.0 * x + 0.01 * np.random.default_rng(0).standard_normal(x.size)

    def problem(vary_b: bool) -> FitProblem:
        P = lmfit.Parameters()
        P.add("a", value=0.5)
        P.add("b", value=0.0, vary=vary_b)
        return FitProblem("line", "a + b x", P, lambda v: v["a"] + v["b"] * x, y,
                          np.full(x.size, 2.0), objective="wls")

    small, big = fit(problem(False)), fit(problem(True))
    assert big.free == ("a", "b") and big.wls < small.wls
    expected = (small.wls - big.wls) * (x.size - 2) / big.wls
    gain = _chi2_gain(problem(True), small, big)
    assert gain == pytest.approx(expected, rel=1e-6)
    assert gain > 1e6 > x.size
