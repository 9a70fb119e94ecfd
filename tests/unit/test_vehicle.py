"""The vehicle analysis (identify.vehicle) against closed forms and the single-track model.

Acceptance of issue 47: the two-track steady state at vanishing lateral acceleration against
the single-track understeer gradient (m/l)(b/Cf - a/Cr) and the yaw-rate gain V/(l + K V^2) at
seven front/rear settings on the bundled tyre; the directions pressure moves the understeer
gradient and the ride; the two-track solve against tyres with a closed-form axle stiffness
and against the friction limit mu g; the single-track eigenvalues and the ride's RMS against
their closed forms.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np
import pytest

from identify.io.tir import read_tir
from identify.model.evaluate import evaluate
from identify.model.modes import FIT_MODE
from identify.simulate.default_tyre import default_tir_path
from identify.vehicle import steady
from identify.vehicle.analysis import DEFAULT_SETTINGS_BAR, analyse
from identify.vehicle.ride import (
    N0,
    N_MAX,
    N_MIN,
    ROAD_CLASSES,
    QuarterCarModel,
    ride_response,
    road_profile,
    transfer,
)
from identify.vehicle.spec import G, default_vehicle
from identify.vehicle.transient import SingleTrack
from identify.vehicle.tyre import MfTyre, ValidityRange

SETTINGS = [(f * 1e5, r * 1e5) for f, r in DEFAULT_SETTINGS_BAR]
V100 = 100 / 3.6


@pytest.fixture(scope="module")
def bundled():
    tir = read_tir(default_tir_path())
    return MfTyre(tir.params(), damping_given=True)


@pytest.fixture(scope="module")
def result(bundled):
    return analyse(bundled, default_vehicle(), SETTINGS)


@dataclass(frozen=True)
class OddTyre:
    """The bundled tyre without the forces it gives at zero slip (ply steer, conicity): the
    odd part in slip angle of Fy and Mz, so load transfer moves no force at zero slip."""

    base: MfTyre

    @property
    def validity(self):
        return self.base.validity

    def lateral(self, fz, alpha, gamma, p):
        fy1, mz1 = self.base.lateral(fz, alpha, gamma, p)
        fy2, mz2 = self.base.lateral(fz, -np.asarray(alpha), gamma, p)
        return 0.5 * (fy1 - fy2), 0.5 * (mz1 - mz2)

    def relaxation_length(self, fz, gamma, p):
        return self.base.relaxation_length(fz, gamma, p)

    def vertical(self, fz, p, vx):
        return self.base.vertical(fz, p, vx)


def _axle_stiffness_closed_form(P, fz, p, c_fy, c_mz):
    """2 Ky / (1 + c_Fy Ky + c_Mz Kmz) of one axle, Ky = |dFy/dalpha| and Kmz = dMz/dalpha of
    the .tir at alpha = 0 (central differences of the forward model, odd parts only)."""
    h = 1e-5
    out = evaluate(P, np.full(2, fz), 0.0, np.array([h, -h]), 0.0, V100, p=np.full(2, p),
                   mode=FIT_MODE)
    ky = -(out["Fy"][0] - out["Fy"][1]) / (2 * h)
    kmz = (out["Mz"][0] - out["Mz"][1]) / (2 * h)
    return 2 * ky / (1 + c_fy * ky + c_mz * kmz)


def test_understeer_gradient_at_vanishing_ay_is_the_single_track_value(bundled):
    """Seven settings: K of the two-track solve at ay -> 0 against (m/l)(b/Cf - a/Cr), the axle
    stiffnesses in closed form from the tyre's Ky and Kmz with compliance steer."""
    v = default_vehicle().vehicle
    tyre = OddTyre(bundled)
    pf = np.array([s[0] for s in SETTINGS])
    pr = np.array([s[1] for s in SETTINGS])
    k = steady.understeer_gradient(tyre, v, pf, pr)
    d = math.pi / 180
    cf = np.array([_axle_stiffness_closed_form(bundled.params, v.static_wheel_load("front"), p,
                                               v.steer_compliance_fy_front_deg_per_N * d,
                                               v.steer_compliance_mz_front_deg_per_Nm * d)
                   for p in pf])
    cr = np.array([_axle_stiffness_closed_form(bundled.params, v.static_wheel_load("rear"), p,
                                               v.steer_compliance_fy_rear_deg_per_N * d,
                                               v.steer_compliance_mz_rear_deg_per_Nm * d)
                   for p in pr])
    single = v.mass_kg / v.wheelbase_m * (v.b / cf - v.a / cr)
    assert np.all(single > 0)
    # issue 47 asks for 1 %; the solve is exact to the O(ay^2) of the difference quotient
    np.testing.assert_allclose(k, single, rtol=1e-3)


def test_the_bundled_tyres_zero_slip_forces_add_the_load_transfer_term(bundled, result):
    """On the bundled tyre as it is, load transfer moves the mirrored wheels' zero-slip forces
    (PVY1, PHY1 ...): K = (m/l)(b/Cf - a/Cr) - (D_f/Cf - D_r/Cr), D = d(axle force at zero
    axle slip)/d ay through the wheel loads."""
    v = default_vehicle().vehicle
    front, rear = steady.axle_setups(v)
    m, a, b, wb = v.mass_kg, v.a, v.b, v.wheelbase_m
    dd = 0.01
    for s in result.settings:
        f = s.figures
        cf = f["axle_cornering_stiffness_front_N_per_rad"]
        cr = f["axle_cornering_stiffness_rear_N_per_rad"]
        terms = []
        for ax, p in ((front, f["front_pressure_Pa"]), (rear, f["rear_pressure_Pa"])):
            fl, fr = steady.wheel_loads(v, ax.axle, dd)
            terms.append(float(steady.axle_force(bundled, ax, fl, fr, 0.0, p).force) / dd)
        expected = m / wb * (b / cf - a / cr) - (terms[0] / cf - terms[1] / cr)
        k = math.radians(f["understeer_gradient_deg_per_mps2"])
        assert k == pytest.approx(expected, rel=1e-3)
        single = math.radians(f["understeer_gradient_single_track_deg_per_mps2"])
        # the term is small but not nothing on this tyre: between 0.3 % and 3 % of K
        assert 0.003 < (k - single) / k < 0.03


def test_yaw_rate_gain_is_v_over_l_plus_k_v2(result):
    v = default_vehicle().vehicle
    for s in result.settings:
        k = math.radians(s.figures["understeer_gradient_deg_per_mps2"])
        gain = V100 / (v.wheelbase_m + k * V100 ** 2)
        assert s.figures["yaw_rate_gain_per_s"] == pytest.approx(gain, rel=1e-6)
        assert s.stable


def test_single_track_dc_gain_and_eigenvalues_match_the_closed_forms():
    """Without tyre lag (sigma 1 mm: lag poles at -V/sigma) the body mode is the bicycle
    model's: 2 zeta wn = (Cf + Cr)/(m V) + (a^2 Cf + b^2 Cr)/(Iz V),
    wn^2 = Cf Cr l^2/(m Iz V^2) + (b Cr - a Cf)/Iz."""
    m, iz, a, b, cf, cr, V = 1500.0, 2500.0, 1.2, 1.5, 90e3, 120e3, 25.0
    model = SingleTrack(m, iz, a, b, cf, cr, 1e-3, 1e-3, V)
    wb = a + b
    k = m / wb * (b / cf - a / cr)
    assert model.steady_state_yaw_gain() == pytest.approx(V / (wb + k * V ** 2), rel=1e-9)
    wn2 = cf * cr * wb ** 2 / (m * iz * V ** 2) + (b * cr - a * cf) / iz
    two_zeta_wn = (cf + cr) / (m * V) + (a ** 2 * cf + b ** 2 * cr) / (iz * V)
    fn, zeta, stable = model.body_mode()
    assert stable
    assert (2 * math.pi * fn) ** 2 == pytest.approx(wn2, rel=2e-3)
    assert 2 * zeta * 2 * math.pi * fn == pytest.approx(two_zeta_wn, rel=2e-3)
    # relaxation lengths delay the response but leave the steady state alone
    lagged = replace(model, sigma_front=0.5, sigma_rear=0.5)
    assert lagged.steady_state_yaw_gain() == pytest.approx(model.steady_state_yaw_gain(),
                                                           rel=1e-12)
    r0 = np.angle(model.response([1.0])[0][0])
    r1 = np.angle(lagged.response([1.0])[0][0])
    assert r1 < r0


def test_pressure_moves_the_understeer_gradient_the_way_the_axle_stiffnesses_say(result):
    """Front raised (2.7/2.5) and rear lowered (2.5/2.2) against 2.5/2.5: the change of K has
    the sign and, within 10 %, the size of the change of (m/l)(b/Cf - a/Cr)."""
    by = {s.label: s.figures for s in result.settings}
    base = by["2.50/2.50 bar"]
    for label in ("2.70/2.50 bar", "2.50/2.20 bar", "2.70/2.20 bar"):
        f = by[label]
        dk = f["understeer_gradient_deg_per_mps2"] - base["understeer_gradient_deg_per_mps2"]
        ds = (f["understeer_gradient_single_track_deg_per_mps2"]
              - base["understeer_gradient_single_track_deg_per_mps2"])
        assert np.sign(dk) == np.sign(ds) != 0
        assert dk == pytest.approx(ds, rel=0.1)
    # on this tyre the cornering stiffness at the sedan's wheel loads falls with pressure:
    # raising the front lowers Cf, lowering the rear raises Cr, both add understeer
    assert (by["2.70/2.50 bar"]["axle_cornering_stiffness_front_N_per_rad"]
            < base["axle_cornering_stiffness_front_N_per_rad"])
    assert (by["2.50/2.20 bar"]["axle_cornering_stiffness_rear_N_per_rad"]
            > base["axle_cornering_stiffness_rear_N_per_rad"])
    assert (by["2.70/2.20 bar"]["understeer_gradient_deg_per_mps2"]
            > by["2.70/2.50 bar"]["understeer_gradient_deg_per_mps2"]
            > base["understeer_gradient_deg_per_mps2"])


def test_ride_gets_harsher_with_the_pressure_of_all_four_tyres(result):
    """Settings with equal front and rear pressure, in pressure order: the tyre's vertical
    stiffness rises, and so do the body acceleration and the wheel-load RMS."""
    equal = sorted((s for s in result.settings
                    if s.figures["front_pressure_Pa"] == s.figures["rear_pressure_Pa"]),
                   key=lambda s: s.figures["front_pressure_Pa"])
    assert [s.label for s in equal] == ["1.90/1.90 bar", "2.20/2.20 bar", "2.50/2.50 bar",
                                        "3.00/3.00 bar"]
    cz = [s.figures["vertical_stiffness_front_N_per_m"] for s in equal]
    acc = [s.figures["ride_body_acceleration_rms_mps2"] for s in equal]
    load = [s.figures["ride_wheel_load_rms_N"] for s in equal]
    assert np.all(np.diff(cz) > 0)
    assert np.all(np.diff(acc) > 0)
    assert np.all(np.diff(load) > 0)


@dataclass(frozen=True)
class QuadraticTyre:
    """Fy = -Ky(Fz) alpha with Ky = c1 Fz - c2 Fz^2 (ISO signs), no aligning moment."""

    c1: float = 40.0
    c2: float = 2.5e-3
    validity: ValidityRange = ValidityRange()

    def ky(self, fz):
        return self.c1 * fz - self.c2 * fz ** 2

    def lateral(self, fz, alpha, gamma, p):
        fz, alpha = np.broadcast_arrays(np.asarray(fz, float), np.asarray(alpha, float))
        return -self.ky(fz) * alpha, np.zeros(fz.shape)


def test_two_track_with_cornering_stiffness_quadratic_in_load():
    """Load transfer dF lowers an axle's stiffness from 2 Ky(F0) to 2 Ky(F0) - 2 c2 dF^2, so
    alpha_axle = (m ay share / l) / (2 Ky(F0) - 2 c2 dF(ay)^2) exactly."""
    tyre = QuadraticTyre()
    v = replace(default_vehicle().vehicle, steer_compliance_fy_front_deg_per_N=0.0,
                steer_compliance_fy_rear_deg_per_N=0.0,
                steer_compliance_mz_front_deg_per_Nm=0.0, cg_to_front_axle_m=1.3)
    ay = np.array([0.5, 2.0, 4.0, 6.0, 8.0])
    front, rear = steady.handling_points(tyre, v, ay, 2.5e5, 2.5e5)
    for sol, axle, share in ((front, "front", v.b), (rear, "rear", v.a)):
        f0 = v.static_wheel_load(axle)
        dfz = v.load_transfer_per_ay(axle) * ay
        c_axle = 2 * tyre.ky(f0) - 2 * tyre.c2 * dfz ** 2
        expected = v.mass_kg * ay * share / v.wheelbase_m / c_axle
        np.testing.assert_allclose(sol.alpha, expected, rtol=1e-8)
        np.testing.assert_allclose(sol.fz_right - sol.fz_left, 2 * dfz, rtol=1e-12)
    # and the understeer gradient at vanishing ay is the single-track value (the difference
    # quotient at ay = 0.01 m/s^2 keeps the c2 dF^2 term: a few 1e-6 of K)
    k = steady.understeer_gradient(tyre, v, 2.5e5, 2.5e5)[0]
    cf = 2 * tyre.ky(v.static_wheel_load("front"))
    cr = 2 * tyre.ky(v.static_wheel_load("rear"))
    assert k == pytest.approx(v.mass_kg / v.wheelbase_m * (v.b / cf - v.a / cr), rel=1e-5)


@dataclass(frozen=True)
class SaturatingTyre:
    """Fy = -mu Fz sin(C atan(B alpha)): peak friction mu at every load."""

    mu: float = 1.05
    validity: ValidityRange = ValidityRange()

    def lateral(self, fz, alpha, gamma, p):
        fz, alpha = np.broadcast_arrays(np.asarray(fz, float), np.asarray(alpha, float))
        return -self.mu * fz * np.sin(1.4 * np.arctan(12.0 * alpha)), np.zeros(fz.shape)


def test_max_lateral_acceleration_is_mu_g_without_load_transfer(bundled):
    """Centre of gravity on the ground: no load transfer; with the same peak friction front and
    rear the limit is mu_peak g. Closed-form tyre to 1e-4; the bundled tyre (its mu_peak at the
    static load and pressure from the forward model on a 0.0005 rad grid) to 0.1 % (the two
    wheels of an axle do not reach their peaks at quite the same axle slip angle)."""
    v = replace(default_vehicle().vehicle, cg_height_m=0.0)
    ay, limiting = steady.max_lateral_acceleration(SaturatingTyre(), v, 2.5e5, 2.5e5)
    assert ay[0] == pytest.approx(1.05 * G, rel=1e-4)
    pressures = np.array([1.9e5, 2.5e5, 3.0e5])
    ay, _ = steady.max_lateral_acceleration(bundled, v, pressures, pressures)
    fz = v.static_wheel_load("front")
    alpha = np.linspace(-0.4, 0.4, 1601)
    for p, a_max in zip(pressures, ay):
        fy = evaluate(bundled.params, fz, 0.0, alpha, 0.0, V100, p=p, mode=FIT_MODE)["Fy"]
        # the right wheel is the left one mirrored: the axle's peak friction is the mean of
        # the .tir's positive and negative peaks (they differ by its zero-slip offsets)
        mu_peak = (fy.max() - fy.min()) / 2 / fz
        # issue 47 asks for 1 %; the 0.01 rad slip grid's parabolic peak does far better
        assert a_max == pytest.approx(mu_peak * G, rel=1e-3)
    assert np.all(np.diff(ay) < 0)  # this tyre's friction falls with pressure (PPY3 < 0)


def test_ride_rms_is_the_spectral_integral_and_does_not_depend_on_the_seed():
    q = QuarterCarModel(375.0, 40.0, 22e3, 1700.0, 240e3, 300.0)
    speed = 25.0
    road = road_profile("C", seed=3)
    r = ride_response(q, road, speed)
    n = np.geomspace(N_MIN, N_MAX, 20001)
    acc, load = transfer(q, n * speed)
    gd = ROAD_CLASSES["C"] * (n / N0) ** -2
    for rms, h in ((r.body_acceleration_rms, acc), (r.wheel_load_rms, load)):
        integral = math.sqrt(np.trapezoid(np.abs(h) ** 2 * gd, n))
        assert rms == pytest.approx(integral, rel=0.01)
    other = ride_response(q, road_profile("C", seed=4), speed)
    assert other.body_acceleration_rms == pytest.approx(r.body_acceleration_rms, rel=1e-9)
    assert not np.allclose(road.elevation([0.0, 7.0]), road_profile("C", 4).elevation([0, 7.0]))
    # one class up is four times the spectral density: twice the RMS
    d = ride_response(q, road_profile("D", seed=3), speed)
    assert d.body_acceleration_rms == pytest.approx(2 * r.body_acceleration_rms, rel=1e-12)
    # a static road lifts the body with it
    acc0, load0 = transfer(q, [1e-6])
    assert abs(acc0[0]) < 1e-9 and abs(load0[0]) < 1e-6


def test_result_round_trips_through_its_dict(result):
    from identify.vehicle.analysis import VehicleResult

    back = VehicleResult.from_dict(result.to_dict())
    for s, t in zip(result.settings, back.settings):
        assert s.figures == t.figures
        assert s.handling["alpha_front_deg"] == t.handling["alpha_front_deg"]
    assert back.spec == result.spec
