"""Relation fits: global optimum on the thesis data, recovery, constraints, .tir round trip."""
from __future__ import annotations

import copy
import dataclasses

import numpy as np
import pandas as pd
import pytest
from scipy.optimize import differential_evolution

from identify.fit.optimize import fit
from identify.fit.relations import problems as R
from identify.io.tir import read_tir
from identify.model import relations as rel
from identify.model.parameters import defaults
from tests.reference_data import THESIS_CSV

P0_BAR, FZ0 = 2.5, 5000.0
PRESSURES = np.array([1.9, 2.2, 2.5, 2.7, 3.0])
LOADS = np.array([3000.0, 5000.0, 7000.0])
TIR = {k: float(v) for k, v in defaults().items() if isinstance(v, (int, float))}
TIR.update(FNOMIN=FZ0, NOMPRES=2.5e5, INFLPRES=2.5e5, UNLOADED_RADIUS=0.3205)
CTX = R.Context(FZ0, P0_BAR, TIR)


def _grid(quantity, values_fn, loads=LOADS, **extra):
    pi, fz = np.meshgrid(PRESSURES, loads, indexing="ij")
    pi, fz = pi.ravel(), fz.ravel()
    frame = pd.DataFrame({"quantity": quantity, "pi_bar": pi, "p_Pa": pi * 1e5, "Fz_N": fz,
                          "value": values_fn(fz, rel.dpi(pi, P0_BAR)), "unit": "-"})
    for k, v in extra.items():
        frame[k] = v
    return frame


def _perturbed(problem, truth, sign):
    """The same problem started from truth * (1 +/- 20 %) (free parameters only)."""
    params = copy.deepcopy(problem.parameters)
    for name in problem.free:
        p = params[name]
        value = truth[name] * (1 + 0.2 * sign) if truth[name] != 0 else 0.05 * sign
        p.set(value=float(np.clip(value, p.min, p.max)))
    return dataclasses.replace(problem, parameters=params)


# --- acceptance 1: the global optimum of the thesis metric ------------------------------------

@pytest.mark.parametrize("relation,form", [("CFz", "mf"), ("CFz", "qfz"),
                                           ("CFx", "linear_load"), ("CFx", "quadratic_load"),
                                           ("CFy", "linear_load"), ("CFy", "quadratic_load")])
def test_thesis_characteristics_reach_the_global_optimum(relation, form):
    chars = pd.read_csv(THESIS_CSV)
    chars["p_Pa"] = chars["pi_bar"] * 1e5
    builder = {"CFz": R.cfz, "CFx": R.cfx, "CFy": R.cfy}[relation]
    problem = builder(chars, CTX, form=form)
    ours = fit(problem, seed=0)
    lo, hi = problem.bounds()
    box = list(zip(lo, hi))
    de_best = min(differential_evolution(problem.objective_value, box, seed=s, tol=1e-10,
                                         maxiter=2000, polish=True).fun for s in range(5))
    table = "\n".join(f"    {p:.1f} bar: {e:.3f} %" for p, e in ours.error_by_pressure_pct.items())
    print(f"\n{relation} [{form}] total {ours.error_total_pct:.4f} % (DE best of 5 seeds "
          f"{de_best:.4f} %)\n{table}")
    # the acceptance: within 0.5 % (relative) of the best independent DE value
    assert ours.error_total_pct <= de_best * 1.005
    assert ours.converged and ours.starts_at_best >= 1


# --- acceptance 2: recovery at zero noise from +/-20 % starts --------------------------------

def _cases():
    q = (217608.0, 827108.0, 0.7875)
    mf = rel.mf_from_qfz(*q, r0=0.3205, fz0=FZ0)
    yield ("CFz", "qfz", _grid("CFz", lambda f, d: rel.cfz_qfz_at_load(f, d, *q)),
           {"QFZ1": q[0], "QFZ2": q[1], "QFZ3": q[2]}, R.cfz)
    yield ("CFz", "mf", _grid("CFz", lambda f, d: rel.cfz_qfz_at_load(f, d, *q)), mf, R.cfz)
    for name, keys, builder in (("CFx", ("LONGITUDINAL_STIFFNESS", "PCFX1", "PCFX2", "PCFX3"),
                                 R.cfx),
                                ("CFy", ("LATERAL_STIFFNESS", "PCFY1", "PCFY2", "PCFY3"), R.cfy)):
        for form, c2 in (("linear_load", 0.0), ("quadratic_load", -0.25)):
            truth = dict(zip(keys, (2.2e5, 0.23, c2, 0.21)))
            data = _grid(name, lambda f, d, c2=c2: rel.load_pressure_stiffness(
                f, d, 2.2e5, 0.23, c2, 0.21, FZ0))
            yield name, form, data, truth, builder
    yield ("CMz", "T1", _grid("CMz", lambda f, d: rel.cmz_t1(f, d, 5200.0, -0.55, FZ0)),
           {"YAW_STIFFNESS": 5200.0, "PCMZ1": -0.55}, R.cmz)
    yield ("CMz", "T2", _grid("CMz", lambda f, d: rel.cmz_t2(f, d, 5000.0, 0.9, 0.12, -0.4,
                                                              FZ0)),
           {"PCMZ1": 0.9, "PCMZ2": 0.12, "PCMZ3": -0.4}, R.cmz)


@pytest.mark.parametrize("case", list(_cases()), ids=lambda c: f"{c[0]}-{c[1]}")
@pytest.mark.parametrize("sign", [-1, 1])
def test_relation_recovery_without_noise(case, sign):
    relation, form, data, truth, builder = case
    problem = builder(data, CTX, form=form)
    if relation == "CMz" and form == "T2":
        problem.parameters["YAW_STIFFNESS"].set(value=5000.0)
    result = fit(_perturbed(problem, {**truth, **{k: problem.parameters[k].value
                                                  for k in problem.free if k not in truth}},
                            sign), seed=3)
    for name, value in truth.items():
        # 1e-6 relative: the recovery level for relations (exact data, tight solvers)
        assert result.parameters[name] == pytest.approx(value, rel=1e-6, abs=1e-9), name


def test_rolling_resistance_and_camber_recovery_through_the_mf():
    tir = read_tir("identify/simulate/data/tyre_225_50R17.tir").params()
    ctx = R.Context(tir["FNOMIN"], tir["NOMPRES"] / 1e5, tir)
    truth = dict(QSY1=0.0085, QSY3=0.0006, QSY4=3e-5, QSY7=0.87, QSY8=-0.4)
    speeds = np.array([5.0, 15.0, 25.0])
    pi, fz, vx = (a.ravel() for a in np.meshgrid(PRESSURES, LOADS, speeds, indexing="ij"))
    base = R.Context(tir["FNOMIN"], tir["NOMPRES"] / 1e5, {**tir, **truth})
    frame = pd.DataFrame({"quantity": "FxRR", "pi_bar": pi, "p_Pa": pi * 1e5, "Fz_N": fz,
                          "Vx_mps": vx, "value": 0.0, "unit": "N"})
    frame["value"] = R.rolling_resistance(frame, base, form="new").predict()
    result = fit(_perturbed(R.rolling_resistance(frame, ctx, form="new"), truth, 1), seed=1)
    for k, v in truth.items():
        assert result.parameters[k] == pytest.approx(v, rel=1e-6), k
    # camber thrust: PPY5 through the MF equations
    g = np.deg2rad([-10.0, -5.0, 5.0, 10.0])
    pi, fz, gd = (a.ravel() for a in np.meshgrid(PRESSURES, LOADS, np.rad2deg(g), indexing="ij"))
    frame = pd.DataFrame({"quantity": "Fy_gamma", "pi_bar": pi, "p_Pa": pi * 1e5, "Fz_N": fz,
                          "gamma_deg": gd, "value": 0.0, "unit": "N"})
    hidden = R.Context(ctx.fz0, ctx.p0_bar, {**tir, "PPY5": -0.3})
    frame["value"] = R.camber(frame, hidden, "Fy_gamma").predict()
    result = fit(R.camber(frame, ctx, "Fy_gamma"), seed=1)
    assert result.parameters["PPY5"] == pytest.approx(-0.3, rel=1e-6)


# --- acceptance 4: constraints ----------------------------------------------------------------

def test_relaxation_strategy_keeps_pcfy2_nonpositive():
    """sigma_y data made with a CFy that has pCFy2 = +0.3: unconstrained the fit finds it,
    constrained it stops at PCFY2 = 0 and says the constraint is active."""
    tir = dict(TIR, PKY1=-29.9, PKY2=3.0, PPY1=0.45, PPY2=0.78)
    ctx = R.Context(FZ0, P0_BAR, tir, kya_from_tir=True)

    def sigma(fz, dp):
        k = rel.kya(fz, dp, -29.9, 3.0, 0.45, 0.78, FZ0)
        return np.abs(k) / rel.load_pressure_stiffness(fz, dp, 1.4e5, 0.1, 0.3, 0.46, FZ0)
    data = _grid("sigma_y", sigma)
    data = pd.concat([data, _grid("CFy", lambda f, d: rel.load_pressure_stiffness(
        f, d, 1.4e5, 0.1, 0.3, 0.46, FZ0))])
    free = fit(R.cfy(data, ctx, "relaxation", pcfy2_nonpositive=False))
    assert free.parameters["PCFY2"] == pytest.approx(0.3, rel=1e-4)
    constrained = fit(R.cfy(data, ctx, "relaxation"))
    assert constrained.parameters["PCFY2"] <= 1e-9
    assert "PCFY2 <= 0" in constrained.active_constraints
    assert constrained.converged


def test_cmz_t2_stays_nonnegative_at_500_n():
    """CMz data whose unconstrained T2 fit is negative at 500 N."""
    loads = np.array([1000.0, 2000.0, 3000.0, 4000.0, 5000.0, 6000.0])
    data = _grid("CMz", lambda f, d: rel.cmz_t2(f, d, 5000.0, -0.2, 1.2, -0.4, FZ0), loads=loads)
    free = fit(R.cmz(data, CTX, "T2", nonnegative=False))
    v = free.parameters
    assert rel.cmz_t2(500.0, 0.0, v["YAW_STIFFNESS"], v["PCMZ1"], v["PCMZ2"], v["PCMZ3"],
                      FZ0) < 0
    constrained = fit(R.cmz(data, CTX, "T2"))
    v = constrained.parameters
    grid = np.linspace(500.0, 12000.0, 200)
    for dp in rel.dpi(PRESSURES, P0_BAR):
        assert np.all(rel.cmz_t2(grid, dp, v["YAW_STIFFNESS"], v["PCMZ1"], v["PCMZ2"],
                                 v["PCMZ3"], FZ0) >= -1e-6)
    assert constrained.active_constraints and constrained.active_constraints[0].startswith(
        "CMz >= 0")
    assert constrained.error_total_pct > free.error_total_pct
