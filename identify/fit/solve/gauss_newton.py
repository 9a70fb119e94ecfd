"""Gauss-Newton steps inside the bounds, taken before scipy's trust-region reflective solver
(identify.fit.solve.engine.least_squares with Tolerances.gauss_newton: the MF stages' solves).

Why: near a noisy optimum in a curved valley, trf spends iterations on its trust region
rather than on the step. When a first full step overshoots, trf shrinks its region to a
fraction of that step and regains it only by doubling, each iteration gaining a fraction of
what the linearised model predicts. Full Gauss-Newton steps in the coefficients scaled to
unit Jacobian columns gain what the model predicts once the iterate is in the quadratic
region, so they reach the same optimum in fewer evaluations (bench/fit_cost.py's nfev column
counts them per stage). The MF stages' optima are interior, where these steps need no bound
handling; a step that would leave the bounds hands over to trf.

The phase (:func:`interior_steps`): at x, the Gauss-Newton step v of the column-scaled
Jacobian (thin SVD by identify.fit.solve.trf_svd.tall_svd, singular values below RCOND x the largest
dropped) and its decrement 0.5 ||P_J r||^2 (the fall of the cost the linearised model
predicts). The phase ends converged when the decrement is below ``noise_ftol`` x s^2 (the
engine's decrement stop, s^2 = r^T r / (n - k); never where a residual is the penalty of a
non-finite model value, identify.fit.solve.problem.penalised, whose s^2 is not the noise's);
otherwise it takes x + t v for the first t of 1, 1/2, 1/4, 1/8 that lowers the cost by at
least ARMIJO x t x 2 x the decrement (the Armijo condition: 2 x decrement is minus the
cost's slope along v). It hands x over to the trust-region solver, which then goes on as
without the phase, when a full step would leave the bounds, none of the four steps lowers
the cost enough (far from the optimum, or at round-off on data without noise), the Jacobian
is not finite or zero, or after ``max_nfev`` evaluations.
"""
from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from identify.fit.solve.covariance import column_scaled, residual_variance
from identify.fit.solve.problem import penalised
from identify.fit.solve.trf_svd import tall_svd

__all__ = ["ARMIJO", "HALVINGS", "RCOND", "Steps", "gauss_newton_step", "interior_steps"]

ARMIJO = 1e-4
"""Fraction of the linear model's fall of the cost that a step must achieve (Armijo)."""
HALVINGS = 3
"""Step lengths tried: 1 and HALVINGS halvings of it."""
RCOND = 1e-12
"""Singular values of the column-scaled Jacobian below RCOND x the largest are dropped from
the step (directions the data do not determine; numpy lstsq's default is ~1e-12 for the
MF stages' shapes)."""


@dataclass(frozen=True)
class Steps:
    """Where the Gauss-Newton phase ended.

    Attributes
    ----------
    x : ndarray            last iterate (free parameters)
    fun : ndarray          residuals at x
    jac : ndarray or None  Jacobian at x (None if not evaluated there)
    nfev, njev : int       residual and Jacobian evaluations of the phase
    converged : bool       the decrement at x is below noise_ftol x s^2
    stopped : str or None  the caller's ``stop`` message, if it ended the phase
    reason : str           why the phase ended (for a hand-over, what the trust-region
                           solver takes over from)
    """

    x: np.ndarray
    fun: np.ndarray
    jac: np.ndarray | None
    nfev: int
    njev: int
    converged: bool
    stopped: str | None
    reason: str

    @property
    def cost(self) -> float:
        """0.5 r^T r at x."""
        return float(0.5 * self.fun @ self.fun)


def gauss_newton_step(J: np.ndarray, r: np.ndarray) -> tuple[np.ndarray, float] | None:
    """(Gauss-Newton step, decrement 0.5 ||P_J r||^2) at a point with Jacobian ``J`` and
    residuals ``r``; None when J is not finite or zero. The phase's steps and the engine's
    decrement stop (identify.fit.solve.engine.Tolerances.decrement_stop)."""
    if not np.isfinite(J).all():
        return None
    Js, norms = column_scaled(J)
    if not Js.any():
        return None
    U, s, vt = tall_svd(Js, full_matrices=False)
    keep = s > RCOND * s[0]
    ur = U.T.dot(r)[keep]
    p = -(vt[keep].T @ (ur / s[keep]))
    return p / norms, 0.5 * float(ur @ ur)


def interior_steps(residuals: Callable[[np.ndarray], np.ndarray],
                   jac: Callable[[np.ndarray], np.ndarray], x0: np.ndarray,
                   lo: np.ndarray, hi: np.ndarray, *, noise_ftol: float, max_nfev: int,
                   stop: Callable[[np.ndarray, float], str | None] | None = None) -> Steps:
    """Gauss-Newton steps from ``x0`` while they stay within [lo, hi] and lower the cost (see
    module).

    Parameters
    ----------
    residuals : callable     x (k,) -> r (n,), weighted residuals [-]
    jac : callable           x -> d r / d x, (n, k), exact
    x0 : ndarray             start, within the bounds
    lo, hi : ndarray         bounds (+/-inf for none)
    noise_ftol : float       convergence: decrement below noise_ftol x s^2
    max_nfev : int           residual evaluations of the phase at most
    stop : callable, optional
        stop(x, cost) after every step, the Jacobian evaluated at x first (as scipy's trf
        calls its callback): a message ends the phase there (engine.least_squares' ``stop``).
    """
    x = np.array(x0, dtype=float)
    r = np.asarray(residuals(x), dtype=float)
    nfev, njev = 1, 0
    if not np.isfinite(r).all():
        return Steps(x, r, None, nfev, njev, False, None, "residuals not finite at the start")
    J = np.asarray(jac(x), dtype=float)
    njev += 1
    n, k = J.shape
    while True:
        cost = 0.5 * float(r @ r)
        step = gauss_newton_step(J, r)
        if step is None:
            return Steps(x, r, J, nfev, njev, False, None, "Jacobian not finite or zero")
        v, decrement = step
        if not penalised(r) and decrement < noise_ftol * residual_variance(cost, n, k):
            return Steps(x, r, J, nfev, njev, True, None, "decrement")
        if not np.all((x + v >= lo) & (x + v <= hi)):
            return Steps(x, r, J, nfev, njev, False, None, "a full step leaves the bounds")
        for t in 0.5 ** np.arange(HALVINGS + 1):
            if nfev >= max_nfev:
                return Steps(x, r, J, nfev, njev, False, None, "budget")
            x_new = x + t * v
            r_new = np.asarray(residuals(x_new), dtype=float)
            nfev += 1
            if 0.5 * float(r_new @ r_new) <= cost - ARMIJO * t * 2.0 * decrement:
                break
        else:
            return Steps(x, r, J, nfev, njev, False, None, "no step lowers the cost enough")
        x, r = x_new, r_new
        J = np.asarray(jac(x), dtype=float)
        njev += 1
        if stop is not None:
            message = stop(x, 0.5 * float(r @ r))
            if message is not None:
                return Steps(x, r, J, nfev, njev, False, message, "stopped")
