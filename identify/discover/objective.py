"""Least squares for discovery: a problem's residuals, prewhitened, on a subset of points.

Discovery compares nested models with likelihood-ratio/F tests, so every fit here minimises
the sum of squared residuals r = (model - measured)/sigma (sigma: the noise std per point, or
the thesis-metric group weights when the noise is unknown), transformed per sweep by the AR(1)
prewhitening when the noise is correlated. A ``mask`` restricts the fit to training points
(whole sweeps or pressure levels) for held-out errors.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np
from scipy.linalg import qr
from scipy.optimize import lsq_linear

from identify.discover.noise import Sweeps, whiten
from identify.fit.solve.engine import DISCOVERY, fd_jacobian, least_squares
from identify.fit.solve.problem import FitProblem

__all__ = ["Objective", "Solution", "problem_name"]


def problem_name(problem: FitProblem) -> str:
    """The discovery name of a problem (``extra["name"]`` or ``relation/form``)."""
    return str(problem.extra.get("name") or f"{problem.relation}/{problem.form}")


@dataclass(frozen=True)
class Solution:
    """A least-squares solution.

    Attributes
    ----------
    x : ndarray             free parameters (problem.free order)
    r : ndarray             transformed residuals at x (training points)
    jac : ndarray           their Jacobian (n x p)
    rss : float             r @ r
    ok : bool               the solver reported convergence
    stationary : bool       the gradient J^T r is negligible (a minimum, not a stall)
    message : str
    nfev : int
    seconds : float
    """

    x: np.ndarray
    r: np.ndarray
    jac: np.ndarray
    rss: float
    ok: bool
    stationary: bool
    message: str
    nfev: int
    seconds: float


@dataclass(frozen=True)
class Objective:
    """Transformed residuals of ``problem`` on the points of ``mask``.

    Attributes
    ----------
    problem : FitProblem     weighted-least-squares problem (sigma set, or group weights)
    index : Sweeps           sweeps of all points (a list of index arrays is converted)
    phi : float              AR(1) prewhitening coefficient (0: none)
    mask : ndarray or None   training points (bool, all points when None)
    """

    problem: FitProblem
    index: Sweeps
    phi: float = 0.0
    mask: np.ndarray | None = None

    def __post_init__(self) -> None:
        # the sweeps as arrays, and those of the masked points, once (not per evaluation)
        sweeps = Sweeps.of(self.index, self.problem.measured.size)
        object.__setattr__(self, "index", sweeps)
        object.__setattr__(self, "_local", sweeps if self.mask is None
                           else sweeps.subset(self.mask))

    def subset(self, mask: np.ndarray | None) -> Objective:
        return dataclasses.replace(self, mask=mask)

    def transform(self, a: np.ndarray) -> np.ndarray:
        """Restrict (n,) or (n, k) arrays to the mask, then prewhiten."""
        a = a if self.mask is None else a[self.mask]
        return whiten(a, self._local, self.phi) if self.phi else a

    def residuals(self, x: np.ndarray) -> np.ndarray:
        return self.transform(self.problem.residuals(x))

    def columns(self, x: np.ndarray, coefs: dict[str, float],
                rel_step: float = 1e-5) -> np.ndarray:
        """Transformed d r / d c at the coefficients' current values ``coefs`` (their values
        in ``x``'s parameter set): the problem's exact Jacobian when it has one, central
        differences (step rel_step x max(|c|, 1)) otherwise."""
        exact = self.problem.residual_jacobian(x, tuple(coefs))
        if exact is not None:
            return self.transform(exact)
        vals = self.problem.values(x)
        w = self.problem.weights()

        def weighted_model(c: np.ndarray) -> np.ndarray:
            return np.asarray(self.problem.model({**vals, **dict(zip(coefs, c))}),
                              dtype=float) * w

        c0 = np.array(list(coefs.values()), dtype=float)
        return self.transform(fd_jacobian(weighted_model, c0, rel_step=rel_step, floor=1.0))

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Jacobian of the transformed residuals (n x p) at ``x``: exact when the problem has
        one, central differences otherwise."""
        exact = self.problem.residual_jacobian(x)
        if exact is not None:
            return self.transform(exact)
        return fd_jacobian(self.residuals, x, self.problem.bounds(), floor=1e-3)

    def _exact_jacobian(self):
        """The exact Jacobian of the transformed residuals for the solver, or None."""
        if self.problem.jacobian is None:
            return None
        return lambda x: self.transform(self.problem.residual_jacobian(x))

    def identifiable(self, x: np.ndarray, rtol: float = 1e-5) -> np.ndarray:
        """Bool mask of the free parameters the points of this objective determine (pivoted QR
        of the column-normalised Jacobian; the trailing pivots below ``rtol`` are not)."""

        J = self.jacobian(x)
        norms = np.linalg.norm(J, axis=0)
        ok = norms > 0
        keep = np.zeros(x.size, dtype=bool)
        if not ok.any():
            return keep
        _, R, piv = qr(J[:, ok] / norms[ok], mode="economic", pivoting=True)
        d = np.abs(np.diag(R))
        good = piv[:d.size][d > rtol * d[0]]  # fewer points than columns: min(n, k) pivots
        keep[np.flatnonzero(ok)[good]] = True
        return keep

    def solve(self, x0: np.ndarray, max_nfev: int | None = None,
              central: bool = False) -> Solution:
        """Least squares from ``x0`` within the bounds (the engine's solver, DISCOVERY
        tolerances).

        ``central``: a solve that stopped on its tolerances at a point that is not stationary
        on the solver's forward differences is judged on central ones, and solved on with
        them when they agree it is not (the base fits, whose stationarity decides whether
        any candidate is tested; 2 k + 1 evaluations per iteration)."""
        t0 = time.perf_counter()
        est = least_squares(self.residuals, x0, self.problem.bounds(), DISCOVERY,
                            jac=self._exact_jacobian(), max_nfev=max_nfev)
        r, J = est.fun, est.jac
        stationary = self._stationary(est.x, r, J)
        if central and not stationary and est.success and self.problem.jacobian is None:
            # stopped on its tolerances where the forward differences it stepped on still
            # promise a gain: one-sided across the kinks of the E <= 1 limit, they can point
            # nowhere. Judged on central differences, and solved on with them.
            J = self.jacobian(est.x)
            stationary = self._stationary(est.x, r, J)
            if not stationary:
                more = least_squares(self.residuals, est.x, self.problem.bounds(), DISCOVERY,
                                     jac=self.jacobian, max_nfev=CENTRAL_ITERATIONS)
                if float(more.fun @ more.fun) <= float(r @ r):
                    nfev = est.nfev + more.nfev * (1 + 2 * est.x.size)
                    r, J = more.fun, more.jac
                    stationary = self._stationary(more.x, r, J)
                    est = dataclasses.replace(more, nfev=nfev,
                                              success=more.success or stationary)
        return Solution(est.x, r, J, float(r @ r), est.success, stationary, est.message,
                        est.nfev, time.perf_counter() - t0)


    def _stationary(self, x: np.ndarray, r: np.ndarray, jac: np.ndarray) -> bool:
        """Whether ``x`` is a minimum for every test made on it: the gradient is negligible,
        or no Gauss-Newton step within the bounds lowers r^T r by STATIONARY_GAIN residual
        variances, neither on the solver's linearisation nor on the residuals themselves.

        The step is bounded (a parameter on its bound pulled outwards is at its minimum
        there, not stalled) and tried on the residuals when the linearisation promises a
        gain: the Magic Formula's E <= 1 limit makes the objective piecewise smooth, and a
        solve ends on a kink where the solver's one-sided differences promise a gain that
        no step gives."""
        lo, hi = (np.asarray(b, dtype=float) for b in self.problem.bounds())
        grad = np.abs(jac.T @ r)
        scale = np.linalg.norm(jac, axis=0) * max(np.linalg.norm(r), 1e-300)
        if np.all(grad <= 1e-4 * scale + 1e-300):
            return True
        n, k = jac.shape
        if n <= k:
            return False
        s2 = float(r @ r) / (n - k)
        if not s2 > 0:
            return True
        step, gain = bounded_gauss_newton(jac, r, lo - x, hi - x)
        if gain < STATIONARY_GAIN * s2:
            return True
        rss = float(r @ r)
        for t in (1.0, 0.25, 1.0 / 16, 1.0 / 64):
            rt = self.residuals(np.clip(x + t * step, lo, hi))
            if np.all(np.isfinite(rt)) and rss - float(rt @ rt) >= STATIONARY_GAIN * s2:
                return False
        return True


#: A solve whose Gauss-Newton step from the end point would lower the objective by less than
#: this many residual variances s^2 is at its minimum for every test made on it (the score
#: and F tests compare gains of chi^2 3.84 and more): on tens of thousands of noisy real
#: samples a solver stops on its ftol with residuals whose angle to a column is still above
#: the strict gradient test's 1e-4, yet no step could change a conclusion.
STATIONARY_GAIN = 0.1

#: Most iterations of the central-difference solve that follows a solve whose end point is
#: not stationary (each costs 2 k + 1 evaluations of the residuals).
CENTRAL_ITERATIONS = 20


def bounded_gauss_newton(jac: np.ndarray, r: np.ndarray, lo: np.ndarray,
                         hi: np.ndarray) -> tuple[np.ndarray, float]:
    """The Gauss-Newton step d minimising ||r + jac d|| within lo <= d <= hi, and what it
    takes off r^T r on the linearisation (the n x k problem reduced to k x k by QR first)."""
    k = jac.shape[1]
    if k == 0:
        return np.zeros(0), 0.0
    Q, R = np.linalg.qr(jac)
    b = Q.T @ r
    if np.all(np.isinf(lo)) and np.all(np.isinf(hi)):
        step, *_ = np.linalg.lstsq(R, -b, rcond=None)
    else:
        step = lsq_linear(R, -b, bounds=(np.minimum(lo, 0.0), np.maximum(hi, 0.0)),
                          method="bvls").x
    return step, float(b @ b - np.sum((b + R @ step) ** 2))
