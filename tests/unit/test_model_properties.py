"""Property tests of the forward model (hypothesis): invariances a correct MF must have."""
from __future__ import annotations

import warnings

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from identify.model.evaluate import evaluate
from identify.model.parameters import PRESSURE_KEYS
from tests.model_cases import params

P61 = params(61)
P62 = params(62)

loads = st.floats(200.0, 10000.0)
slips = st.floats(-0.3, 0.3)
angles = st.floats(-0.25, 0.25)
cambers = st.floats(-0.1, 0.1)
speeds = st.floats(2.0, 40.0)
pressures = st.floats(1.6e5, 3.8e5)
point = st.tuples(loads, slips, angles, cambers, speeds, pressures)

# Coefficients that make the tyre asymmetric in alpha/kappa (shifts, ply-steer, conicity,
# camber terms); with all of them at zero Fy and Mz are odd in alpha.
ASYMMETRIC = ("PHX1", "PHX2", "PVX1", "PVX2", "PEX4", "PHY1", "PHY2", "PVY1", "PVY2", "PVY3",
              "PVY4", "PKY6", "PKY7", "PEY3", "PEY4", "QHZ1", "QHZ2", "QHZ3", "QHZ4", "RHX1",
              "RHY1", "RHY2", "RVY1", "RVY2", "RVY3", "RBY3", "QDZ6", "QDZ7", "QDZ8", "QDZ9",
              "QDZ10", "QDZ11", "SSZ1", "SSZ2", "SSZ3", "SSZ4", "QSX1", "QSX2", "QSX3", "QSX4",
              "QSX10", "QSX12", "QSX13", "QSX14", "QSY5", "QSY6", "QEZ4", "QEZ5")
SYMMETRIC = {**P61, **{k: 0.0 for k in ASYMMETRIC}}


def _eval(P, pts, mode=211):
    a = np.asarray(pts, dtype=float).reshape(-1, 6)
    return evaluate(P, a[:, 0], a[:, 1], a[:, 2], a[:, 3], a[:, 4], p=a[:, 5], mode=mode)


@settings(max_examples=40, deadline=None)
@given(st.lists(point, min_size=2, max_size=12), st.sampled_from([111, 211, 121]))
def test_batch_equals_points_one_by_one(pts, mode):
    """A point's outputs do not depend on the other points of the call (default solver)."""
    for P in (P61, P62):
        batch = _eval(P, pts, mode)
        for i, pt in enumerate(pts):
            one = _eval(P, [pt], mode)
            for name in ("Fx", "Fy", "Mz", "Mx", "My", "Re", "omega", "Rl", "Cz"):
                assert np.isclose(batch[name][i], one[name][0], rtol=1e-12, atol=1e-12), name


@settings(max_examples=60, deadline=None)
@given(point)
def test_symmetric_tyre_is_odd_in_slip_angle(pt):
    fz, kappa, alpha, _, vx, p = pt
    out = _eval(SYMMETRIC, [(fz, kappa, alpha, 0.0, vx, p), (fz, kappa, -alpha, 0.0, vx, p)])
    scale = max(1.0, abs(out["Fy"][0]))
    assert abs(out["Fy"][0] + out["Fy"][1]) <= 1e-9 * scale
    assert abs(out["Fx"][0] - out["Fx"][1]) <= 1e-9 * max(1.0, abs(out["Fx"][0]))
    assert abs(out["Mz"][0] + out["Mz"][1]) <= 1e-9 * max(1.0, abs(out["Mz"][0]))


@settings(max_examples=40, deadline=None)
@given(point, st.lists(st.floats(-1.0, 1.0), min_size=len(PRESSURE_KEYS),
                       max_size=len(PRESSURE_KEYS)))
def test_pressure_terms_vanish_at_nominal_pressure(pt, coefficients):
    """At p = NOMPRES every pressure coefficient (PPX*, PPY*, PPZ*, PPMX1, QSY8, PFZ1) drops out
    (QSY7 is a load exponent, so it is left as it is)."""
    fz, kappa, alpha, gamma, vx, _ = pt
    P = dict(P61)
    changed = dict(P, **{k: c for k, c in zip(PRESSURE_KEYS, coefficients) if k != "QSY7"})
    x = [(fz, kappa, alpha, gamma, vx, P["NOMPRES"])]
    a, b = _eval(P, x), _eval(changed, x)
    for name in ("Fx", "Fy", "Mz", "Mx", "My", "Re", "rho", "Kya", "Kxk", "2a"):
        assert np.isclose(a[name][0], b[name][0], rtol=1e-12, atol=1e-12), name


@settings(max_examples=30, deadline=None)
@given(slips, angles, cambers, speeds, pressures)
def test_no_load_no_force(kappa, alpha, gamma, vx, p):
    out = _eval(P61, [(0.0, kappa, alpha, gamma, vx, p)])
    assert out["Fx"][0] == 0.0 and out["Fy"][0] == 0.0 and out["mux"][0] == 0.0


def test_negative_load_is_clipped_to_zero():
    out = _eval(P61, [(-500.0, 0.1, 0.1, 0.0, 16.7, 2.5e5)])
    assert out["Fz"][0] == 0.0 and out["Fx"][0] == 0.0


def test_an_mf62_loaded_radius_without_a_root_is_flagged_without_a_warning():
    """MF 6.2 at 9.76 kN and kappa 0.25 (Fx 10.7 kN, beyond the load): the loaded-radius
    secant finds no root. It says so (Rl_converged False) and leaves the other points of the
    call alone, without numpy's RuntimeWarning (found by the batch property above)."""
    pts = [(200.0, 0.0, 0.0, 0.0, 2.0, 1.6e5), (9760.0, 0.25, 0.0, 0.0, 2.0, 1.6e5)]
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        out = _eval(P62, pts, 111)
    assert list(out["Rl_converged"]) == [True, False]
    assert out["Rl"][0] == _eval(P62, pts[:1], 111)["Rl"][0]
