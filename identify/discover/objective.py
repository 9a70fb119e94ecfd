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
from scipy import optimize

from identify.discover.noise import whiten
from identify.fit.problem import FitProblem

__all__ = ["Objective", "Solution", "problem_name", "with_free", "with_fixed"]


def problem_name(problem: FitProblem) -> str:
    """The discovery name of a problem (``extra["name"]`` or ``relation/form``)."""
    return str(problem.extra.get("name") or f"{problem.relation}/{problem.form}")


def with_free(problem: FitProblem, values: dict[str, float],
              bounds: dict[str, tuple[float, float]]) -> FitProblem:
    """A copy with the named parameters freed at ``values`` within ``bounds``."""
    P = problem.parameters.copy()
    for k, v in values.items():
        lo, hi = bounds[k]
        P[k].set(value=float(np.clip(v, lo, hi)), vary=True, min=lo, max=hi)
    return dataclasses.replace(problem, parameters=P)


def with_fixed(problem: FitProblem, names: list[str], x: np.ndarray) -> FitProblem:
    """A copy with the named free parameters held at their values in ``x``."""
    P = problem.parameters.copy()
    for k in names:
        P[k].set(value=float(x[problem.free.index(k)]), vary=False)
    return dataclasses.replace(problem, parameters=P)


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
    index : list of ndarray  sweeps (index arrays into all points)
    phi : float              AR(1) prewhitening coefficient (0: none)
    mask : ndarray or None   training points (bool, all points when None)
    """

    problem: FitProblem
    index: list
    phi: float = 0.0
    mask: np.ndarray | None = None

    def subset(self, mask: np.ndarray | None) -> "Objective":
        return dataclasses.replace(self, mask=mask)

    def _local_index(self) -> list[np.ndarray]:
        if self.mask is None:
            return self.index
        pos = np.cumsum(self.mask) - 1
        return [pos[idx[self.mask[idx]]] for idx in self.index if self.mask[idx].any()]

    def transform(self, a: np.ndarray) -> np.ndarray:
        """Restrict (n,) or (n, k) arrays to the mask, then prewhiten."""
        a = a if self.mask is None else a[self.mask]
        return whiten(a, self._local_index(), self.phi) if self.phi else a

    def residuals(self, x: np.ndarray) -> np.ndarray:
        return self.transform(self.problem.residuals(x))

    def columns(self, x: np.ndarray, coefs: dict[str, float],
                rel_step: float = 1e-5) -> np.ndarray:
        """Transformed d r / d c at the coefficients' current values (central differences)."""
        vals = self.problem.values(x)
        w = self.problem.weights()
        cols = []
        for k, c0 in coefs.items():
            h = rel_step * max(1.0, abs(c0))
            with np.errstate(all="ignore"):
                up = np.asarray(self.problem.model({**vals, k: c0 + h}), dtype=float)
                dn = np.asarray(self.problem.model({**vals, k: c0 - h}), dtype=float)
            cols.append((up - dn) / (2 * h) * w)
        G = np.column_stack(cols)
        return self.transform(np.where(np.isfinite(G), G, 0.0))

    def jacobian(self, x: np.ndarray) -> np.ndarray:
        """Forward-difference Jacobian of the transformed residuals (n x p)."""
        r0 = self.residuals(x)
        lo, hi = self.problem.bounds()
        cols = []
        for j in range(x.size):
            h = 1e-6 * max(abs(x[j]), 1e-3)
            h = -h if x[j] + h > hi[j] else h
            xp = x.copy()
            xp[j] += h
            cols.append((self.residuals(xp) - r0) / h)
        return np.column_stack(cols) if cols else np.zeros((r0.size, 0))

    def identifiable(self, x: np.ndarray, rtol: float = 1e-5) -> np.ndarray:
        """Bool mask of the free parameters the points of this objective determine (pivoted QR
        of the column-normalised Jacobian; the trailing pivots below ``rtol`` are not)."""
        from scipy.linalg import qr

        J = self.jacobian(x)
        norms = np.linalg.norm(J, axis=0)
        ok = norms > 0
        keep = np.zeros(x.size, dtype=bool)
        if not ok.any():
            return keep
        _, R, piv = qr(J[:, ok] / norms[ok], mode="economic", pivoting=True)
        d = np.abs(np.diag(R))
        good = piv[d > rtol * d[0]]
        keep[np.flatnonzero(ok)[good]] = True
        return keep

    def solve(self, x0: np.ndarray, max_nfev: int | None = None) -> Solution:
        """Trust-region-reflective least squares from ``x0`` within the bounds."""
        t0 = time.perf_counter()
        lo, hi = self.problem.bounds()
        x0 = np.clip(np.asarray(x0, dtype=float), lo, hi)
        if x0.size == 0:
            r = self.residuals(x0)
            return Solution(x0, r, np.zeros((r.size, 0)), float(r @ r), True, True,
                            "nothing to fit", 1, time.perf_counter() - t0)
        x0 = np.where((x0 == lo) & np.isfinite(hi), x0 + 1e-9 * (hi - lo), x0)
        x0 = np.where((x0 == hi) & np.isfinite(lo), x0 - 1e-9 * (hi - lo), x0)
        res = optimize.least_squares(self.residuals, x0, bounds=(lo, hi), method="trf",
                                     x_scale="jac", ftol=1e-10, xtol=1e-10, gtol=1e-10,
                                     max_nfev=max_nfev or 60 * (x0.size + 1))
        r, J = res.fun, res.jac
        grad = np.abs(J.T @ r)
        scale = np.linalg.norm(J, axis=0) * max(np.linalg.norm(r), 1e-300)
        free_dir = ~(res.active_mask != 0)
        stationary = bool(np.all(grad[free_dir] <= 1e-4 * scale[free_dir] + 1e-300))
        return Solution(res.x, r, J, float(r @ r), bool(res.status > 0), stationary,
                        str(res.message), int(res.nfev), time.perf_counter() - t0)
