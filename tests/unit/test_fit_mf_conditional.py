"""Free MF coefficients whose values rest on held ones (identify.fit.mf.conditional): the
variance inflation against hand-made Jacobians, and an Mx stage fitted with QSX4 held at its
default while the data come from a tyre with that term (the coefficients it trades with are
reported as not identifiable on their own, with the held names)."""
from __future__ import annotations

import dataclasses

import numpy as np
import pandas as pd
import pytest

from identify.fit.identifiability import unidentified
from identify.fit.mf.conditional import AFTER_FIT, conditional_on_held, inflation, with_conditional
from identify.fit.mf.problem import stage_problem
from identify.fit.optimize import fit
from identify.fit.result import FitResult
from tests.unit.test_fit_calibration_mf import add_noise, design, simulate
from tests.unit.test_fit_mf_stages import _truth


def test_inflation_is_the_variance_ratio_of_the_two_least_squares_problems():
    """Columns a, b free and h held: with h = a + 0.1 e (e orthogonal to a, b) freeing h
    multiplies a's variance by 1 + |a|^2 / (0.1 |e|)^2 (= 101 here) and leaves b's at 1;
    h = a exactly leaves a undetermined (inf); h orthogonal to both changes nothing."""
    rng = np.random.default_rng(0)
    q, _ = np.linalg.qr(rng.standard_normal((200, 4)))
    a, b, e, f = q.T
    vif = inflation(np.column_stack([a, b, a + 0.1 * e]), 2)
    np.testing.assert_allclose(vif, [101.0, 1.0], rtol=1e-9)
    assert np.isinf(inflation(np.column_stack([a, b, a]), 2)[0])
    np.testing.assert_allclose(inflation(np.column_stack([a, b, f]), 2), [1.0, 1.0],
                               rtol=1e-12)
    assert np.isnan(inflation(np.column_stack([a, a, f]), 2)).all()  # undetermined already


def test_a_column_without_effect_leaves_the_others_assessed():
    """A free coefficient with no effect at the optimum (its column 0) is undetermined (nan)
    but does not hide the others: a's inflation by h = a + 0.1 e is still 101; a held column
    of zeros changes nothing; a Jacobian of zeros leaves all undetermined (no division by 0)."""
    rng = np.random.default_rng(0)
    q, _ = np.linalg.qr(rng.standard_normal((200, 4)))
    a, b, e, f = q.T
    vif = inflation(np.column_stack([a, 0 * b, a + 0.1 * e]), 2)
    np.testing.assert_allclose(vif[0], 101.0, rtol=1e-9)
    assert np.isnan(vif[1])
    np.testing.assert_allclose(inflation(np.column_stack([a, b, 0 * f]), 2), [1.0, 1.0],
                               rtol=1e-12)
    with np.errstate(all="raise"):
        assert np.isnan(inflation(np.zeros((200, 3)), 2)).all()


@pytest.fixture(scope="module")
def mx_fit():
    """Mx data from a tyre with the QSX4 term (another tyre's values: QSX4 = 4.912, QSX5 =
    1.02, QSX6 = 22.83, QSX7 = 0.7104, QSX8 = -0.0234, QSX9 = 0.658), fitted with QSX4 held at
    its default 5 and QSX6 at 10, as when the re-fit with them did not go through."""
    truth = dict(_truth(), QSX4=4.912, QSX5=1.02, QSX6=22.83, QSX7=0.7104, QSX8=-0.0234,
                 QSX9=0.658)
    pts = design(loads=(3000.0, 5000.0, 7000.0))
    data = add_noise(simulate(truth, pts[pts["run"].str.startswith("lat")]), 7)
    start = dict(truth, QSX4=5.0, QSX6=10.0, QSX7=0.0, QSX8=0.0)
    free = ["QSX1", "QSX2", "QSX3", "QSX7", "QSX8"]
    held = {n: f"sensitivity: {AFTER_FIT}, and the re-fit with it did not converge"
            for n in ("QSX4", "QSX6")}
    sp = stage_problem("Mx", data, start, free={"Mx": free + list(held)}, hold=held)
    assert sp.problem.free == tuple(free)
    result = fit(sp.problem, starts=sp.problem.x0()[None, :])
    assert result.converged
    return result, sp, data, start, truth


def test_the_coefficients_a_held_one_trades_with_are_conditional(mx_fit):
    """QSX7 and QSX8 (the sine's arguments, scaled by the held QSX4), QSX3 (QSX4's term is
    linear in Fy through QSX8 QSX9) and QSX2 (camber, as QSX7) rest on QSX4 and QSX6, and
    their estimates are 8-68 standard errors from the truth; QSX1 (a constant) does not, and
    is within 0.4. Without the AFTER_FIT reason nothing is flagged (a hold the data do not
    contradict)."""
    result, sp, data, start, truth = mx_fit
    found = conditional_on_held(result, sp, "Mx", data, start)
    assert set(found) == {"QSX2", "QSX3", "QSX7", "QSX8"}, found
    z = {n: (result.parameters[n] - truth[n]) / result.stderr[n] for n in result.free}
    assert all(abs(z[n]) > 5 for n in found), z  # measured 7.9-68: the intervals would lie
    assert abs(z["QSX1"]) < 3, z  # measured 0.4
    assert all("QSX4 = 5" in why and "QSX6 = 10" in why for why in found.values())
    other = dataclasses.replace(sp, held={"QSX4": "data: one load", "QSX6": "x"})
    assert conditional_on_held(result, other, "Mx", data, start) == {}


def test_conditional_coefficients_are_unidentified_and_round_trip_through_json(mx_fit):
    """identifiability counts them not identifiable on their own (the reason names the held
    ones), the stage is "poorly identified", and FitResult.conditional survives to_dict /
    from_dict."""
    result, sp, data, start, _ = mx_fit
    flagged = with_conditional(result, sp, "Mx", data, start)
    assert flagged.identification == "poorly identified"
    names = set(flagged.conditional)
    assert names and names <= set(unidentified(flagged))
    assert any("its interval assumes them exact" in r for r in flagged.reasons)
    back = FitResult.from_dict(flagged.to_dict())
    assert back.conditional == flagged.conditional
    assert set(unidentified(back)) == set(flagged.unidentified)


def test_a_shift_held_for_slip_angles_of_one_sign_leaves_what_trades_with_it_conditional():
    """Combined slip at slip angles 3 and 6 deg only (a TTC drive/brake run sets 0, -3, -6
    deg; the stage's points leave out 0) at two cambers, from a tyre with RBY3 = -0.03: the
    coverage holds RBY3 at 0 (a shift of the slip angle needs both signs), and RBY2, which
    trades with it along By_kappa = RBY1 cos(atan(RBY2 (alpha - RBY3))), is listed as resting
    on it (mf_conditional.ONE_SIGN). Without the ONE_SIGN reason nothing is flagged."""
    truth = dict(_truth(), RBY3=-0.03)
    d = np.deg2rad
    pts = pd.concat([pd.DataFrame({"run": f"comb_{fz:g}_{g:g}_{a:g}", "Vx": 16.7,
                                   "kappa": np.linspace(-0.25, 0.25, 41), "alpha": d(a),
                                   "gamma": d(g), "p": 2.5e5, "Fz": fz})
                     for fz in (3000.0, 5000.0, 7000.0) for g in (0.0, 2.0) for a in (3.0, 6.0)],
                    ignore_index=True)
    data = add_noise(simulate(truth, pts), 3)
    start = dict(truth, RBY3=0.0)
    sp = stage_problem("Fy", data, start)
    assert sp.held["RBY3"] == "data: slip angles of one sign only"
    result = fit(sp.problem, starts=sp.problem.x0()[None, :])
    assert result.converged and "RBY2" in result.free
    found = conditional_on_held(result, sp, "Fy", data, start)
    assert "RBY2" in found and "RBY3 = 0" in found["RBY2"], found
    other = dataclasses.replace(sp, held={**sp.held, "RBY3": "data: one load"})
    assert "RBY2" not in conditional_on_held(result, other, "Fy", data, start)
