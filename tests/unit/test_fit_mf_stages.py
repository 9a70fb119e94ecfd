"""The Magic Formula slip coefficients fitted in stages from trailer data (identify.fit.mf.stages).

Recovery: noise-free data simulated with the forward model (useMode 211) from the bundled
225/50 R17 tyre (with some of its zero coefficients made non-zero, so that they are recovered
rather than sitting at 0) on sweeps at 3 pressures x 3 loads x several cambers; every stage's
free coefficients come back within 1e-4 relative from a start perturbed by +/-20 %.
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from identify.fit.limits import table_limits
from identify.fit.mf.constraints import validity_grid
from identify.fit.mf.stage_data import both_signs
from identify.fit.mf.stage_specs import STAGES
from identify.fit.mf.stages import DEFAULT_STAGES, fit_mf, stage_problem
from identify.fit.optimize import fit
from identify.fit.run import FitSettings
from identify.io.tir import read_tir, write_tir
from identify.io.trailer.files import read_trailer
from identify.model.evaluate import evaluate

ROOT = Path(__file__).resolve().parents[2]
TIR = ROOT / "identify" / "simulate" / "data" / "tyre_225_50R17.tir"
SAMPLE = ROOT / "measurements" / "sample-225-50R17" / "trailer"
RECOVERY_RTOL = 1e-4

# zero in the bundled file -> non-zero here (RCY1 = 1 keeps Gyk > 0 on the whole check grid)
OVERRIDES = {
    "RCY1": 1.0, "PVX1": 0.01, "PVX2": 0.005, "PEY4": 0.3, "PEY5": 1.5, "PKY5": 0.8,
    "PVY4": 0.1, "QBZ3": 0.3, "QBZ9": 2.0, "QDZ4": 0.5, "QDZ10": 0.02, "QDZ11": 0.01,
    "QEZ3": 0.1, "QEZ5": 0.3, "QHZ4": 0.01, "RBX3": 5.0, "REX2": -0.1, "RHX1": 0.002,
    "RBY3": 0.01, "RBY4": 5.0, "REY2": 0.1, "RHY1": 0.002, "RHY2": 0.001, "RVY1": 0.02,
    "RVY2": 0.01, "RVY3": 0.1, "SSZ4": 0.01, "QSX12": 0.05, "QSX13": 0.01, "QSX14": 0.01,
    "QSY2": 0.002, "QSY5": 0.001, "QSY6": 0.0005}


def _truth() -> dict[str, float]:
    P = read_tir(TIR).params()
    P.update(OVERRIDES)
    return P


def _sweeps(pressures=(1.9, 2.5, 3.0), loads=(3000.0, 5000.0, 7000.0),
            combined_alpha_deg=(-3.0, 2.0, 5.0, 9.0)) -> pd.DataFrame:
    """Trailer-like sweeps: longitudinal (kappa, 2 cambers), lateral (alpha, 5 cambers),
    combined (kappa at 4 slip angles, 2 cambers) and free rolling at 5 speeds."""
    d = np.deg2rad
    kappa, alpha = np.linspace(-0.3, 0.3, 31), d(np.linspace(-12, 12, 31))
    frames = []

    def add(run, pb, fz, **cols):
        frames.append(pd.DataFrame({"run": f"{run}_p{pb:g}", "Fz": fz, "p": pb * 1e5,
                                    "Vx": 16.7, "kappa": 0.0, "alpha": 0.0, "gamma": 0.0,
                                    **cols}))

    for pb in pressures:
        for fz in loads:
            for g in (0.0, 4.0):
                add("long", pb, fz, kappa=kappa, gamma=d(g))
            for g in (-6.0, -3.0, 0.0, 3.0, 6.0):
                add("lat", pb, fz, alpha=alpha, gamma=d(g))
            for g in (0.0, 4.0):
                for a in combined_alpha_deg:
                    add("comb", pb, fz, kappa=np.linspace(-0.25, 0.25, 21), alpha=d(a),
                        gamma=d(g))
            add("rr", pb, fz, Vx=np.array([5.0, 10.0, 20.0, 30.0, 25.0]),
                gamma=d(np.array([0.0, 4.0, 0.0, 0.0, -4.0])))
    return pd.concat(frames, ignore_index=True)


def _simulate(P, points: pd.DataFrame) -> pd.DataFrame:
    """The model's forces and moments, the wheel speed omega of the fixed point
    omega = (1 + kappa) Vx / Re(omega) solved to round-off (evaluate's stops at 1e-9 m), so
    that Vx/omega at kappa = 0 is Re(omega) to ~1e-16 relative, and the loaded radius rl at
    that omega."""
    cols = [points[c].to_numpy() for c in ("Fz", "kappa", "alpha", "gamma", "Vx")]
    out = evaluate(P, *cols, p=points["p"].to_numpy(), mode=211)
    omega = out["omega"]
    for _ in range(4):
        re = evaluate(P, *cols, p=points["p"].to_numpy(), omega=omega, mode=211)["Re"]
        omega = (1 + cols[1]) * cols[4] / re
    rl = evaluate(P, *cols, p=points["p"].to_numpy(), omega=omega, mode=211)["Rl"]
    return points.assign(omega=omega, rl=rl,
                         **{q: out[q] for q in ("Fx", "Fy", "Mz", "Mx", "My")})


@pytest.fixture(scope="module")
def truth():
    return _truth()


@pytest.fixture(scope="module")
def data(truth):
    return _simulate(truth, _sweeps())


@pytest.fixture(scope="module")
def free_sets(truth, data):
    return {st: stage_problem(st, data, truth).problem.free for st in DEFAULT_STAGES}


def _perturb(truth, names, seed):
    rng = np.random.default_rng(seed)
    start = dict(truth)
    for n in names:
        start[n] = truth[n] * (1 + 0.2 * rng.choice([-1.0, 1.0]))
    return start


def _rel_errors(result, truth):
    return {n: abs(result.parameters[n] - truth[n]) / (abs(truth[n]) or 1.0)
            for n in result.free}


@pytest.mark.parametrize("stage", DEFAULT_STAGES)
def test_each_stage_recovers_its_coefficients(stage, truth, data, free_sets):
    start = _perturb(truth, free_sets[stage], seed=1)
    mf = fit_mf(data, start, stages=(stage,))
    result = mf.result(stage)
    assert result.relation == "MF" and result.form == stage
    assert set(result.free) == set(free_sets[stage])  # the same definition at the start
    errors = _rel_errors(result, truth)
    worst = max(errors, key=errors.get)
    print(f"{stage}: {len(errors)} coefficients, worst {worst} {errors[worst]:.1e}, "
          f"{result.starts_at_best}/{result.n_starts} starts at best, {result.seconds:.1f} s")
    assert errors[worst] <= RECOVERY_RTOL, (worst, errors[worst])
    assert result.converged and result.error_total_pct < 1e-8
    assert result.starts_at_best >= 1


def test_stage_definitions_on_the_recovery_design(free_sets):
    f = free_sets
    # pure slip: the pressure coefficients are in their stages
    assert {"PPX1", "PPX2", "PPX3", "PPX4"} <= set(f["Fx0"])
    assert {"PPY1", "PPY2", "PPY3", "PPY4", "PPY5"} <= set(f["Fy0"])
    assert {"PPZ1", "PPZ2"} <= set(f["Mz0"])
    assert "PPMX1" in f["Mx"] and {"QSY7", "QSY8"} <= set(f["My"])
    assert {"PKX1", "PKX2"} <= set(f["Fx0"]) and "PKX3" not in f["Fx0"]  # three loads
    # QSX4 = QSX7 = QSX8 = QSX10 = 0: the sine and atan terms of Mx vanish, their
    # coefficients have no effect and are held
    assert not {"QSX4", "QSX5", "QSX6", "QSX7", "QSX8", "QSX9", "QSX10", "QSX11"} & set(f["Mx"])
    # no stage frees another stage's coefficients, except the free radius and its speed
    # term, which the vertical and the geometry stage both read: the stages in sequence fit
    # them once, in the vertical stage (fit_mf, test_geometry_holds_what_the_vertical_fitted)
    all_free = [n for st in DEFAULT_STAGES for n in f[st]]
    assert {n for n in all_free if all_free.count(n) > 1} == {"Q_RE0", "Q_V1"}
    assert {"Q_RE0", "Q_V1", "Q_V2"} <= set(f["vertical"])  # this design has three speeds


def test_coefficients_the_data_cannot_identify_are_held(truth):
    # no camber anywhere, combined slip at two slip angles only (like the bundled sample)
    points = _sweeps(combined_alpha_deg=(3.0, 6.0))
    points = points[points["gamma"] == 0.0].reset_index(drop=True)
    data = _simulate(truth, points)
    fx0 = stage_problem("Fx0", data, truth)
    assert fx0.held["PDX3"] == "data: no camber variation"
    # Byk depends on alpha through cos(atan(RBY2 (alpha - RBY3))): two slip angles give two
    # values for three coefficients (without the slip-ratio sweep at zero slip angle, which
    # the Fy stage fits too)
    fy = stage_problem("Fy", data[np.abs(data["alpha"]) > np.deg2rad(1.0)], truth)
    for n in ("RBY4", "RVY3"):
        assert fy.held[n] == "data: no camber variation"
    # a shift of the slip angle, and the slip angles all of one sign
    assert fy.held["RBY3"] == "data: slip angles of one sign only"
    assert "RBY3" not in fy.problem.free
    # of both signs, -3 and 3 deg: still two values of |alpha|, found by the sensitivity screen
    both = _simulate(truth, _sweeps(combined_alpha_deg=(-3.0, 3.0)))
    both = both[both["gamma"] == 0.0].reset_index(drop=True)
    fy = stage_problem("Fy", both[np.abs(both["alpha"]) > np.deg2rad(1.0)], truth)
    assert fy.held["RBY3"].startswith("sensitivity: not separable from")
    assert "RBY3" not in fy.problem.free
    # RVY1 = RVY2 = RVY3 = 0: the shape coefficients of SVyk have no effect
    start = dict(truth, RVY1=0.0, RVY2=0.0, RVY3=0.0)
    fy0 = stage_problem("Fy", data, start)
    for n in ("RVY4", "RVY5", "RVY6"):
        assert fy0.held[n] == "sensitivity: no effect on the data at the start values"
    one_pressure = data[data["p"] == 2.5e5]
    assert stage_problem("Fx0", one_pressure, truth).held["PPX1"] == "data: one pressure"


def test_three_loads_cannot_choose_the_slip_stiffness_branch(truth, data):
    """With three loads (dfz = -0.4, 0, 0.4) Kx/Fz = (PKX1 + PKX2 dfz) exp(PKX3 dfz) takes the
    same three values on a second branch, PKX2' = -PKX2, PKX3' = PKX3 + 2.5 ln((PKX1 +
    0.4 PKX2)/(PKX1 - 0.4 PKX2)): PKX3 is held unless the data have four load levels."""
    a, b, k1 = truth["PKX2"], truth["PKX3"], truth["PKX1"]
    mirror = dict(truth, PKX2=-a, PKX3=b + 2.5 * np.log((k1 + 0.4 * a) / (k1 - 0.4 * a)))
    np.testing.assert_allclose(_simulate(mirror, data)["Fx"], data["Fx"], rtol=1e-12,
                               atol=1e-9)
    held = stage_problem("Fx0", data, truth).held
    assert held["PKX3"] == "data: 3 load level(s), 4 needed"
    four = _simulate(truth, _sweeps(loads=(3000.0, 4500.0, 6000.0, 7500.0)))
    assert "PKX3" in stage_problem("Fx0", four, truth).problem.free


@pytest.mark.parametrize("stage", ["Fx0", "Fy", "geometry"])
def test_a_stage_problem_built_like_an_earlier_one_is_the_same_problem(stage, truth, data):
    """stage_problem(like=): the earlier problem's points reused, at other parameter values
    and with holds, give the problem built from the table afresh; a different nominal load
    numbers the sweeps again."""
    first = stage_problem(stage, data, truth)
    moved = {**truth, **{n: truth[n] * 1.1 for n in first.problem.free}}
    for kwargs in ({}, {"hold": {n: "held" for n in first.problem.free[:1]}}):
        fresh = stage_problem(stage, data, moved, **kwargs)
        again = stage_problem(stage, data, moved, like=first, **kwargs)
        assert again.points is first.points
        np.testing.assert_array_equal(again.rows, fresh.rows)
        assert again.held == fresh.held and again.problem.free == fresh.problem.free
        for name in ("measured", "pressure_bar", "sweeps"):
            np.testing.assert_array_equal(getattr(again.problem, name),
                                          getattr(fresh.problem, name))
        x = fresh.problem.x0()
        np.testing.assert_array_equal(again.problem.residuals(x), fresh.problem.residuals(x))
        np.testing.assert_array_equal(again.problem.constraint_values(x),
                                      fresh.problem.constraint_values(x))
    other = stage_problem(stage, data, {**moved, "FNOMIN": 2 * truth["FNOMIN"]}, like=first)
    assert other.points is not first.points and other.points.fnomin == 2 * truth["FNOMIN"]


@pytest.mark.parametrize("stage", ["Fx0", "Fy0"])
def test_a_screened_stage_problem_is_the_one_built_with_its_holds(stage, truth, data):
    """The screened problem (its screen's problem reused when the screen held nothing more)
    has the parameters, bounds, constraints and residuals of the problem built with the
    screen's holds."""
    start = _perturb(truth, STAGES[stage].coefficients, seed=3)
    sp = stage_problem(stage, data, start)
    held = stage_problem(stage, data, start, hold=sp.held)
    a, b = sp.problem, held.problem
    assert a.free == b.free and a.parameters.valuesdict() == b.parameters.valuesdict()
    for x, y in zip(a.bounds(), b.bounds()):
        np.testing.assert_array_equal(x, y)
    assert len(a.constraints) == len(b.constraints) > 0
    x = a.x0()
    np.testing.assert_array_equal(a.constraint_values(x), b.constraint_values(x))
    np.testing.assert_array_equal(a.residuals(x), b.residuals(x))


def test_geometry_stage_model_is_evaluates_re(truth, data):
    """The geometry stage's model at any coefficients is bit-identical to evaluate()'s Re with
    the measured omega; the measured Re is Vx/omega on the free-rolling points only."""
    sp = stage_problem("geometry", data, truth)
    pts = data.iloc[sp.rows]
    assert set(pts["run"].str.split("_").str[0]) == {"lat", "rr"}  # no kappa sweeps
    values = {"Q_RE0": 1.01, "Q_V1": 0.002, "DREFF": 0.2, "FREFF": 0.03, "BREFF": 6.0}
    P = dict(truth, **values)
    out = evaluate(P, pts["Fz"].to_numpy(), pts["kappa"].to_numpy(), pts["alpha"].to_numpy(),
                   pts["gamma"].to_numpy(), pts["Vx"].to_numpy(), p=pts["p"].to_numpy(),
                   omega=pts["omega"].to_numpy(), mode=211)
    model = sp.problem.model
    np.testing.assert_array_equal(model(values), out["Re"])
    np.testing.assert_array_equal(sp.problem.measured,
                                  pts["Vx"].to_numpy() / pts["omega"].to_numpy())


def test_geometry_stage_recovers_breff_with_four_loads_at_one_pressure(truth):
    """Four load levels identify BREFF at one pressure too (three need the pressure scaling of
    Cz', see NEEDS); the vertical stiffness VERTICAL_STIFFNESS, PFZ1 is held at the start."""
    points = _sweeps(pressures=(2.5,), loads=(2500.0, 4000.0, 5500.0, 7000.0))
    data = _simulate(truth, points[points["run"].str.startswith(("lat", "rr"))])
    free = stage_problem("geometry", data, truth).problem.free
    assert set(free) == {"Q_RE0", "Q_V1", "DREFF", "FREFF", "BREFF"}
    for seed in (1, 2):
        start = _perturb(truth, free, seed=seed)
        result = fit_mf(data, start, stages=("geometry",)).result("geometry")
        errors = _rel_errors(result, truth)
        worst = max(errors, key=errors.get)
        print(f"geometry, 4 loads, seed {seed}: worst {worst} {errors[worst]:.1e}")
        assert errors[worst] <= RECOVERY_RTOL, (worst, errors[worst])
        assert result.converged and result.error_total_pct < 1e-8
        assert set(result.parameters) >= {"Q_RE0", "BREFF"}
        assert "VERTICAL_STIFFNESS" not in result.parameters


def test_geometry_stage_holds_and_skips(truth, data):
    # three loads at three pressures: all five free (BREFF through the pressure scaling of Cz')
    assert stage_problem("geometry", data, truth).held == {}
    one_pressure = data[data["p"] == 2.5e5]
    for P in (truth, dict(truth, PFZ1=0.0)):  # no pressure scaling: BREFF is not separable
        for d in (one_pressure, data):
            why = stage_problem("geometry", d, P).held.get("BREFF", "")
            assert why.startswith("sensitivity: not separable") == (P is not truth or
                                                                     d is one_pressure)
    two_loads = data[data["Fz"] < 6000.0]
    assert stage_problem("geometry", two_loads, truth).held["FREFF"] == \
        "data: 2 load level(s), 3 needed"
    one_speed = data[data["Vx"] == 16.7]
    assert stage_problem("geometry", one_speed, truth).held["Q_V1"] == "data: one speed"
    # no wheel-speed channel: the stage is skipped with the reason, the others still fit
    mf = fit_mf(data.drop(columns="omega"), truth, stages=("geometry", "My"))
    assert [r.form for r in mf.results] == ["My"]
    assert mf.skipped["geometry"].startswith("no wheel-speed (omega) channel")
    assert "MF [geometry] skipped: no wheel-speed" in mf.report()
    # a wheel speed but no free rolling (only slip sweeps)
    slip_only = data[data["run"].str.startswith(("long", "comb"))]
    mf = fit_mf(slip_only, truth, stages=("geometry",))
    assert mf.results == () and mf.skipped["geometry"].startswith("no free-rolling points")


@pytest.fixture(scope="module")
def chained(truth, data, free_sets):
    """All stages perturbed at once and fitted in sequence (three passes: SSZ1..4 act on the
    Mz0 points through s*Fx)."""
    start = _perturb(truth, [n for st in DEFAULT_STAGES for n in free_sets[st]], seed=2)
    return fit_mf(data, start, passes=3, seed=3)


def test_geometry_holds_what_the_vertical_fitted(chained):
    """In sequence the free radius and its speed term are fitted once, from the loaded
    radius; the geometry stage holds them at those values and says why."""
    vertical, geometry = chained.result("vertical"), chained.result("geometry")
    assert {"Q_RE0", "Q_V1"} <= set(vertical.free) and not {"Q_RE0", "Q_V1"} & set(geometry.free)
    assert chained.held["geometry"]["Q_V1"] == "fitted in the vertical stage"
    assert "Q_RE0" not in geometry.parameters  # not a parameter of its problem at all
    assert chained.params["Q_RE0"] == vertical.parameters["Q_RE0"]


def test_all_stages_in_sequence_recover_every_coefficient(chained, truth):
    assert [r.form for r in chained.results] == list(DEFAULT_STAGES)
    for r in chained.results:
        errors = _rel_errors(r, truth)
        worst = max(errors, key=errors.get)
        print(f"{r.form}: worst {worst} {errors[worst]:.1e}")
        assert errors[worst] <= RECOVERY_RTOL, (r.form, worst, errors[worst])
    assert set(chained.keys_fitted) <= set(chained.params)


def test_written_tir_reproduces_the_fitted_predictions_exactly(chained, tmp_path):
    path = write_tir(tmp_path / "fit.tir", {k: v for k, v in chained.params.items()},
                     fittyp=61)
    back = read_tir(path).params()
    for r in chained.results:
        pts = chained.points[r.form]
        out = evaluate(back, pts["Fz"].to_numpy(), pts["kappa"].to_numpy(),
                       pts["alpha"].to_numpy(), pts["gamma"].to_numpy(), pts["Vx"].to_numpy(),
                       p=pts["p"].to_numpy(), mode=211)
        quantity = {"Fx0": "Fx", "Fy0": "Fy", "Mz0": "Mz", "geometry": "Re",
                    "vertical": "Rl"}.get(r.form, r.form)
        if r.form in ("geometry", "vertical"):  # Re and Rl at the measured wheel speed
            out = evaluate(back, pts["Fz"].to_numpy(), pts["kappa"].to_numpy(),
                           pts["alpha"].to_numpy(), pts["gamma"].to_numpy(),
                           pts["Vx"].to_numpy(), p=pts["p"].to_numpy(),
                           omega=pts["omega"].to_numpy(), mode=211)
        np.testing.assert_array_equal(out[quantity], r.predicted, err_msg=r.form)
        assert all(back[n] == r.parameters[n] for n in r.free)


def test_validity_constraint_active(truth):
    """Ex = (PEX1 + PEX2 dfz)(1 - PEX4 sgn(kappa)) reaches 1.15 at the highest measured load
    (7 kN, kappa < 0): the unconstrained optimum (the truth) violates Ex <= 1 on the check grid
    over the data's ranges (the limits the written .tir states), the constrained fit respects
    it and says so. (With PEX1 = 0.5, Ex <= 1 holds over the measured loads and breaks only
    beyond them, at FZMAX = 10 kN: no constraint is active then.)"""
    P = dict(truth, PEX1=0.6, PEX2=0.3, PEX3=0.0, PEX4=0.6)
    data = _simulate(P, _sweeps())
    assert np.min(stage_problem("Fx0", data, {**P, **table_limits(data)}
                                ).problem.constraint_values(None)) < -0.15
    mf = fit_mf(data, P, stages=("Fx0",))
    r = mf.result("Fx0")
    assert r.active_constraints == ("Ex <= 1",)
    refit = stage_problem("Fx0", data, mf.params).problem
    margins = {c.name: np.min(c.fun(refit.values())) for c in refit.constraints}
    assert min(margins.values()) >= -1e-8
    assert margins["Ex <= 1"] < 1e-6
    assert r.converged and r.error_total_pct > 1e-3  # the data cannot be met exactly


def test_validity_beyond_the_data_does_not_bind(truth):
    """Ex <= 1 broken only beyond the measured loads (PEX1 = 0.5: Ex 1.28 at FZMAX = 10 kN,
    at most 0.99 up to 7 kN): the fit holds the conditions where the written .tir claims
    validity, so it returns the truth, which it could not while the grid reached FZMAX."""
    P = dict(truth, PEX1=0.5, PEX2=0.3, PEX3=0.0, PEX4=0.6)
    data = _simulate(P, _sweeps())
    assert np.min(stage_problem("Fx0", data, P).problem.constraint_values(None)) < -0.2
    r = fit_mf(data, P, stages=("Fx0",)).result("Fx0")
    assert r.active_constraints == () and r.converged
    assert r.error_total_pct < 1e-6


def test_validity_grid_follows_the_tir_limits(truth):
    grid = validity_grid(dict(truth, FZMIN=0.0), [2.5e5, 1.9e5, 2.5e5])
    assert grid.fz[0] == 1.0 and grid.fz[-1] == truth["FZMAX"] and grid.fz.size == 11
    assert grid.kappa[0] == truth["KPUMIN"] and grid.alpha[-1] == truth["ALPMAX"]
    assert grid.gamma[0] == truth["CAMMIN"] and list(grid.p) == [1.9e5, 2.5e5]


def test_bundled_sample_longitudinal_stages():
    """The bundled folder's braking/driving and combined runs (1 % noise): Fx0 and Fx fit to
    the noise level; the outputs follow docs/fit-directory.md."""
    runs = [f"{kind}_p{p}" for kind in ("braking_driving", "combined") for p in (190, 250, 300)]
    trailer = pd.concat([read_trailer(SAMPLE / f"{r}.csv.gz", run=r) for r in runs],
                        ignore_index=True)
    base = read_tir(TIR).params()
    mf = fit_mf(trailer, base, stages=("Fx0", "Fx"))
    for r in mf.results:
        assert r.converged
        assert 0.5 < r.error_total_pct < 2.0  # 1 % noise
        assert set(r.error_by_pressure_pct) == {1.9, 2.5, 3.0}
    table = mf.measured_vs_model()
    assert list(table.columns) == ["relation", "form", "quantity", "unit", "pi_bar", "Fz_N",
                                   "gamma_deg", "alpha_rad", "kappa", "Vx_mps", "measured",
                                   "model"]
    assert len(table) == sum(r.n_points for r in mf.results)
    assert set(table["quantity"]) == {"Fx"} and set(table["relation"]) == {"MF"}
    d = json.loads(json.dumps(mf.to_dict()))
    assert [f["form"] for f in d["fits"]] == ["Fx0", "Fx"]
    assert d["held"]["Fx0"]["PDX3"] == "data: no camber variation"


def test_a_second_pass_solves_the_stages_whose_inputs_a_later_stage_moved(truth, data,
                                                                          free_sets):
    """SSZ1..4 (stage Mz) act on the Mz0 points through s Fx: fitted in one pass, Mz0's
    coefficients are the optimum for the SSZ of the start, not the SSZ the .tir carries. The
    second pass (mfid fit's default, FitSettings.mf_passes) solves again exactly the stages
    something they read has moved in (names_read) and leaves the others as they were: after
    it, Mz0 is at its optimum for the final values (a solve from there gains nothing next to
    the one-pass fit's objective), and its objective at the final values is far below the
    one-pass fit's."""
    assert FitSettings().mf_passes == 2
    start = _perturb(truth, [n for st in DEFAULT_STAGES for n in free_sets[st]], seed=2)
    one, two = (fit_mf(data, start, passes=p, seed=3) for p in (1, 2))
    wls = {p: mf.result("Mz0").wls for p, mf in ((1, one), (2, two))}
    assert wls[2] < 0.1 * wls[1], wls
    mz0 = two.result("Mz0")
    again = fit(stage_problem("Mz0", data, two.params, free={"Mz0": list(mz0.free)},
                              hold={}).problem,
                starts=np.array([[two.params[n] for n in mz0.free]]))
    assert mz0.wls - again.wls <= 1e-6 * wls[1]  # noise-free data: both near round-off
    # geometry reads nothing a later stage fits: pass 2 kept it (same evaluations)
    assert two.result("geometry").nfev == one.result("geometry").nfev
    # a stage solved again keeps the holds of pass 1 and their reasons (the .tir says why
    # a coefficient is at its start value); Fx0, solved again, holds PKX3 (three loads)
    assert "PKX3" in one.held["Fx0"]
    for stage, held in one.held.items():
        assert held.items() <= two.held[stage].items(), stage


def test_a_zero_sweep_off_zero_is_no_second_sign(truth):
    """A real drive/brake run's "0 deg" sweep sits a few tenths of a degree off zero (the
    slip-angle channel's offset). Beside sweeps at 3 and 6 deg, one at -0.4 deg is no second
    sign (RBY3 stays held as for slip angles of one sign: counted by any sample beyond 0.25
    deg, it was freed), one at -3 deg is; a single stray sample is none either."""
    for alphas, one_sign in (((-0.4, 3.0, 6.0), True), ((-3.0, 3.0, 6.0), False)):
        data = _simulate(truth, _sweeps(combined_alpha_deg=alphas))
        fy = stage_problem("Fy", data, truth)
        assert (fy.held.get("RBY3") == "data: slip angles of one sign only") is one_sign
    a = np.deg2rad(np.r_[np.full(500, 3.0), np.full(500, 6.0), -5.0])
    assert not both_signs(a, np.deg2rad(0.25))
    assert both_signs(np.r_[a, np.deg2rad(np.full(60, -2.0))], np.deg2rad(0.25))


@pytest.mark.parametrize("stage", ["Mz0", "Mz"])
def test_mz_stage_model_with_the_slip_computed_once_is_the_inline_one(stage, truth, data):
    """The Mz stages' numpy models take the residual moment's slip computed once
    (identify.model.aligning.residual_slip): the same predictions, bit for bit, as computing it
    in every evaluation, at scalar and at batched (walker) values."""
    from identify.fit.mf import stage_specs as specs

    sp = stage_problem(stage, data, truth, screen=False)
    p = sp.problem
    inputs = specs._model_inputs(stage, sp.params, sp.state, sp.omega)
    assert "mz_slip" in inputs
    inline = {k: v for k, v in inputs.items() if k != "mz_slip"}
    rng = np.random.default_rng(0)
    X = p.x0() * (1 + 0.3 * rng.standard_normal((5, p.x0().size)))
    for values in [p.values(x) for x in X] + [p.values_batch(X)]:
        P = {**sp.params, **values}
        np.testing.assert_array_equal(specs.stage_predict(stage, P, sp.state, inputs),
                                      specs.stage_predict(stage, P, sp.state, inline))
