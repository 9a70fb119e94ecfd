"""MCMC uncertainty for a fitted problem (emcee), kept apart from the least-squares optimum.

Posterior: uniform priors on the parameter bounds (flat where a bound is open), uniform prior
on log(sigma), Gaussian likelihood of the weighted residuals r_i = w_i (model_i - meas_i) with
the noise level sigma as a parameter, w_i from the problem's noise model
(FitProblem.noise_weights: the relations' characteristics have relative noise, sigma the noise
level as a fraction; the MF stages' channels noise relative to each sweep's RMS); optionally
AR(1) noise along each sweep (innovations
e_t - phi e_(t-1) ~ N(0, sigma^2), stationary start), phi in (-0.99, 0.99).

Walkers >= max(32, 2 x parameters); the chain runs in chunks until it is longer than 50
autocorrelation times (or ``max_steps``); the first 3 tau are discarded and the chain thinned by
tau/2. All walkers are evaluated in one vectorised call when the model broadcasts over
parameter arrays of shape (walkers, 1).

Moves: differential evolution (emcee.moves.DEMove) by default. It is affine-invariant like
emcee's stretch move, but its autocorrelation time grows far more slowly with the dimension:
measured on the 18-coefficient Fx0 stage tau ~ 60 steps against ~ 500 for the stretch move,
and about half the stretch move's tau on the 2-4 parameter relations, so the 50-tau rule is
met in a fraction of the steps. ``moves="stretch"`` keeps emcee's default. emcee's
DESnookerMove is not used: in emcee 3.1.6 it scales its step by the distance to the anchor
walker (u = delta/sqrt(|delta|) instead of delta/|delta|) and so does not sample the target
(a unit Gaussian in 19 dimensions comes out with variance 0.56 alone, 0.79 as 20 % of a mix
with DE; tests/test_fit_mcmc.py checks the posterior width against a linear problem's exact
one).
"""
from __future__ import annotations

import dataclasses
import time
from pathlib import Path

import emcee
import numpy as np

from identify.fit.engine import problem_covariance
from identify.fit.problem import FitProblem
from identify.fit.result import FitResult, MCMCSummary

TAU_FACTOR = 50
CHUNK = 500
MAX_STEPS = 40000
"""Default cap on a chain [steps] (it stops earlier, at 50 tau)."""
MOVES = ("de", "stretch")


def _moves(name: str):
    if name == "de":
        return emcee.moves.DEMove()
    if name == "stretch":
        return None  # emcee's default StretchMove
    raise ValueError(f"moves must be one of {MOVES}, not {name!r}")


def _innovations(r: np.ndarray, phi: np.ndarray, starts: np.ndarray) -> tuple[np.ndarray, ...]:
    """AR(1) innovations along sweeps for residual rows r (W, n) and phi (W, 1)."""
    e = r.copy()
    e[:, 1:] = r[:, 1:] - phi * r[:, :-1]
    e[:, starts] = r[:, starts] * np.sqrt(1 - phi ** 2)
    return e


class _Posterior:
    def __init__(self, problem: FitProblem, ar1: bool):
        self.problem = problem
        self.free = problem.free
        self.lo, self.hi = problem.bounds()
        self.w = problem.noise_weights()
        self.meas = problem.measured
        self.ar1 = ar1
        sweeps = problem.sweeps if problem.sweeps is not None else np.zeros(self.meas.size)
        sweeps = np.asarray(sweeps)
        self.starts = np.flatnonzero(np.r_[True, sweeps[1:] != sweeps[:-1]])
        self.vectorised = True

    def _predict(self, theta: np.ndarray) -> np.ndarray:
        k = len(self.free)
        base = self.problem.values()
        if self.vectorised:
            vals = dict(base, **{n: theta[:, i:i + 1] for i, n in enumerate(self.free)})
            try:
                pred = np.asarray(self.problem.model(vals), dtype=float)
                if pred.shape == (theta.shape[0], self.meas.size):
                    return pred
            except Exception:  # noqa: BLE001 - model does not broadcast: fall back below
                pass
            self.vectorised = False
        return np.array([self.problem.model(dict(base, **dict(zip(self.free, row[:k]))))
                         for row in theta])

    def __call__(self, theta: np.ndarray) -> np.ndarray:
        theta = np.atleast_2d(theta)
        k = len(self.free)
        x = theta[:, :k]
        log_sigma = theta[:, k]
        out = np.full(theta.shape[0], -np.inf)
        ok = np.all((x >= self.lo) & (x <= self.hi), axis=1) & (np.abs(log_sigma) < 50)
        if self.ar1:
            phi = theta[:, k + 1]
            ok &= np.abs(phi) < 0.99
        if not ok.any():
            return out
        pred = self._predict(theta[ok])
        r = (pred - self.meas) * self.w
        sigma = np.exp(log_sigma[ok])[:, None]
        if self.ar1:
            r = _innovations(r, phi[ok][:, None], self.starts)
            extra = 0.5 * np.log(1 - phi[ok] ** 2) * self.starts.size
        else:
            extra = 0.0
        n = self.meas.size
        ll = -0.5 * np.sum((r / sigma) ** 2, axis=1) - n * np.log(sigma[:, 0]) + extra
        out[ok] = np.where(np.isfinite(ll), ll, -np.inf)
        return out


def run_mcmc(problem: FitProblem, result: FitResult, *, seed: int = 0, ar1: bool = False,
             n_walkers: int | None = None, max_steps: int = MAX_STEPS,
             chain_file: str | Path | None = None, moves: str = "de") -> FitResult:
    """Sample the posterior around a least-squares result; return the result with ``mcmc`` set.

    Parameters
    ----------
    problem, result : FitProblem, FitResult
        The problem and its optimum (the starting point; it is not changed).
    seed : int
        Seeds the walkers' start and emcee's generator.
    ar1 : bool
        AR(1) noise along ``problem.sweeps``.
    chain_file : path, optional
        Save the chain to this HDF5 file (emcee HDFBackend, group ``mcmc``).
    moves : str
        ``"de"`` (differential evolution, the default) or ``"stretch"``.
    """
    t0 = time.perf_counter()
    move_list = _moves(moves)
    free = problem.free
    k = len(free)
    xb = np.array([result.parameters[n] for n in free])
    r = (problem.predict(xb) - problem.measured) * problem.noise_weights()
    r = r[np.isfinite(r)]
    sigma0 = max(float(np.sqrt(np.mean(r ** 2))) if r.size else 1.0, 1e-12)
    ndim = k + 1 + int(ar1)
    nw = max(32, 2 * ndim, n_walkers or 0)
    nw += nw % 2
    rng = np.random.default_rng(seed)
    sd = (np.sqrt(np.clip(np.diag(problem_covariance(problem, xb)), 0, None)) if k
          else np.zeros(0))
    lo, hi = problem.bounds()
    span = np.where(np.isfinite(hi - lo), hi - lo, np.maximum(np.abs(xb), 1.0))
    scale = np.where(sd > 0, sd, 1e-4 * span)
    p0 = np.empty((nw, ndim))
    p0[:, :k] = xb + 0.1 * scale * rng.standard_normal((nw, k))
    # keep the start inside the prior box (reflect off bounds)
    p0[:, :k] = np.clip(p0[:, :k], lo + 1e-9 * span, hi - 1e-9 * span)
    p0[:, k] = np.log(sigma0) + 0.01 * rng.standard_normal(nw)
    if ar1:
        p0[:, k + 1] = 0.5 + 0.01 * rng.standard_normal(nw)
    backend = None
    if chain_file is not None:
        backend = emcee.backends.HDFBackend(str(chain_file), name="mcmc")
        backend.reset(nw, ndim)
    posterior = _Posterior(problem, ar1)
    sampler = emcee.EnsembleSampler(nw, ndim, posterior, vectorize=True, backend=backend,
                                    moves=move_list)
    sampler.random_state = np.random.RandomState(seed).get_state()
    state = p0
    steps = 0
    tau = np.full(ndim, np.inf)
    while steps < max_steps:
        state = sampler.run_mcmc(state, CHUNK, progress=False)
        steps += CHUNK
        tau = sampler.get_autocorr_time(tol=0)
        if np.all(np.isfinite(tau)) and steps > TAU_FACTOR * np.max(tau):
            break
    tau_max = float(np.max(tau)) if np.all(np.isfinite(tau)) else float(steps) / TAU_FACTOR
    discard = int(np.ceil(3 * tau_max))
    thin = max(1, int(tau_max / 2))
    flat = sampler.get_chain(discard=discard, thin=thin, flat=True)
    names = list(free) + ["log_sigma"] + (["phi"] if ar1 else [])
    q = np.quantile(flat, [0.025, 0.16, 0.5, 0.84, 0.975], axis=0)
    corr_m = np.corrcoef(flat[:, :k], rowvar=False) if k > 1 else np.ones((k, k))
    corr = {f"{free[i]}|{free[j]}": float(corr_m[i, j]) for i in range(k) for j in range(i + 1, k)}
    noise = {"sigma": float(np.exp(q[2, k]))}
    if ar1:
        noise["phi"] = float(q[2, k + 1])
    n_eff = int(nw * (steps - discard) / max(tau_max, 1.0))
    summary = MCMCSummary(
        median={n: float(q[2, i]) for i, n in enumerate(free)},
        q16={n: float(q[1, i]) for i, n in enumerate(free)},
        q84={n: float(q[3, i]) for i, n in enumerate(free)},
        q025={n: float(q[0, i]) for i, n in enumerate(free)},
        q975={n: float(q[4, i]) for i, n in enumerate(free)},
        tau={n: float(t) for n, t in zip(names, tau)},
        acceptance=float(np.mean(sampler.acceptance_fraction)), n_walkers=nw, n_steps=steps,
        n_discard=discard, n_thin=thin, n_samples=n_eff, correlations=corr, noise=noise,
        seed=seed, converged=bool(np.all(np.isfinite(tau)) and steps > TAU_FACTOR * tau_max),
        seconds=time.perf_counter() - t0,
        chain_file=None if chain_file is None else str(chain_file),
        samples=flat[:, :k])
    return dataclasses.replace(result, mcmc=summary)
