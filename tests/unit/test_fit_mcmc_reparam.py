"""The cornering-stiffness map that Fy0's MCMC samples in (identify.fit.mcmc.reparam and its
compiled Newton solve, identify.fit.mcmc.kya_newton): the map equals the model's Kya, its
Jacobian equals finite differences, the inverse returns the coefficients and the
log-determinant of its Jacobian, and the anchors follow the data's pressures and cambers."""
from __future__ import annotations

import numpy as np
import pytest

from identify.fit.mcmc.kya_newton import _jacobian, _values
from identify.fit.mcmc.reparam import ALL_NAMES, KyaRidge, kya_ridge
from identify.model.lateral import fy0
from identify.model.state import prepare
from tests.unit.test_fit_mf_stages import _truth


def _params():
    return dict(_truth())


def _data(pressures_bar=(1.9, 2.5, 3.0), cambers_deg=(-5.0, 0.0, 5.0)):
    """Loads [N], pressures [Pa] and cambers [rad] of a design like the calibration's (21
    points a sweep)."""
    fz, p, g, _ = np.meshgrid([3000.0, 5000.0, 7000.0], np.asarray(pressures_bar) * 1e5,
                              np.deg2rad(cambers_deg), np.arange(21), indexing="ij")
    return fz.ravel(), p.ravel(), g.ravel()


def _ridge(free=ALL_NAMES, **design) -> tuple[KyaRidge, dict]:
    P = _params()
    fz, p, g = _data(**design)
    s = prepare(P, fz, 0 * fz, 0 * fz, g, 16.7 + 0 * fz, p=p)
    x = np.array([P[n] for n in free])
    ridge = kya_ridge(list(free), x, s.fz, P, dpi=s.dpi, gamma_star=s.gamma_star)
    return ridge, P


def test_the_map_is_the_models_cornering_stiffness_at_its_anchors():
    """Kya from KyaRidge equals identify.model.lateral.fy0's kya at each anchor (load,
    pressure, camber) for coefficients away from the truth: rounding only (1e-12)."""
    ridge, P = _ridge()
    assert ridge.names == ALL_NAMES
    rng = np.random.default_rng(3)
    for _ in range(5):
        x = np.array([P[n] for n in ridge.names]) * (1 + 0.2 * rng.standard_normal(7))
        Q = dict(P, **dict(zip(ridge.names, x)))
        fz, dpi, g = (np.array(c) for c in zip(*ridge.anchors))
        gamma = np.deg2rad(5.0) * np.sign(g)  # the design's largest camber
        s = prepare(Q, fz, 0 * fz, 0 * fz, gamma, 16.7 + 0 * fz, p=P["NOMPRES"] * (1 + dpi))
        np.testing.assert_allclose(s.gamma_star, g, rtol=1e-15)
        np.testing.assert_allclose(ridge.forward(x[None, :])[0], fy0(Q, s).kya, rtol=1e-12)


def test_the_jacobian_equals_central_differences_and_the_inverse_returns_the_point():
    """d Kya / d coefficient against central differences (1e-7 relative; the differences'
    truncation error is ~1e-10), and inverse(forward(x)) = x within 1e-9 relative with
    log |det dx/dz| = -log |det dz/dx|, for 200 points scattered 5 % around the truth."""
    ridge, P = _ridge()
    x0 = np.array(ridge.start)
    _, jac = ridge._kya(x0[None, :])
    h = 1e-6 * np.abs(x0)
    fd = np.stack([(ridge._kya((x0 + e)[None, :])[0] - ridge._kya((x0 - e)[None, :])[0])[0]
                   / (2 * hi) for e, hi in zip(np.diag(h), h)], axis=-1)
    np.testing.assert_allclose(jac[0], fd, rtol=1e-7, atol=1e-7 * np.abs(jac).max())
    rng = np.random.default_rng(0)
    x = x0 * (1 + 0.05 * rng.standard_normal((200, 7)))
    back, logdet = ridge.inverse(ridge.forward(x))
    assert np.all(np.isfinite(logdet))
    np.testing.assert_allclose(back, x, rtol=1e-9)
    np.testing.assert_allclose(logdet, -np.linalg.slogdet(ridge._kya(x)[1])[1], rtol=1e-9)


@pytest.mark.parametrize("pressures", [(1.9, 2.5, 3.0), (2.5,)])
def test_the_compiled_newtons_map_and_jacobian_are_the_numpy_ones(pressures):
    """The compiled solve's Kya and d Kya / d coefficient (identify.fit.mcmc.kya_newton, its
    own copy of the arithmetic) equal KyaRidge._kya's at 20 points scattered 20 % around the
    truth, for all seven coefficients and for the five without PPY1, PPY2 (positions not
    contiguous in the full vector): rounding only (1e-13 of the largest entry). A drifted
    Jacobian would only slow Newton's method, which the inverse test cannot see."""
    ridge, _ = _ridge(pressures_bar=pressures)
    pos = np.array([ALL_NAMES.index(n) for n in ridge.names], dtype=np.int64)
    fz, dpi, g = (np.ascontiguousarray(c, dtype=float) for c in zip(*ridge.anchors))
    rng = np.random.default_rng(1)
    p = np.array(ridge.start) * (1 + 0.2 * rng.standard_normal((20, len(pos))))
    kya, jac = ridge._kya(p)
    for row in range(len(p)):
        full = np.array(ridge.fixed)
        full[pos] = p[row]
        val, dk = np.empty(len(pos)), np.empty((len(pos), len(pos)))
        _values(full, fz, dpi, g, ridge.fz0p, ridge.lky, val)
        _jacobian(full, pos, fz, dpi, g, ridge.fz0p, ridge.lky, dk)
        np.testing.assert_allclose(val, kya[row], rtol=0, atol=1e-13 * np.abs(kya[row]).max())
        np.testing.assert_allclose(dk, jac[row], rtol=0, atol=1e-13 * np.abs(jac[row]).max())


def test_a_point_without_a_preimage_gets_zero_density():
    """Kya at the middle load above the chord's reach of a curve through the origin that
    bends down (far outside the data's posterior): no coefficients on the optimum's branch
    give it, so the inverse returns NaN and -inf, and quickly (the compiled row loop)."""
    ridge, _ = _ridge(free=("PKY1", "PKY2", "PKY4"))
    z = ridge.forward(np.array(ridge.start)[None, :])
    z[0, 1] *= 10.0  # Kya at 5 kN ten times Kya at 3 and 7 kN
    x, logdet = ridge.inverse(z)
    assert np.isnan(x).all() and logdet[0] == -np.inf


def test_a_newton_start_where_the_peak_load_factor_is_0_is_given_up_not_raised():
    """A start with PKY2 = 0 (Fz / (Fz0' PKY2) divides by 0): the compiled solve gives the row
    up (residual inf; the inverse then starts it again from the optimum) instead of raising
    ZeroDivisionError in the middle of a chain (numba's default error model)."""
    ridge, _ = _ridge(free=("PKY1", "PKY2", "PKY4"))
    target = ridge.forward(np.array(ridge.start)[None, :])[:, list(ridge.index)]
    p = np.array(ridge.start)[None, :]
    p[0, 1] = 0.0
    _, err = ridge._newton(p, target)
    assert err[0] == np.inf


@pytest.mark.parametrize("pressures, cambers, names", [
    ((1.9, 2.5, 3.0), (-5.0, 0.0, 5.0), ALL_NAMES),
    ((2.5,), (-5.0, 0.0, 5.0), ("PKY1", "PKY2", "PKY4", "PKY3", "PKY5")),
    ((1.9, 2.5, 3.0), (0.0,), ("PKY1", "PKY2", "PKY4", "PPY1", "PPY2")),
    ((2.5,), (0.0,), ("PKY1", "PKY2", "PKY4")),
])
def test_pressure_and_camber_coefficients_are_replaced_only_where_the_data_vary_them(
        pressures, cambers, names):
    """PPY1, PPY2 join the map where the pressures span 5 % of nominal, PKY3, PKY5 where
    |camber| reaches 0.02; the anchors are at measured loads (5/50/95 % quantiles) and
    pressures (the reference is the level nearest nominal)."""
    ridge, _ = _ridge(pressures_bar=pressures, cambers_deg=cambers)
    assert ridge.names == names
    assert ridge.loads == (3000.0, 5000.0, 7000.0)
    dpis = {round(a[1], 6) for a in ridge.anchors}
    nompres = _params()["NOMPRES"]
    assert dpis <= {round(pb * 1e5 / nompres - 1, 6) for pb in pressures} | {0.0}
    if "PPY1" in names:
        assert ridge.labels[0] == "Kya@3000N,2.50bar" and ridge.labels[3] == "Kya@3000N,1.90bar"
    else:
        assert ridge.labels[:3] == ("Kya@3000N", "Kya@5000N", "Kya@7000N")
