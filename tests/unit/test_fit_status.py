"""Statuses weigh the error against the noise floor; bounds are physical or arbitrary."""
from __future__ import annotations

import math

import numpy as np
import pytest

from identify.fit import status as S
from identify.fit.bounds import (
    ARBITRARY,
    PHYSICAL,
    arbitrary_hits,
    bound_kinds,
    start_bounds,
    widen,
)
from identify.fit.mf.starts import data_starts
from identify.fit.result import FitResult
from identify.model.parameters import defaults


def _sweeps(n_sweeps: int, n: int, rng, sigma: float, offsets=None):
    """Slip-angle sweeps of a smooth curve plus white noise ``sigma`` (and a per-sweep
    offset)."""
    alpha = np.tile(np.deg2rad(np.linspace(-8, 8, n)), n_sweeps)
    truth = -3000.0 * np.sin(1.4 * np.arctan(12.0 * alpha))
    sweep = np.repeat(np.arange(n_sweeps), n)
    off = np.zeros(n_sweeps) if offsets is None else np.asarray(offsets, float)
    measured = truth + off[sweep] + rng.normal(0.0, sigma, truth.size)
    return alpha, truth, sweep, measured


def test_floor_of_white_noise_is_its_thesis_error():
    rng = np.random.default_rng(0)
    alpha, truth, sweep, y = _sweeps(4, 400, rng, 30.0)
    floor = S.noise_floor(y, truth, np.full(y.size, 1.0), sweep)
    expected = 100.0 * 30.0 / np.sqrt(np.mean(y ** 2))
    # 1600 points: the variance estimate's relative s.e. is ~sqrt(2/1596) = 3.5 %, the
    # floor's half of it
    assert floor.pct == pytest.approx(expected, rel=0.06)
    assert floor.source.startswith("neighbouring samples")  # the model is the truth


def test_repeated_sweeps_see_the_drift_between_them():
    """Two repeats 150 N apart at the same conditions: no single-valued model gets below
    75 N RMS there, which the neighbouring samples (noise 10 N) do not see. (The noise
    within each 0.25 deg bin, ~10 points of two sweeps, counts at (n - 2)/n of its variance:
    the bin's line takes two degrees of freedom.)"""
    rng = np.random.default_rng(1)
    alpha, truth, sweep, y = _sweeps(2, 300, rng, 10.0, offsets=[-75.0, 75.0])
    n = y.size
    cond = {"Fz": np.full(n, 3000.0), "alpha": alpha, "kappa": np.zeros(n),
            "gamma": np.zeros(n), "Vx": np.full(n, 16.7)}
    model = truth + 100.0  # a model that misses by more than the repeats differ
    floor = S.noise_floor(y, model, np.full(n, 1.0), sweep, conditions=cond, fnomin=3000.0)
    expected = 100.0 * math.hypot(75.0, 10.0) / np.sqrt(np.mean(y ** 2))
    assert floor.source == "repeated sweeps"
    assert floor.pct == pytest.approx(expected, rel=0.1)
    alone = S.noise_floor(y, model, np.full(n, 1.0), sweep)
    assert alone.pct < 0.2 * floor.pct


def test_floor_is_capped_at_the_error():
    rng = np.random.default_rng(2)
    alpha, truth, sweep, y = _sweeps(2, 200, rng, 30.0, offsets=[-75.0, 75.0])
    n = y.size
    cond = {"Fz": np.full(n, 3000.0), "alpha": alpha, "kappa": np.zeros(n),
            "gamma": np.zeros(n), "Vx": np.full(n, 16.7)}
    # a "model" through the measured points (two-valued: no tyre model is): no error
    floor = S.noise_floor(y, y + 1e-9, np.ones(n), sweep, conditions=cond, fnomin=3000.0)
    assert floor.pct <= 1e-6
    assert "capped" in floor.source


@pytest.mark.parametrize("error, floor, expected", [
    (98.6, 5.0, S.FAILED),       # the model misses the run's data grossly
    (75.0, 50.0, S.FAILED),
    (37.0, 6.0, S.POOR_FIT),     # far above its floor
    (37.0, 20.0, S.POOR_FIT),    # within 3x the floor but above 30 %
    (4.0, 2.0, S.OK),            # what the data allow
    (1.5, 0.01, S.OK),           # below the transducers' accuracy
    (6.0, 1.0, S.POOR_FIT),
    (29.0, math.nan, S.OK),      # no floor: only the caps apply
])
def test_quality(error, floor, expected):
    status, why = S.quality_problems(error, {1.0: error}, floor, "neighbouring samples")
    assert status == expected
    assert bool(why) == (expected != S.OK)
    if expected == S.POOR_FIT and math.isfinite(floor) and error > 3 * floor:
        assert f"{error:.3g} %" in why[0] and f"{floor:.3g} %" in why[0]


def test_one_pressure_missed_grossly_fails_the_fit():
    status, why = S.quality_problems(40.0, {0.8: 5.0, 1.2: 75.0}, 5.0)
    assert status == S.FAILED and "1.2 bar" in why[0]


def test_status_vocabulary_and_precedence():
    assert S.STATUSES == ("ok", "poorly identified", "poor fit", "failed")
    assert S.fit_status(False, S.OK, S.OK) == S.FAILED
    assert S.fit_status(True, S.POORLY_IDENTIFIED, S.OK) == S.POORLY_IDENTIFIED
    assert S.fit_status(True, S.POORLY_IDENTIFIED, S.POOR_FIT) == S.POOR_FIT
    assert S.fit_status(True, S.OK, S.FAILED) == S.FAILED


def test_fit_json_round_trip_keeps_floor_and_status():
    r = FitResult("MF", "Fy0", "wls", {"PDY1": 2.5}, ("PDY1",), {"PDY1": 0.1},
                  {"PDY1": (0.5, 3.0)}, (), (), 37.0, {1.0: 37.0}, 1.0, 100, True, "",
                  1, 1, {}, np.empty(0), np.empty(0), np.empty(0),
                  noise_floor_pct=6.0, floor_source="repeated sweeps", fit_status=S.POOR_FIT)
    d = r.to_dict()
    assert d["fit_status"] == "poor fit" and d["noise_floor_pct"] == 6.0
    back = FitResult.from_dict(d)
    assert back.status_text == S.POOR_FIT and back.floor_source == "repeated sweeps"


def test_physical_and_arbitrary_ends():
    assert bound_kinds("PEY1") == (ARBITRARY, PHYSICAL)      # E <= 1
    assert bound_kinds("PCY1") == (PHYSICAL, PHYSICAL)       # 1 <= C <= 2
    assert bound_kinds("DREFF") == (PHYSICAL, ARBITRARY)     # sign; 2 is a range
    # magnitude bounds mirror with the sign: PKY1 < 0 has (-150, -1)
    assert bound_kinds("PKY1", -20.0) == (ARBITRARY, ARBITRARY)
    assert bound_kinds("PPY5") == (PHYSICAL, PHYSICAL)  # (1 + PPY5 dpi) > 0 up to dpi = 1


def test_widening_keeps_signs_and_grows_ranges():
    assert widen(1.0, 150.0, "upper") == (1.0, 150.0 + 3 * 149.0)
    assert widen(-150.0, -1.0, "lower") == (-150.0 - 3 * 149.0, -1.0)
    assert widen(-150.0, -1.0, "upper") == (-150.0, -0.25)  # towards 0, never across
    assert widen(0.5, 3.0, "lower") == (0.125, 3.0)
    hits = arbitrary_hits(("PKY1", "PEY1", "Q_FZ2", "PDY1"),
                          {"PKY1": -150.0, "PEY1": 1.0, "Q_FZ2": 99.99998, "PDY1": 2.9},
                          {"PKY1": (-150.0, -1.0), "PEY1": (-10.0, 1.0),
                           "Q_FZ2": (1e-4, 100.0), "PDY1": (0.5, 3.0)})
    # PEY1 = 1 is physics; a solver's hair inside the bound is at it
    assert hits == {"PKY1": "lower", "Q_FZ2": "upper"}


def test_start_bounds_take_a_start_beyond_an_arbitrary_end():
    assert start_bounds("PKY1", -180.0) == (-180.0 - 179.0, -1.0)
    assert start_bounds("PDY1", 2.5) == (0.5, 3.0)
    assert start_bounds("PCY1", 2.5) == (1.0, 2.0)  # physical: the start is clipped


def test_data_starts_of_an_fsae_tyre():
    """A slick at 650 N nominal load: friction 2.6, Kya 50 kN/rad (77 Fz0): the passenger-car
    defaults (1.1, -20) are replaced, a start within a factor 2 is kept."""
    rng = np.random.default_rng(3)
    fz = np.repeat([220.0, 650.0, 1100.0], 600)
    alpha = np.tile(np.deg2rad(np.linspace(-12, 12, 600)), 3)
    kya, mu = 50000.0 * fz / 650.0, 2.6
    c = 1.4
    b = kya / (c * mu * fz)
    fy = -mu * fz * np.sin(c * np.arctan(b * alpha)) + rng.normal(0, 5, fz.size)
    import pandas as pd
    table = pd.DataFrame({"Fz": fz, "alpha": alpha, "kappa": 0.0, "gamma": 0.0, "Fy": fy})
    params = {k: float(v) for k, v in defaults().items() if not isinstance(v, str)}
    params["FNOMIN"] = 650.0
    got = data_starts(table, params)
    assert got["PDY1"] == pytest.approx(mu, rel=0.02)
    # the secant over +-1 deg of the saturating curve: a few per cent below the slope at 0
    assert got["PKY1"] == pytest.approx(-50000.0 / 650.0, rel=0.05)
    params.update(PDY1=2.0, PKY1=-60.0)
    assert data_starts(table, params) == {}
    # free-rolling points of other runs (Fx = 0 at kappa = 0) are no friction sample: no PDX1
    assert "PDX1" not in data_starts(table.assign(Fx=0.0), params)


def test_sweeps_at_other_speeds_repeat_a_speedless_model():
    """Two sweeps at 25 and 70 km/h, 150 N apart: repeats for a stage without speed terms
    (the MF forces), not for one with them (My, the radii)."""
    rng = np.random.default_rng(4)
    alpha, truth, sweep, y = _sweeps(2, 300, rng, 10.0, offsets=[-75.0, 75.0])
    n = y.size
    cond = {"Fz": np.full(n, 3000.0), "alpha": alpha, "kappa": np.zeros(n),
            "gamma": np.zeros(n), "Vx": np.where(sweep == 0, 6.9, 19.4)}
    model = truth + 100.0
    speedless = S.noise_floor(y, model, np.ones(n), sweep, conditions=cond, fnomin=3000.0,
                              by_speed=False)
    with_speed = S.noise_floor(y, model, np.ones(n), sweep, conditions=cond, fnomin=3000.0)
    assert speedless.source == "repeated sweeps"
    assert with_speed.source == "neighbouring samples"
    assert with_speed.pct < 0.2 * speedless.pct
