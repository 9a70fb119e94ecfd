"""The pressure relations (identify.model.relations): hand-computed values and properties."""
from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from identify.model import relations as rel

Q = dict(qfz1=2e5, qfz2=1e6, qfz3=0.5)
QSY = (0.01, 0.0, 0.0004, 4e-5, 0.0, 0.0, 0.85, -0.4)

loads = st.floats(0.0, 12000.0)
dpis = st.floats(-0.5, 0.5)
coef = st.floats(-1.0, 1.0)


# --- hand-computed values ---------------------------------------------------------------------

def test_increments():
    assert rel.dpi(3.0, 2.5) == pytest.approx(0.2)
    assert rel.dfz(6000.0, 5000.0) == pytest.approx(0.2)


def test_vertical_qfz_hand_values():
    # (1 + 0.5*0.2) * (2e5*0.02 + 1e6*0.02^2) = 1.1 * 4400
    assert rel.fz_qfz(0.02, 0.2, **Q) == pytest.approx(4840.0)
    assert rel.cfz_qfz(0.02, 0.2, **Q) == pytest.approx(1.1 * 240000.0)
    assert rel.rho_qfz(4840.0, 0.2, **Q) == pytest.approx(0.02)
    # 1.1 * sqrt(4e10 + 4e6 * 4400) = 1.1 * 240000
    assert rel.cfz_qfz_at_load(4840.0, 0.2, **Q) == pytest.approx(264000.0)
    assert rel.rho_qfz(1000.0, 0.0, 2e5, 0.0, 0.0) == pytest.approx(0.005)


def test_vertical_mf_form_hand_values_and_equivalence():
    mf = rel.mf_from_qfz(2e5, 1e6, 0.5, r0=0.3, fz0=4000.0)
    assert mf["VERTICAL_STIFFNESS"] == pytest.approx(math.sqrt(5.6e10))
    assert mf["Q_FZ2"] == pytest.approx(22.5)
    assert mf["PFZ1"] == 0.5
    rho = np.linspace(0.0, 0.04, 9)
    args = (mf["VERTICAL_STIFFNESS"], mf["Q_FZ2"], mf["PFZ1"], 0.3, 4000.0)
    np.testing.assert_allclose(rel.fz_mf(rho, -0.1, *args), rel.fz_qfz(rho, -0.1, **Q),
                               rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(rel.cfz_mf(rho, 0.3, *args), rel.cfz_qfz(rho, 0.3, **Q),
                               rtol=1e-12)
    assert rel.qfz_from_mf(*args) == pytest.approx((2e5, 1e6, 0.5), rel=1e-12)


def test_load_pressure_stiffness_hand_value():
    # 1e5 * (1 + 0.2*0.2 - 0.1*0.04) * (1 - 0.5*0.2)
    assert rel.load_pressure_stiffness(6000.0, -0.2, 1e5, 0.2, -0.1, 0.5, 5000.0) == \
        pytest.approx(93240.0)


def test_rebased_stiffness_is_the_same_function():
    c = rel.LoadPressureStiffness(225408.0, 0.23, -0.28, 0.21, 4000.0)
    r = c.rebased(5000.0)
    fz = np.linspace(500.0, 9000.0, 11)
    np.testing.assert_allclose(r(fz, 0.12), c(fz, 0.12), rtol=1e-12)
    assert r.fz0 == 5000.0 and r(5000.0, 0.0) == pytest.approx(r.nominal)


def test_cmz_forms_hand_values():
    assert rel.cmz_t1(2500.0, 0.2, 5000.0, -0.5, 5000.0) == pytest.approx(2250.0)
    # 5000 * (1.2*0.5 - 0.2*0.25) * (1 - 0.5*0.2)
    assert rel.cmz_t2(2500.0, 0.2, 5000.0, 1.2, -0.2, -0.5, 5000.0) == pytest.approx(2475.0)
    assert rel.YawT1(5000.0, -0.5, 5000.0)(2500.0, 0.2) == pytest.approx(2250.0)


def test_kya_hand_values():
    assert rel.kya(5000.0, 0.0, -20.0, 1.0, 0.5, 1.0, 5000.0) == pytest.approx(-100000.0)
    t = 5000.0 / (1.2 * 5000.0)  # sin(2 atan t) = 2t/(1 + t^2)
    expected = -20.0 * 1.1 * 5000.0 * 2 * t / (1 + t * t)
    assert rel.kya(5000.0, 0.2, -20.0, 1.0, 0.5, 1.0, 5000.0) == pytest.approx(expected)
    assert rel.sigma_ratio(-100000.0, 125000.0) == pytest.approx(0.8)


def test_carcass_chain_hand_values():
    # rho/r0 = 1/16: 0.5*0.3*(0.0625 + 0.4*0.25)
    assert rel.contact_half_length(0.3 / 16, 0.3, 0.5, 0.4) == pytest.approx(0.024375)
    assert rel.carcass_compliance(2e5, 4e5, 2.25e4, 0.3) == pytest.approx(1.15e-5)
    assert rel.cfy_chain(1e5, 2e5, 0.05) == pytest.approx(1 / 5.5e-6)
    assert rel.sigma_chain(-1e5, 2e5, 0.05) == pytest.approx(0.55)


def test_rolling_resistance_hand_values():
    bracket = 0.01 + 0.0004 + 0.00004
    assert rel.fxrr_new(4000.0, 2.5e5, 0.0, 16.7, 0.0, QSY, 2.5e5, 4000.0, 16.7) == \
        pytest.approx(-4000.0 * bracket)
    assert rel.fxrr_new(8000.0, 5e5, 0.0, 16.7, 0.0, QSY, 2.5e5, 4000.0, 16.7) == \
        pytest.approx(-4000.0 * bracket * 2 ** 0.85 * 2 ** -0.4)
    assert rel.fxrr_old(8000.0, 0.0, 16.7, 0.0, QSY, 4000.0, 16.7) == \
        pytest.approx(-8000.0 * bracket)


def test_camber_stiffness_hand_value():
    # (-0.9 - 0.2*0.2) * 6000 * (1 - 0.15*0.2)
    assert rel.kyg0(6000.0, 0.2, -0.9, -0.2, -0.15, 5000.0) == pytest.approx(-5470.8)


def test_sidewall_and_eigenfrequency_hand_values():
    assert rel.sidewall_scaled(1e6, 0.65, 0.2) == pytest.approx(1.13e6)
    assert rel.eigenfrequency((2 * math.pi * 80.0) ** 2 * 7.8, 7.8) == pytest.approx(80.0)
    ring = rel.SidewallRing((1.0, 1.0, 1.0, 4.0, 9.0, 9.0), (0.5,) * 6, 1.0, 1.0, 4.0)
    assert ring.frequency("theta", 0.0) == pytest.approx(1 / (2 * math.pi))
    assert ring.frequency("gamma", 0.0) == pytest.approx(3 / (2 * math.pi))
    assert ring.stiffness("y", 0.2) == pytest.approx(1.1)
    assert ring.to_dict()["modes"] == list(rel.RING_MODES)


def test_rotta_hand_values_at_right_angle():
    g, t, ls, p = 1.6e6, 0.01, 0.121, 2e5
    c_u, c_v, c_w = rel.rotta_membrane(p, g, t, ls, math.pi / 2)
    assert c_u == pytest.approx(g * t / ls, rel=1e-9)  # p/tan(90 deg) vanishes
    assert c_w == pytest.approx(p * math.pi / 2)
    assert c_v == pytest.approx(p / (1 - math.pi / 4))
    ring = rel.rotta_ring(p, 0.3, g, t, ls, math.pi / 2)
    assert ring["x"] == pytest.approx(math.pi * 0.3 * (c_u + c_w))
    assert ring["theta"] == pytest.approx(2 * math.pi * 0.3 ** 3 * c_u)
    # no pressure, no membrane stiffness: only the rubber term of c_u is left
    zero = rel.rotta_ring(0.0, 0.3, g, t, ls, np.deg2rad(62.3))
    assert zero["y"] == 0 and zero["gamma"] == 0 and zero["theta"] > 0


def test_dataclasses_are_frozen_and_serialise():
    v = rel.VerticalQFz(**Q)
    with pytest.raises(AttributeError):
        v.qfz1 = 1.0
    assert v.to_dict() == Q
    assert rel.YawT2(1.0, 2.0, 3.0, 4.0, 5.0).to_dict()["form"] == "T2"
    assert rel.RollingResistance(QSY, 2.5e5, 4000.0, 16.7).to_dict()["qsy"] == list(QSY)


# --- properties -------------------------------------------------------------------------------

@settings(max_examples=200, deadline=None)
@given(loads, dpis, coef, st.floats(100.0, 20000.0))
def test_cmz_t1_never_negative(fz, dp, p1, nominal):
    assert rel.cmz_t1(fz, dp, nominal, p1, 5000.0) >= 0


@settings(max_examples=100, deadline=None)
@given(st.floats(500.0, 12000.0), coef, coef, coef, coef, st.floats(0.5, 5.0))
def test_reduction_to_nominal_pressure(fz, a, b, c, d, pky2):
    """At dpi = 0 (and for power laws p = p0) the pressure coefficients drop out."""
    assert rel.load_pressure_stiffness(fz, 0.0, 1e5, 0.1, -0.05, a, 5000.0) == pytest.approx(
        rel.load_pressure_stiffness(fz, 0.0, 1e5, 0.1, -0.05, b, 5000.0))
    assert rel.kya(fz, 0.0, -20.0, pky2, a, b, 5000.0) == pytest.approx(
        rel.kya(fz, 0.0, -20.0, pky2, c, d, 5000.0))
    assert rel.kyg0(fz, 0.0, -0.9, 0.1, a, 5000.0) == pytest.approx(
        rel.kyg0(fz, 0.0, -0.9, 0.1, b, 5000.0))
    assert rel.cfz_qfz_at_load(fz, 0.0, 2e5, 1e6, a) == pytest.approx(
        rel.cfz_qfz_at_load(fz, 0.0, 2e5, 1e6, b))
    assert rel.sidewall_scaled(1e6, a, 0.0) == 1e6
    assert rel.cmz_t1(5000.0, 0.0, 4000.0, a, 5000.0) == pytest.approx(4000.0)
    assert rel.load_pressure_stiffness(5000.0, 0.0, 1e5, a, b, c, 5000.0) == pytest.approx(1e5)


@settings(max_examples=100, deadline=None)
@given(st.floats(-1.0, 0.0), st.floats(0.5, 1.0))
def test_rolling_resistance_power_laws_do_not_vanish_at_nominal(q8, q7):
    qsy = (0.01, 0.0, 0.0004, 4e-5, 0.0, 0.0, q7, q8)
    nominal = rel.fxrr_new(4000.0, 2.5e5, 0.0, 20.0, 0.0, qsy, 2.5e5, 4000.0, 16.7)
    assert nominal == pytest.approx(rel.fxrr_old(4000.0, 0.0, 20.0, 0.0, qsy, 4000.0, 16.7))
    assert nominal < 0


@settings(max_examples=100, deadline=None)
@given(loads, dpis, st.floats(0.0, 0.3))
def test_old_rolling_resistance_is_new_with_unit_exponents(fz, dp, gamma):
    qsy = (0.01, 0.001, 0.0004, 4e-5, 0.3, 0.1, 1.0, 0.0)
    p = 2.5e5 * (1 + dp)
    assert rel.fxrr_new(fz, p, 50.0, 25.0, gamma, qsy, 2.5e5, 4000.0, 16.7) == pytest.approx(
        rel.fxrr_old(fz, 50.0, 25.0, gamma, qsy, 4000.0, 16.7), rel=1e-12, abs=1e-12)


@settings(max_examples=150, deadline=None)
@given(st.floats(0.0, 0.06), dpis, st.floats(0.0, 3e6))
def test_vertical_inverse_and_derivative(rho, dp, qfz2):
    q = (2e5, qfz2, 0.7)
    fz = rel.fz_qfz(rho, dp, *q)
    assert rel.rho_qfz(fz, dp, *q) == pytest.approx(rho, rel=1e-9, abs=1e-12)
    assert rel.cfz_qfz_at_load(fz, dp, *q) == pytest.approx(rel.cfz_qfz(rho, dp, *q), rel=1e-9)
    h = 1e-7
    numeric = (rel.fz_qfz(rho + h, dp, *q) - rel.fz_qfz(rho - h, dp, *q)) / (2 * h)
    assert numeric == pytest.approx(rel.cfz_qfz(rho, dp, *q), rel=1e-6)


@settings(max_examples=100, deadline=None)
@given(st.floats(1e4, 3e5), st.floats(5e4, 5e5), st.floats(0.0, 0.1))
def test_chain_sigma_is_cfalpha_over_cfy(cfalpha, c_y, a):
    assert rel.sigma_chain(cfalpha, c_y, a) == pytest.approx(
        rel.sigma_ratio(cfalpha, rel.cfy_chain(cfalpha, c_y, a)), rel=1e-12)


@settings(max_examples=100, deadline=None)
@given(st.floats(100.0, 5000.0), dpis)
def test_kya_sign_follows_pky1_and_rises_below_its_peak(fz, dp):
    """Below the peak load PKY2 (1 + PPY2 dpi) Fz0 (>= 5250 N here) |Kya| rises with load."""
    k = rel.kya(fz, dp, -20.0, 1.5, 0.3, 0.6, 5000.0)
    assert k < 0
    assert abs(rel.kya(fz / 2, dp, -20.0, 1.5, 0.3, 0.6, 5000.0)) < abs(k)


def test_vectorised_broadcasting():
    fz = np.array([[2000.0], [5000.0]])
    dp = np.array([-0.2, 0.0, 0.2])
    out = rel.load_pressure_stiffness(fz, dp, 1e5, 0.1, 0.0, 0.4, 5000.0)
    assert out.shape == (2, 3)
    assert rel.kya(fz, dp, -20.0, 1.5, 0.3, 0.6, 5000.0).shape == (2, 3)
