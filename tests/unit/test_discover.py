"""mfid discover: the method on synthetic problems (fast; the statistical trials are in
tests/trials/test_discovery_trials.py)."""
from __future__ import annotations

import json

import lmfit
import numpy as np
import pytest

from identify.core.errors import InputError
from identify.discover.library import load_library, parse_library
from identify.discover.noise import choose_noise, fit_ar1, sweep_index, variogram, whiten
from identify.discover.scenarios import Matrix, make_problem
from identify.discover.score import ambiguity_groups, canonical_cosines, holm, score_candidates
from identify.discover.search import Settings, discover
from identify.fit.solve.problem import FitProblem

SMALL = Matrix(density=0.3)


@pytest.fixture(scope="module")
def library():
    return load_library()


@pytest.fixture(scope="module")
def hidden_ppy5(library):
    problem, truth = make_problem("MF/Fy", np.random.default_rng(7), "PPY5", -0.2, matrix=SMALL)
    return discover([problem], library, Settings()), truth


def test_hidden_ppy5_is_named(hidden_ppy5):
    d, truth = hidden_ppy5
    assert d.named == "PPY5"
    a = d.accepted[0]
    assert a.coefficients["PPY5"] == pytest.approx(-0.2, abs=4 * a.stderr["PPY5"] + 0.01)
    assert a.error_after_pct < a.error_before_pct
    assert a.heldout_after_pct < a.heldout_before_pct
    assert a.excess_explained > 0.8
    assert "camber thrust stiffness depends on inflation pressure" in d.conclusion
    assert "PPY5 = -0.2" in d.conclusion


def test_candidate_table_and_json_schema(hidden_ppy5):
    d, _ = hidden_ppy5
    doc = json.loads(json.dumps(d.to_dict()))
    assert doc["schema"] == "mfid.discovery/1"
    for key in ("base", "steps", "accepted", "noise_floor_pct", "excess_explained",
                "conclusion"):
        assert key in doc
    acc = doc["accepted"][0]
    for key in ("name", "coefficients", "error_before_pct", "error_after_pct",
                "heldout_before_pct", "heldout_after_pct", "p_value"):
        assert key in acc
    assert acc["name"] == "PPY5" and set(acc["coefficients"]) == {"PPY5"}
    rows = {r["name"]: r for r in doc["steps"][0]["candidates"]}
    assert set(rows) == {"PPY1", "PPY2", "PPY3", "PPY4", "PPY5"}
    assert rows["PPY5"]["passes"] and rows["PPY5"]["p_holm"] < 1e-6
    assert doc["base"]["problems"][0]["noise"]["kind"] == "independent"
    assert doc["base"]["problems"][0]["cells"]
    assert 0.5 < doc["noise_floor_pct"] < 2.0


def test_null_data_adds_nothing(library):
    for scenario, seed in (("MF/Fx", 3), ("RR", 4), ("CFy", 5)):
        problem, _ = make_problem(scenario, np.random.default_rng(seed), None, matrix=SMALL)
        d = discover([problem], library, Settings())
        assert d.accepted == (), (scenario, d.conclusion)
        assert d.conclusion.startswith("No missing effect found")


def test_ar1_noise_is_diagnosed_and_prewhitened(library):
    problem, _ = make_problem("RR", np.random.default_rng(11), "QSY8", -0.4, rho=0.9,
                              matrix=SMALL)
    d = discover([problem], library, Settings())
    p = d.problems[0]
    assert p.base_noise.kind == "ar1" and 0.7 < p.base_noise.phi < 0.99
    assert d.named == "QSY8"


def test_ambiguity_group_with_two_pressure_levels(library):
    m = Matrix(pressures_bar=(2.5, 3.0), density=0.3)
    problem, _ = make_problem("MF/Fy", np.random.default_rng(2), "PPY3", -0.12, matrix=m)
    d = discover([problem], library, Settings(max_steps=1))
    rows = {r.name: r for r in d.steps[0].candidates}
    assert rows["PPY3"].cosines["PPY4"] > 0.999
    assert "PPY4" in rows["PPY3"].ambiguity_group
    assert d.accepted and set(d.accepted[0].ambiguous_with) | {d.accepted[0].name} >= {
        "PPY3", "PPY4"}
    assert d.named is None  # never one confident name
    assert "ambiguous" in d.conclusion


def test_symmetric_pressures_make_a_quadratic_term_untestable(library):
    m = Matrix(pressures_bar=(2.2, 2.8), density=0.3)
    problem, _ = make_problem("MF/Fx", np.random.default_rng(2), None, matrix=m)
    d = discover([problem], library, Settings())
    rows = {r.name: r for r in d.steps[0].candidates}
    assert not rows["PPX2"].testable and not rows["PPX4"].testable
    assert "Not testable" in d.conclusion


# ----- score test, Holm, noise ----------------------------------------------------------------

def _linear_case(rng, beta_c=0.0, n=400):
    """Residuals r = model - y of a straight-line fit to data with a quadratic term."""
    x = np.linspace(-1, 1, n)
    J = np.column_stack([np.ones(n), x])
    g = x ** 2
    y = 1.0 + 0.5 * x + beta_c * g + 0.1 * rng.standard_normal(n)
    coef, *_ = np.linalg.lstsq(J, y, rcond=None)
    return J @ coef - y, J, g, y


def test_score_is_the_one_step_f_test_of_a_linear_model():
    rng = np.random.default_rng(0)
    r, J, g, y = _linear_case(rng, beta_c=0.05)
    scores, _ = score_candidates(r, J, {"c": g[:, None]})
    full = np.column_stack([J, g])
    coef, *_ = np.linalg.lstsq(full, y, rcond=None)
    rss0, rss1 = float(r @ r), float(np.sum((full @ coef - y) ** 2))
    f = (rss0 - rss1) / (rss1 / (r.size - 3))
    assert scores["c"].statistic == pytest.approx(f, rel=1e-8)
    assert scores["c"].drop == pytest.approx(rss0 - rss1, rel=1e-8)
    assert scores["c"].step[0] == pytest.approx(coef[2], rel=1e-8)


def test_projection_removes_what_the_fit_explains():
    rng = np.random.default_rng(1)
    r, J, g, _ = _linear_case(rng)
    scores, proj = score_candidates(r, J, {"in_span": (2 * J[:, 1])[:, None],
                                           "new": g[:, None],
                                           "block": np.column_stack([g, g ** 2])})
    assert not scores["in_span"].testable and scores["in_span"].rel_norm < 1e-8
    assert scores["new"].testable and scores["block"].dof == 2
    cos = canonical_cosines({k: proj[k] for k in ("new", "block")})
    assert cos[("new", "block")] == pytest.approx(1.0)
    assert ambiguity_groups(["new", "block"], cos) == [("new", "block")]


def test_holm_adjustment():
    adj = holm({"a": 0.01, "b": 0.04, "c": 0.03})
    assert adj == {"a": pytest.approx(0.03), "c": pytest.approx(0.06), "b": pytest.approx(0.06)}


def test_null_score_p_values_are_uniformish():
    rng = np.random.default_rng(3)
    ps = []
    for _ in range(300):
        r, J, g, _ = _linear_case(rng)
        ps.append(score_candidates(r, J, {"c": g[:, None]})[0]["c"].p_value)
    assert 0.02 < np.mean(np.array(ps) < 0.05) < 0.09


def _ar1(rng, rho, n_sweeps=40, n=150):
    out = []
    for _ in range(n_sweeps):
        z = rng.standard_normal(n)
        x = np.empty(n)
        x[0] = z[0]
        for t in range(1, n):
            x[t] = rho * x[t - 1] + np.sqrt(1 - rho ** 2) * z[t]
        out.append(x)
    return np.concatenate(out), sweep_index(np.repeat(np.arange(n_sweeps), n), n_sweeps * n)


def test_noise_model_choice():
    rng = np.random.default_rng(4)
    e, idx = _ar1(rng, 0.0)
    assert choose_noise(e, idx).kind == "independent"
    e, idx = _ar1(rng, 0.9)
    m = choose_noise(e, idx)
    assert m.kind == "ar1" and m.phi == pytest.approx(0.9, abs=0.05)
    phi, s2 = fit_ar1(variogram(e, idx, 20))  # long lags pin the plateau
    assert s2 == pytest.approx(1.0, rel=0.2)
    w = whiten(e, idx, m.phi)
    assert fit_ar1(variogram(w, idx))[0] < 0.2
    trend = np.concatenate([np.sin(np.linspace(0, 3, 150))] * 40)  # smooth misfit
    assert choose_noise(rng.standard_normal(e.size) * 0.1 + trend, idx).kind == "independent"
    assert choose_noise(e[:12], sweep_index(None, 12)).kind == "independent"


# ----- library ---------------------------------------------------------------------------------

def test_library_covers_the_pressure_coefficients(library):
    coefs = set(library.neutral_values())
    for key in ("PPX1", "PPX2", "PPX3", "PPX4", "PPY1", "PPY2", "PPY3", "PPY4", "PPY5",
                "PPZ1", "PPZ2", "PPMX1", "QSY7", "QSY8", "PFZ1", "PCFX2", "PCFX3", "PCFY2",
                "PCFY3", "PCMZ1", "PCMZ2", "F_X", "F_Y", "F_Z", "F_THETA", "F_GAMMA", "F_PSI"):
        assert key in coefs
    assert library.neutral_values()["QSY7"] == 1.0
    assert library["CMZ_T2"].coefficients == {"PCMZ2": 0.0}
    assert {"RR/old", "CMz/T1", "CFy/linear_load"} <= set(library.forms)
    for c in library.candidates:
        assert c.description and c.equation and c.relations


USER = """
[[candidate]]
name = "PPY34"
coefficients = { PPY3 = 0.0, PPY4 = 0.0 }
bounds = { PPY3 = [-2.0, 2.0], PPY4 = [-2.0, 2.0] }
relations = ["MF/Fy"]
equation = "muy = ...(1 + PPY3*dpi + PPY4*dpi^2)"
description = "lateral peak friction depends on pressure (linear and quadratic, jointly)"

[[candidate]]
name = "PPY5"
coefficients = { PPY5 = 0.0 }
bounds = { PPY5 = [-0.5, 0.5] }
relations = ["MF/Fy"]
equation = "Kyg0 = ...(1 + PPY5*dpi)"
description = "user-bounded camber stiffness pressure term"
"""


def test_user_toml_extends_and_overrides(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text(USER)
    lib = load_library(path)
    assert lib["PPY34"].dof == 2 and lib["PPY34"].source == str(path)
    assert lib["PPY5"].bounds["PPY5"] == (-0.5, 0.5)
    assert len(lib.candidates) == len(load_library().candidates) + 1
    problem, _ = make_problem("MF/Fy", np.random.default_rng(5), "PPY3", -0.1, matrix=SMALL)
    d = discover([problem], lib.only(["PPY34", "PPY5"]), Settings(max_steps=1))
    rows = {r.name: r for r in d.steps[0].candidates}
    assert rows["PPY34"].dof == 2 and rows["PPY34"].passes
    assert d.accepted[0].name == "PPY34" and set(d.accepted[0].coefficients) == {"PPY3",
                                                                                "PPY4"}


@pytest.mark.parametrize("text, what", [
    ("[[candidate]]\nname = 'X'\n", "missing"),
    ("[[candidate]]\nname='X'\ncoefficients={A=0.0}\nbounds={A=[1.0, 2.0]}\nrelations=['MF']\n"
     "equation='e'\ndescription='d'\n", "must contain the neutral"),
    ("[[candidate]\n", "malformed TOML"),
    ("[[candidate]]\nname='X'\ncoefficients={A='a'}\nrelations=['MF']\nequation='e'\n"
     "description='d'\n", "finite number"),
])
def test_bad_user_toml(text, what):
    with pytest.raises(InputError, match=what):
        parse_library(text, "mine.toml")


def test_generic_fitproblem_with_a_fixed_neutral_coefficient(library):
    """Any FitProblem whose library coefficients sit fixed at neutral is a base model."""
    rng = np.random.default_rng(9)
    fz = np.repeat([3000.0, 5000.0, 7000.0], 5)
    pb = np.tile([1.9, 2.2, 2.5, 2.7, 3.0], 3)
    dp, dfz = (pb - 2.5) / 2.5, (fz - 5000) / 5000

    def model(v):
        return v["LONGITUDINAL_STIFFNESS"] * (1 + v["PCFX1"] * dfz + v["PCFX2"] * dfz ** 2) \
            * (1 + v["PCFX3"] * dp)
    truth = {"LONGITUDINAL_STIFFNESS": 2e5, "PCFX1": 0.2, "PCFX2": 0.0, "PCFX3": 0.25}
    meas = model(truth) * (1 + 0.005 * rng.standard_normal(fz.size))
    P = lmfit.Parameters()
    P.add("LONGITUDINAL_STIFFNESS", value=1.8e5, min=0, max=1e7)
    P.add("PCFX1", value=0.0, min=-1, max=1)
    P.add("PCFX2", value=0.0, vary=False)
    P.add("PCFX3", value=0.0, vary=False)
    problem = FitProblem("CFx", "linear_load", P, model, meas, pb, extra={"name": "CFx",
                                                                          "Fz_N": fz})
    d = discover([problem], library, Settings())
    assert [a.name for a in d.accepted] == ["PCFX3"]
    assert d.accepted[0].coefficients["PCFX3"] == pytest.approx(0.25, abs=0.02)
    s = d.problems[0]
    # no sweeps, no replicates: the floor comes from the richest candidate model (PCFX2 freed
    # as well), never from the base residuals, and never above the best model's error
    assert s.floor_source.startswith("richest candidate model")
    assert s.noise_floor_pct <= s.final_error_pct


def test_cluster_robust_statistics_for_non_ar1_noise(library):
    """Oscillating AR(2) noise is not AR(1): cluster-robust per-sweep statistics are used."""
    import dataclasses

    rng = np.random.default_rng(8)
    problem, truth = make_problem("CFy", rng, "PCFY2", -0.3, noise=0.0, matrix=SMALL)
    clean = problem.model({k: truth["params"].get(k, p.value)
                           for k, p in problem.parameters.items()})
    noise = np.zeros_like(clean)
    for s in np.unique(problem.sweeps):
        idx = np.flatnonzero(problem.sweeps == s)
        z = rng.standard_normal(idx.size + 50)
        x = np.zeros_like(z)
        for t in range(2, z.size):
            x[t] = 1.2 * x[t - 1] - 0.6 * x[t - 2] + z[t]
        noise[idx] = x[50:] / x[50:].std() * 0.01 * np.sqrt(np.mean(clean[idx] ** 2))
    noisy = dataclasses.replace(problem, measured=clean + noise)
    d = discover([noisy], library, Settings())
    assert d.problems[0].base_noise.kind == "cluster"
    assert d.named == "PCFY2"
    assert d.steps[0].tried[0].test == "cluster-robust Wald"
