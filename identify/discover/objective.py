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

    def solve(self, x0: np.ndarray, max_nfev: int | None = None) -> Solution:
        """Least squares from ``x0`` within the bounds (the engine's solver, DISCOVERY
        tolerances)."""
        t0 = time.perf_counter()
        est = least_squares(self.residuals, x0, self.problem.bounds(), DISCOVERY,
                            jac=self._exact_jacobian(), max_nfev=max_nfev)
        r, J = est.fun, est.jac
        grad = np.abs(J.T @ r)
        scale = np.linalg.norm(J, axis=0) * max(np.linalg.norm(r), 1e-300)
        free_dir = est.active_mask == 0
        stationary = bool(np.all(grad[free_dir] <= 1e-4 * scale[free_dir] + 1e-300)) \
            or _gauss_newton_gain(J[:, free_dir], r) < STATIONARY_GAIN
        return Solution(est.x, r, J, float(r @ r), est.success, stationary, est.message,
                        est.nfev, time.perf_counter() - t0)


#: A solve whose Gauss-Newton step from the end point would lower the objective by less than
#: this many residual variances s^2 is at its minimum for every test made on it (the score
#: and F tests compare gains of chi^2 3.84 and more): on tens of thousands of noisy real
#: samples a solver stops on its ftol with residuals whose angle to a column is still above
#: the strict gradient test's 1e-4, yet no step could change a conclusion.
STATIONARY_GAIN = 0.1


def _gauss_newton_gain(jac: np.ndarray, r: np.ndarray) -> float:
    """What a Gauss-Newton step over the columns of ``jac`` would take off r^T r, in
    residual variances s^2 = r^T r / (n - k) (inf when there are no degrees of freedom)."""
    n, k = jac.shape
    if n <= k:
        return float("inf")
    if k == 0:
        return 0.0
    step, *_ = np.linalg.lstsq(jac, r, rcond=None)
    gain = float(np.sum((jac @ step) ** 2))
    s2 = float(r @ r) / (n - k)
    return gain / s2 if s2 > 0 else 0.0
