"""Each pressure predicted by the MF stages fitted without it (identify.fit.mf.pressure_holdout):
on sweeps generated from a tyre with pressure terms, a level between two others is predicted
nearly as well as fitted, a level with no second one beside it cannot be, and nothing of the
held-out level survives in the refit."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from identify.fit.mf.pressure_holdout import (
    PressureHoldout,
    heldout_start,
    is_pressure_coefficient,
    pressure_holdout,
    refit_without,
)
from identify.fit.mf.stages import fit_mf
from identify.io.tir import read_tir
from identify.model.evaluate import evaluate
from identify.model.modes import FIT_MODE
from identify.model.parameters import defaults
from identify.simulate import default_tir_path

PRESSURES = (0.8, 1.0, 1.2)
"""Pressures of the generated sweeps, as fractions of the nominal pressure."""


def _fy0_table(truth: dict[str, float], pressures=PRESSURES, seed: int = 0) -> pd.DataFrame:
    """Pure slip-angle sweeps (3 loads, camber 0; a run per pressure: its level is the median
    of a run) with Fy [N] from ``truth`` (useMode 211) and
    0.2 % noise of the largest |Fy|."""
    alpha = np.deg2rad(np.linspace(-12, 12, 25))
    rows = [pd.DataFrame({"run": f"cornering {pf:g}", "Fz": lf * truth["FNOMIN"],
                          "p": pf * truth["NOMPRES"], "Vx": 11.1, "kappa": 0.0,
                          "alpha": alpha, "gamma": 0.0})
            for pf in pressures for lf in (0.6, 1.0, 1.4)]
    t = pd.concat(rows, ignore_index=True)
    fy = np.asarray(evaluate(truth, *(t[c].to_numpy() for c in ("Fz", "kappa", "alpha",
                                                                   "gamma", "Vx")),
                             p=t["p"].to_numpy(), mode=FIT_MODE)["Fy"])
    rng = np.random.default_rng(seed)
    return t.assign(Fy=fy + 0.002 * np.max(np.abs(fy)) * rng.standard_normal(fy.size))


def _start(truth):
    start = {k: float(v) for k, v in defaults().items() if not isinstance(v, str)}
    start.update({k: truth[k] for k in ("FNOMIN", "NOMPRES", "INFLPRES", "UNLOADED_RADIUS",
                                         "LONGVL")})
    return start


@pytest.fixture(scope="module")
def case():
    truth = read_tir(default_tir_path()).params()
    table = _fy0_table(truth)
    mf = fit_mf(table, _start(truth), stages=("Fy0",), seed=0, passes=1)
    return truth, table, mf


def test_pressure_coefficients_are_named_and_restarted_from_their_defaults():
    assert all(is_pressure_coefficient(n) for n in ("PPX1", "PPY5", "PPZ2", "PPMX1", "PFZ1",
                                                    "QSY8"))
    assert not any(is_pressure_coefficient(n) for n in ("PKY1", "PDY1", "QSY1", "NOMPRES",
                                                        "PCFY3"))
    start = heldout_start({"PPY1": 0.7, "PKY1": -20.0, "QSY8": -0.1})
    d = defaults()
    assert start == {"PPY1": float(d["PPY1"]), "PKY1": -20.0, "QSY8": float(d["QSY8"])}


def test_a_middle_pressure_is_predicted_nearly_as_well_as_fitted(case):
    truth, table, mf = case
    ph = pressure_holdout(table, mf)
    assert [lv.pressure_bar for lv in ph.levels] == pytest.approx(
        [round(f * truth["NOMPRES"] / 1e5, 2) for f in PRESSURES])
    mid = ph.levels[1]
    assert mid.points["Fy0"] == 75
    # the fit reaches the noise (0.2 % of the peak); between two fitted pressures the
    # linear and quadratic pressure terms interpolate: within 0.2 percentage points
    assert mid.insample_pct["Fy0"] < 0.5
    assert mid.heldout_pct["Fy0"] < mid.insample_pct["Fy0"] + 0.2
    # the outer levels are extrapolations from two levels (the quadratic terms held): worse
    # than in-sample, and the record says so rather than hiding it
    assert all(lv.heldout_pct["Fy0"] > lv.insample_pct["Fy0"] for lv in ph.levels)
    assert ph.seconds > 0 and all(lv.converged for lv in ph.levels)
    back = PressureHoldout.from_dict(ph.to_dict())
    assert back.to_dict() == ph.to_dict()


def test_with_one_level_left_the_pressure_terms_stay_at_their_defaults(case):
    truth = read_tir(default_tir_path()).params()
    table = _fy0_table(truth, pressures=(0.8, 1.2), seed=1)
    mf = fit_mf(table, _start(truth), stages=("Fy0",), seed=0, passes=1)
    assert any(abs(mf.params[n]) > 0 for n in ("PPY1", "PPY3"))  # the full fit found them
    low = np.isclose(table["p"], 0.8 * truth["NOMPRES"])
    params, converged = refit_without(table, mf, low)
    assert converged
    d = defaults()
    for n in ("PPY1", "PPY2", "PPY3", "PPY4", "PPY5"):
        assert params[n] == float(d[n]), n
    # so the held-out level is predicted as the other pressure's tyre: far off
    ph = pressure_holdout(table, mf)
    assert all(lv.heldout_pct["Fy0"] > 3 * lv.insample_pct["Fy0"] for lv in ph.levels)


def test_one_pressure_level_has_nothing_to_hold_out(case):
    truth = read_tir(default_tir_path()).params()
    table = _fy0_table(truth, pressures=(1.0,))
    mf = fit_mf(table, _start(truth), stages=("Fy0",), seed=0, passes=1)
    ph = pressure_holdout(table, mf)
    assert ph.levels == () and "1 pressure level" in ph.skipped
    assert not math.isnan(ph.seconds)


@pytest.mark.parametrize("fittyp", [61, 62])
def test_the_radii_stages_kept_do_not_enter_the_forces(fittyp):
    """The refit keeps the vertical and geometry stages' values: they do not move Fx, Fy, Mz,
    Mx at a given slip, load and pressure (else the held-out prediction would carry them)."""
    from identify.fit.mf.stage_specs import STAGES

    truth = {**read_tir(default_tir_path()).params(), "FITTYP": float(fittyp)}
    other = dict(truth)
    for stage in ("vertical", "geometry"):
        for n in STAGES[stage].coefficients:
            other[n] = 1.5 * truth[n] + 0.1
    t = _fy0_table(truth).assign(kappa=0.05, gamma=np.deg2rad(3.0))
    cols = [t[c].to_numpy() for c in ("Fz", "kappa", "alpha", "gamma", "Vx")]
    a = evaluate(truth, *cols, p=t["p"].to_numpy(), mode=FIT_MODE)
    b = evaluate(other, *cols, p=t["p"].to_numpy(), mode=FIT_MODE)
    for q in ("Fx", "Fy", "Mz", "Mx"):
        np.testing.assert_array_equal(a[q], b[q])


def test_the_page_table_and_bars():
    from matplotlib.figure import Figure

    from identify.fit.mf.pressure_holdout import LevelHoldout
    from identify.report.pressure_pages import _bars, table_rows

    ph = PressureHoldout((LevelHoldout(0.55, {"Fy0": 10, "Mx": 20}, {"Fy0": 2.0, "Mx": 40.0},
                                       {"Fy0": 5.0, "Mx": 44.0}, 1.0, True),
                          LevelHoldout(0.83, {"Fy0": 12}, {"Fy0": 3.0}, {"Fy0": 9000.0}, 1.0,
                                       False)), method="m", seconds=2.0)
    assert table_rows(ph) == [["0.55", "Fy0", "10", "2.00", "5.00", "2.50"],
                              ["0.55", "Mx", "20", "40.00", "44.00", "1.10"],
                              ["0.83", "Fy0", "12", "3.00", "9000.00", "3000.00"]]
    ax = Figure().add_subplot()
    _bars(ax, ph)
    assert ax.get_yscale() == "log"  # 2 % beside 9000 % stays readable
    assert [t.get_text() for t in ax.get_xticklabels()] == ["Fy0", "Mx"]


def test_a_worker_process_gives_the_serial_numbers(case):
    """The levels the pool takes (every other one) are refitted from their own arguments: the
    record is the serial loop's, to the bit, but for the wall times."""
    from identify.core.workers import process_pool

    _, table, mf = case
    serial = pressure_holdout(table, mf).to_dict()
    with process_pool(1) as pool:
        pooled = pressure_holdout(table, mf, pool=pool).to_dict()
    for d in (serial, pooled):
        d.pop("seconds")
        for lv in d["levels"]:
            lv.pop("seconds")
    assert pooled == serial
