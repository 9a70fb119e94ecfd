"""Discovery on the layouts of real sessions (issue 45): pressures outside the base .tir's
validity range reach the model as measured, a partly crossed design keeps a pressure hold-out
on the conditions it shares, moments are scored against their range, not their RMS."""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from identify.discover.design import folds, overlap
from identify.discover.prepared_problem import errors_by_group, group_scale, noise_floor_pct
from identify.discover.scenarios import base_tir
from identify.discover.stage_problems import covering, label_sweeps, stage_problem
from identify.fit.solve.problem import FitProblem


def _fsae_frame(pressures=(0.55e5, 0.83e5), loads=(1500.0, 3000.0), m=120) -> pd.DataFrame:
    """Cornering sweeps (triangle 0 -> 10 -> -10 -> 0 deg) at every pressure x load."""
    s = np.linspace(0.0, 4.0, m)
    tri = np.where(s <= 1, s, np.where(s <= 3, 2 - s, s - 4))
    rows = []
    for i, (p, fz) in enumerate((p, fz) for p in pressures for fz in loads):
        rows.append(pd.DataFrame({"run": "r", "t": 100.0 * i + np.arange(m) / 100.0,
                                  "Fz": fz, "p": p, "alpha": np.deg2rad(10.0) * tri,
                                  "kappa": 0.0, "gamma": 0.0, "Vx": 11.1, "Fy": 0.0}))
    return pd.concat(rows, ignore_index=True)


def test_pressures_below_the_base_tirs_range_reach_the_model():
    """The bundled tyre is valid from 1.5 bar; a Formula Student session runs at 0.55 and
    0.83 bar around a nominal 0.7 bar. With PPY3 = -0.2 the peak friction scales by
    (1 + PPY3 dpi): up at the low pressure (dpi = -0.21), down at the high one (+0.19). Clipped
    to PRESMIN, both levels had dpi = +1.14 and moved the same way."""
    tir = base_tir()
    tir.update(NOMPRES=0.7e5, INFLPRES=0.7e5)
    assert tir["PRESMIN"] > 0.83e5  # the case: every measured pressure below the range
    frame = label_sweeps(_fsae_frame(), {"r": "cornering"})
    p = stage_problem("Fy", frame, tir)
    v0 = p.values()
    change = np.abs(p.model({**v0, "PPY3": -0.2})) - np.abs(p.model(v0))
    at = np.asarray(p.pressure_bar)
    big = np.abs(p.model(v0)) > 0.3 * np.abs(p.model(v0)).max()
    assert np.all(change[big & (at < 0.7)] > 0) and np.all(change[big & (at > 0.7)] < 0)
    t = covering(tir, {"p": np.array([0.55e5, 0.83e5]), "Fz": np.array([50.0, 3000.0])})
    assert (t["PRESMIN"], t["PRESMAX"], t["FZMIN"]) == (0.55e5, tir["PRESMAX"], 50.0)
    assert covering(tir, {"p": np.array([2e5])}) == tir  # inside the range: unchanged


def test_a_partly_crossed_design_leaves_pressures_out_where_they_overlap():
    """Three pressures at load A, load B at the first only (the TTC layout): each fold holds
    out one pressure of load A; load B always trains."""
    pres = np.repeat([0, 1, 2, 0], 10)
    other = np.repeat([0, 0, 0, 1], 10)
    assert overlap(pres, other).tolist() == [True] * 30 + [False] * 10
    meas = np.ones(pres.size)
    problem = FitProblem("x", "y", None, lambda v: meas, meas, np.choose(pres, [1.0, 2.0, 3.0]),
                         extra={"Fz_N": np.where(other == 0, 1000.0, 3000.0)})
    masks, scheme = folds(problem, [np.arange(i, i + 10) for i in range(0, 40, 10)])
    assert scheme.startswith("leave one pressure level out of the conditions")
    assert len(masks) == 3
    for lv, m in enumerate(masks):
        assert np.array_equal(np.flatnonzero(m), np.arange(10 * lv, 10 * lv + 10))


def test_moment_errors_are_relative_to_the_range():
    """An aligning moment through zero: 1 N m RMS error on a curve spanning -20 .. +20 N m is
    2.5 % of its range, whatever its RMS (the thesis metric divides by it)."""
    x = np.linspace(-1.0, 1.0, 2001)
    meas = 20.0 * x  # RMS 11.5, range 40
    err = np.where(np.arange(x.size) % 2 == 0, 1.0, -1.0)
    err[-1] = 1.0
    problem = FitProblem("MF", "Mz", None, lambda v: meas, meas, np.ones(x.size),
                         extra={"quantity": "Mz"})
    got = errors_by_group(problem, meas + err, np.zeros(x.size, dtype=int))
    assert got[0.0] == pytest.approx(100.0 * 1.0 / 40.0, rel=1e-12)
    scale = group_scale(meas, np.zeros(x.size, dtype=int), True)
    assert scale[0] == pytest.approx(40.0 * np.sqrt(x.size), rel=1e-12)
    floor = noise_floor_pct(np.full(x.size, 0.5), meas, np.zeros(x.size, dtype=int), True)
    assert floor == pytest.approx(100.0 * 0.5 / 40.0, rel=1e-12)
    fy = FitProblem("MF", "Fy", None, lambda v: meas, meas, np.ones(x.size),
                    extra={"quantity": "Fy"})  # forces keep the thesis metric
    rms = np.sqrt(np.mean(meas ** 2))
    assert errors_by_group(fy, meas + err, np.zeros(x.size))[0.0] == pytest.approx(
        100.0 / rms, rel=1e-9)
