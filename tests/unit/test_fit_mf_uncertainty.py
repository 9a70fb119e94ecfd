"""The staged jackknife carries into later stages only what a stage's data determine
(identify.fit.mf.uncertainty._determined, issue 14).

Fx0's slip stiffness Kx = Fz (PKX1 + PKX2 dfz) exp(PKX3 dfz) has d/dPKX3 = PKX1 d/dPKX2 where
PKX2 = 0, so a fit that ends there has two proportional Jacobian columns. The jackknife's step
of a left-out sweep then divides that sweep's score along the pair by a singular value at the
rounding level. On a generated TTC session (seed 9) such steps, 549 in column-scaled
coefficients, carried into Mz0 through s Fx, left 23 of Mz0's 29 coefficients not identifiable.
"""
from __future__ import annotations

import numpy as np

from identify.fit.mf.uncertainty import UNDETERMINED_RCOND, _determined
from identify.fit.solve import engine


def _kx_jacobian(pkx2: float, rng: np.random.Generator) -> np.ndarray:
    """Jacobian (n, 3) of Fz (PKX1 + PKX2 dfz) exp(PKX3 dfz) kappa in (PKX1, PKX2, PKX3) at
    PKX1 = 23, PKX3 = 0.18, on 30 sweeps of 20 points at random loads."""
    dfz = np.repeat(rng.uniform(-0.5, 0.5, 30), 20)
    kappa = np.tile(np.linspace(-0.02, 0.02, 20), 30)
    fz, pkx1, pkx3 = 4000.0 * (1 + dfz), 23.0, 0.18
    e = np.exp(pkx3 * dfz) * fz * kappa
    return np.column_stack([e, dfz * e, (pkx1 + pkx2 * dfz) * dfz * e])


def _sweeps() -> list[np.ndarray]:
    return [np.arange(20 * c, 20 * (c + 1)) for c in range(30)]


def test_steps_along_a_direction_the_data_leave_undetermined_are_not_carried():
    rng = np.random.default_rng(9)
    J = _kx_jacobian(-5e-5, rng)  # where the fit of seed 9 ended
    Js, scale = engine.column_scaled(J)
    sv = np.linalg.svd(Js, compute_uv=False)
    assert sv[-1] ** 2 < UNDETERMINED_RCOND * sv[0] ** 2  # the pair is undetermined
    fun = 50.0 * rng.standard_normal(J.shape[0])
    steps = engine.jackknife_steps(J, fun, _sweeps())
    carried = _determined(J, steps)
    # along the determined directions the steps are kept, along the pair they are gone
    _, _, Vt = np.linalg.svd(Js)
    # (to the rounding of subtracting the large undetermined part)
    np.testing.assert_allclose((carried * scale) @ Vt[:2].T, (steps * scale) @ Vt[:2].T,
                               rtol=0, atol=1e-12 * np.abs(steps * scale).max())
    assert np.abs((carried * scale) @ Vt[2]).max() < 1e-8 * np.abs(carried * scale).max()
    # which were by far the largest
    assert np.abs(steps * scale).max() > 1e3 * np.abs(carried * scale).max()


def test_a_stage_whose_data_determine_every_direction_carries_its_steps_unchanged():
    rng = np.random.default_rng(9)
    J = _kx_jacobian(-1.5, rng)  # the truth: PKX2 and PKX3 both act
    fun = 50.0 * rng.standard_normal(J.shape[0])
    steps = engine.jackknife_steps(J, fun, _sweeps())
    np.testing.assert_array_equal(_determined(J, steps), steps)
