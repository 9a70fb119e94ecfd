"""The solver's SVD through a QR first (identify.fit.solve.trf_svd) gives scipy's decomposition and
scipy's solver the same steps, to round-off."""
from __future__ import annotations

import dataclasses

import numpy as np
import pytest
import scipy.linalg

from identify.fit.solve import engine, trf_svd


def _tall(rng, m, k):
    # columns scaled over 8 decades, as an MF stage's Jacobian
    return rng.standard_normal((m, k)) * np.logspace(0, 8, k)


@pytest.mark.parametrize("shape", [(4096, 24), (300, 7), (40, 10)])
def test_tall_svd_matches_scipy(shape):
    rng = np.random.default_rng(1)
    a = _tall(rng, *shape)
    f = rng.standard_normal(shape[0])
    U, s, vt = scipy.linalg.svd(a, full_matrices=False)
    U2, s2, vt2 = trf_svd.tall_svd(a, full_matrices=False)
    np.testing.assert_allclose(s2, s, rtol=1e-13)
    # singular vectors up to their signs; U^T f with the same signs as V
    sign = np.sign(np.sum(vt * vt2, axis=1))
    np.testing.assert_allclose(vt2 * sign[:, None], vt, atol=1e-10)
    np.testing.assert_allclose(U2.T.dot(f) * sign, U.T @ f,
                               atol=1e-12 * np.linalg.norm(f))


def test_tall_svd_leaves_other_calls_to_scipy():
    a = np.arange(12.0).reshape(4, 3)
    for got, want in ((trf_svd.tall_svd(a), scipy.linalg.svd(a)),
                      (trf_svd.tall_svd(a, full_matrices=False),
                       scipy.linalg.svd(a, full_matrices=False))):
        for x, y in zip(got, want):
            np.testing.assert_array_equal(x, y)
    with pytest.raises(ValueError):  # non-finite input as scipy's check_finite
        trf_svd.tall_svd(np.full((40, 2), np.nan), full_matrices=False)


def test_context_patches_and_restores():
    if not trf_svd.PATCHABLE:
        pytest.skip("this scipy's trf is not the one trf_svd knows")
    from scipy.optimize._lsq import trf
    with trf_svd.qr_svd():
        with trf_svd.qr_svd():
            assert trf.svd is trf_svd.tall_svd
        assert trf.svd is trf_svd.tall_svd
    assert trf.svd is scipy.linalg.svd


def test_scipy_svd_is_back_when_the_solve_raises():
    """A model that raises inside a solve with the QR route (a worker's error, an interrupt)
    leaves scipy's trf with its own svd."""
    if not trf_svd.PATCHABLE:
        pytest.skip("this scipy's trf is not the one trf_svd knows")
    from scipy.optimize._lsq import trf
    patched = []

    def residuals(x):
        patched.append(trf.svd is trf_svd.tall_svd)
        if x[0] > 1.5:
            raise RuntimeError("the model failed")
        return np.r_[x - 2.0, np.zeros(20)]

    with pytest.raises(RuntimeError, match="the model failed"):
        engine.least_squares(residuals, np.ones(1), (np.zeros(1), np.full(1, 10.0)),
                             engine.MF_SOLVE)
    assert patched and all(patched)
    assert trf.svd is scipy.linalg.svd


def test_solve_is_the_same_to_round_off():
    """A bounded nonlinear fit (exponentials, 2000 noisy points) solved with and without the QR
    route ends at the same point to 1e-9 of its scale with the same number of evaluations."""
    if not trf_svd.PATCHABLE:
        pytest.skip("this scipy's trf is not the one trf_svd knows")
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 4.0, 2000)
    truth = np.array([2.0, 1.3, 0.7, 0.4, 0.3])

    def model(x):
        return x[0] * np.exp(-x[1] * t) + x[2] * np.exp(-x[3] * t) + x[4]

    y = model(truth) + 0.01 * rng.standard_normal(t.size)

    def jac(x):
        e1, e2 = np.exp(-x[1] * t), np.exp(-x[3] * t)
        return np.column_stack([e1, -x[0] * t * e1, e2, -x[2] * t * e2, np.ones_like(t)])

    bounds = (np.zeros(5), np.full(5, 10.0))
    x0 = np.array([1.0, 1.0, 1.0, 0.1, 0.0])
    plain = dataclasses.replace(engine.MF_SOLVE, qr_svd=False)
    a = engine.least_squares(lambda x: model(x) - y, x0, bounds, plain, jac=jac)
    b = engine.least_squares(lambda x: model(x) - y, x0, bounds, engine.MF_SOLVE, jac=jac)
    assert a.success and b.success
    assert b.nfev == a.nfev
    np.testing.assert_allclose(b.x, a.x, rtol=1e-9, atol=1e-12)
    np.testing.assert_allclose(a.x, truth, atol=0.2)
