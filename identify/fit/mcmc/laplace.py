"""The Laplace approximation of an MCMC posterior and the independence move built on it.

identify.fit.mcmc.chains samples half of its steps with :class:`LaplaceMove` (independence
Metropolis-Hastings proposals from a Student t around the likelihood's maximum with the
covariance sigma^2 (J'J)^-1 of the noise-weighted model) and starts its walkers drawn from the
approximation (:func:`laplace_start`). The posterior object is identify.fit.mcmc.chains's
``_Posterior`` (its ``_predict``, ``meas``, ``w``, ``lo``, ``hi``, ``problem``).
"""
from __future__ import annotations

from typing import TYPE_CHECKING

import emcee
import numpy as np

from identify.fit.mcmc.reparam import KyaRidge
from identify.fit.solve.engine import LAPLACE, least_squares
from identify.fit.solve.problem import FitProblem

if TYPE_CHECKING:  # pragma: no cover
    from identify.fit.mcmc.chains import _Posterior

__all__ = ["LaplaceMove", "laplace", "laplace_start", "likelihood_mode", "sigma0",
           "weighted_jacobian"]


MODE_NFEV = 30
"""Budget of :func:`likelihood_mode`'s least-squares solve [residual evaluations]."""


def _rms(r: np.ndarray) -> float:
    """RMS of the noise-weighted residuals ``r`` (1 for none), at least 1e-12: the noise
    level sigma at the optimum."""
    return max(float(np.sqrt(np.mean(r ** 2))) if r.size else 1.0, 1e-12)


def sigma0(problem: FitProblem, xb: np.ndarray) -> float:
    """RMS of the finite noise-weighted residuals at ``xb`` (the noise level's starting
    value)."""
    r = (problem.predict(xb) - problem.measured) * problem.noise_weights(xb)
    return _rms(r[np.isfinite(r)])


def weighted_jacobian(posterior: _Posterior, x: np.ndarray,
                      h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Noise-weighted residuals (n,) at x and their Jacobian (n, k) by central differences
    (steps h), the 2k + 1 points in one model call."""
    k = x.size
    rows = np.concatenate([x + np.diag(h), x - np.diag(h), x[None, :]])
    pred = posterior._predict(np.column_stack([rows, np.zeros(2 * k + 1)]))
    r = (pred[-1] - posterior.meas) * posterior.w
    return r, ((pred[:k] - pred[k:2 * k]) * posterior.w / (2 * h[:, None])).T


def likelihood_mode(posterior: _Posterior, xb: np.ndarray, h: np.ndarray) -> np.ndarray:
    """The maximum of the MCMC likelihood near the least-squares optimum ``xb`` (their
    weights can differ, e.g. the MF stages' per-sweep residual noise levels): a few bounded
    Gauss-Newton (trust-region, identify.fit.solve.engine.least_squares) steps on the
    noise-weighted residuals; ``xb`` if that does not improve."""
    def residuals(x):
        return (posterior._predict(np.r_[x, 0.0][None, :])[0] - posterior.meas) * posterior.w

    lo, hi = posterior.lo, posterior.hi
    x0 = np.clip(xb, lo, hi)  # xb itself: a fit's optimum lies within its bounds
    r0 = residuals(x0)
    ok = np.isfinite(r0)

    def fun(x):
        return np.nan_to_num(residuals(x)[ok], nan=1e30)

    def jac(x):
        return np.nan_to_num(weighted_jacobian(posterior, x, h)[1][ok], nan=0.0)

    try:
        sol = least_squares(fun, x0, (lo, hi), LAPLACE, jac=jac, max_nfev=MODE_NFEV)
    except (ValueError, np.linalg.LinAlgError):
        return xb
    better = np.all(np.isfinite(sol.x)) and 2 * sol.cost < np.sum(r0[ok] ** 2)
    return sol.x if better else xb


def laplace(posterior: _Posterior, xb: np.ndarray,
            reparam: KyaRidge | None) -> tuple[np.ndarray, np.ndarray] | None:
    """The Laplace approximation of the posterior (sigma profiled) in the sampled coordinates.

    Mean (k + 1,) = [the likelihood's maximum near the optimum ``xb`` (:func:`likelihood_mode`;
    mapped by ``reparam``), log sigma]; covariance sigma^2 (J'J)^-1 n / (n - k) from central
    differences of the noise-weighted model (J of this posterior's likelihood), log sigma's
    variance 1/(2(n - k)). None when it is not usable (non-finite, not positive definite)."""
    k, n = xb.size, posterior.meas.size
    if k == 0:
        return None
    lo, hi = posterior.lo, posterior.hi
    span = np.where(np.isfinite(hi - lo), hi - lo, np.inf)
    h = 6e-6 * np.maximum(np.abs(xb), np.minimum(1e-3 * span, 1.0))
    xb = likelihood_mode(posterior, xb, h)
    r, jac = weighted_jacobian(posterior, xb, h)
    ok = np.isfinite(r) & np.isfinite(jac).all(axis=1)
    s0 = _rms(r[ok])
    jac = jac[ok]
    if reparam is not None:  # d x / d z = (d z / d x)^-1 at the optimum
        rows = np.concatenate([xb + np.diag(h), xb - np.diag(h)])
        zrows = reparam.forward(rows)
        dz = ((zrows[:k] - zrows[k:]) / (2 * h[:, None])).T                   # (k, k)
        try:
            jac = jac @ np.linalg.inv(dz)
        except np.linalg.LinAlgError:
            return None
        xb = reparam.forward(xb[None, :])[0]
    fisher = jac.T @ jac
    d = np.sqrt(np.diag(fisher))  # scaled to unit diagonal: the check is on correlations,
    if not (np.all(np.isfinite(d)) and np.all(d > 0)):  # not on the coefficients' units
        return None
    try:
        vals, vecs = np.linalg.eigh(fisher / np.outer(d, d))
    except np.linalg.LinAlgError:
        return None
    if not (np.all(np.isfinite(vals)) and vals.min() > 1e-12 * vals.max() > 0):
        return None
    cov = np.zeros((k + 1, k + 1))
    cov[:k, :k] = (s0 ** 2 * n / max(n - k, 1)) * ((vecs / vals) @ vecs.T) / np.outer(d, d)
    cov[k, k] = 1.0 / (2 * max(n - k, 1))
    return np.r_[xb, np.log(s0)], cov


class LaplaceMove(emcee.moves.MHMove):
    """Independence Metropolis-Hastings move: every walker proposes a draw of a fixed
    multivariate Student t (``df``) around the Laplace approximation (``mean``, ``cov``
    widened by ``scale``^2) and accepts it with the proposal-density ratio, so the target is
    left exactly invariant whatever the approximation's error (which only lowers the
    acceptance). Where the posterior is close to Gaussian, successive draws are nearly
    independent: autocorrelation times of a few steps where differential evolution needs
    ~2-3 per dimension."""

    def __init__(self, mean: np.ndarray, cov: np.ndarray, scale: float = 1.2,
                 df: float = 20.0):
        self.mean = np.asarray(mean, dtype=float)
        self.scale = float(scale)
        self.chol = np.linalg.cholesky(scale ** 2 * np.asarray(cov, dtype=float))
        self.df = float(df)
        super().__init__(self._propose, ndim=self.mean.size)

    def log_q(self, x: np.ndarray) -> np.ndarray:
        """Log proposal density (up to a constant) of rows x (W, ndim)."""
        u = np.linalg.solve(self.chol, (x - self.mean).T)
        return -0.5 * (self.df + self.mean.size) * np.log1p(np.sum(u * u, axis=0) / self.df)

    def draw(self, n: int, random) -> np.ndarray:
        """n draws (n, ndim) of the proposal with numpy RandomState ``random``."""
        z = random.standard_normal((n, self.mean.size))
        w = random.chisquare(self.df, n) / self.df
        return self.mean + (z @ self.chol.T) / np.sqrt(w)[:, None]

    def _propose(self, coords: np.ndarray, random):
        new = self.draw(coords.shape[0], random)
        return new, self.log_q(coords) - self.log_q(new)


def laplace_start(posterior: _Posterior, move: LaplaceMove, nw: int,
                  random) -> np.ndarray | None:
    """Walkers drawn from the Laplace approximation (the move's proposal without its widening
    ``scale``; a start close to the stationary spread needs no burn-in to grow from a small
    ball), those outside the support drawn again; None if fewer than nw land inside in 5
    tries."""
    keep = []
    narrow = LaplaceMove(move.mean, move.chol @ move.chol.T, scale=1 / move.scale, df=1e6)
    for _ in range(5):
        cand = narrow.draw(2 * nw, random)
        lp = posterior(cand)
        lp = lp[:, 0] if lp.ndim == 2 else lp
        keep += list(cand[np.isfinite(lp)])
        if len(keep) >= nw:
            return np.array(keep[:nw])
    return None
