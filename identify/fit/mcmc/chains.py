"""MCMC uncertainty for a fitted problem (emcee), kept apart from the least-squares optimum.

Posterior: uniform priors on the parameter bounds (flat where a bound is open), uniform prior
on log(sigma), Gaussian likelihood of the weighted residuals r_i = w_i (model_i - meas_i) with
the noise level sigma as a parameter, w_i from the problem's noise model
(FitProblem.noise_weights: the relations' characteristics have relative noise, sigma the noise
level as a fraction; the MF stages' noise level per sweep from the least-squares residuals,
"sweep-residual"); optionally
AR(1) noise along each sweep (innovations e_t - phi e_(t-1) ~ N(0, sigma^2), stationary
start), phi in (-0.99, 0.99).

Walkers >= max(32, 2 x parameters); the chain runs until it is longer than 50 autocorrelation
times (estimated after 250 steps, then where the last estimate says 50 tau is reached), the
step cap ``max_steps`` or the time ``budget``; the first 3 tau are discarded and the chain
thinned by tau/2. All walkers are evaluated in one vectorised call when the model broadcasts
over parameter arrays of shape (walkers, 1). The chain is sampled in memory and written to
its HDF5 file (emcee's layout) once, at the end.

Moves (``moves="de+laplace"``, the default): half of the steps differential evolution
(emcee.moves.DEMove), half independence Metropolis-Hastings proposals from the Laplace
approximation of this posterior (:class:`LaplaceMove`: a Student t around the likelihood's
own maximum, reached from the least-squares optimum by a few Gauss-Newton steps, with
covariance sigma^2 (J'J)^-1 from the noise-weighted model), and the walkers start drawn from
that approximation instead of a small ball, so there is no burn-in to grow out of. Both moves
leave the posterior exactly invariant; the approximation only decides how fast the chain
mixes. Differential evolution is affine-invariant (whitening the coordinates changes nothing
for it), and its autocorrelation time grows with the dimension and with the posterior's
curvature; where the posterior is close to Gaussian the Laplace proposals are nearly
independent draws, and the chain then mixes within a few steps, not growing with the
dimension (bench/mcmc_chains.py prints each chain's tau of an ``mfid fit --mcmc`` run).
``moves="de"`` is differential evolution alone from a small ball, ``"stretch"`` emcee's
default; with AR(1) noise ``"de+laplace"`` is ``"de"`` (phi has no Laplace approximation
here). emcee's DESnookerMove is not used: in emcee 3.1.6 it scales its step by the distance
to the anchor walker (u = delta/sqrt(|delta|) instead of delta/|delta|) and so does not
sample the target (a unit Gaussian in 19 dimensions comes out with variance 0.56 alone,
0.79 as 20 % of a mix with DE; tests/integration/test_fit_mcmc.py checks the posterior width against
a linear problem's exact one).
"""
from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable
from pathlib import Path

import emcee
import numpy as np

from identify.fit.mcmc.laplace import LaplaceMove, laplace, laplace_start, sigma0
from identify.fit.mcmc.reparam import KyaRidge
from identify.fit.mcmc.steps import TAU_FACTOR, ChainProgress, run_chain
from identify.fit.result import FitResult, MCMCSummary
from identify.fit.solve.engine import problem_covariance
from identify.fit.solve.problem import FitProblem

MAX_STEPS = 40000
"""Default cap on a chain [steps] (it stops earlier, at 50 tau)."""
BUDGET_S = 900.0
"""Default wall-time budget of the whole MCMC run of one fit, all chains together [s]
(``mfid fit --mcmc-budget``; identify.workflows.fit shares it out between the chains): with
the fit itself and the report it keeps ``mfid fit --mcmc`` of the bundled sample under 20
minutes on 2 cores."""
MOVES = ("de+laplace", "de", "stretch")
LAPLACE_SHARE = 0.5
"""Share of the steps that are LaplaceMove proposals with ``moves="de+laplace"``."""


def _moves(name: str, laplace: LaplaceMove | None):
    """emcee's moves for ``name`` (one of MOVES, checked by run_mcmc)."""
    if name == "stretch":
        return None  # emcee's default StretchMove
    if name == "de+laplace" and laplace is not None:
        return [(emcee.moves.DEMove(), 1 - LAPLACE_SHARE), (laplace, LAPLACE_SHARE)]
    return emcee.moves.DEMove()


def _innovations(r: np.ndarray, phi: np.ndarray, starts: np.ndarray) -> np.ndarray:
    """AR(1) innovations along sweeps for residual rows r (W, n) and phi (W, 1)."""
    e = r.copy()
    e[:, 1:] = r[:, 1:] - phi * r[:, :-1]
    e[:, starts] = r[:, starts] * np.sqrt(1 - phi ** 2)
    return e


class _Posterior:
    """Log posterior of [sampled free coordinates, log sigma, (phi)] rows; with ``reparam``
    the sampled coordinates are mapped to the free vector and the log-Jacobian is added, so
    that the prior stays flat in the free coefficients, and each row comes back as [log
    posterior, the mapped coefficients, log-Jacobian] (emcee keeps the last ones as blobs)."""

    def __init__(self, problem: FitProblem, ar1: bool, reparam: KyaRidge | None = None,
                 xb: np.ndarray | None = None):
        self.problem = problem
        self.reparam = reparam
        self.free = problem.free
        self.lo, self.hi = problem.bounds()
        self.w = problem.noise_weights(xb)  # xb: the optimum, for residual noise levels
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
        log_jac = 0.0
        if self.reparam is not None:
            x, log_jac = self.reparam.inverse(x)
            theta = np.column_stack([x, theta[:, k:]])
        log_sigma = theta[:, k]
        out = np.full(theta.shape[0], -np.inf)
        with np.errstate(invalid="ignore"):  # NaN rows (no inverse) fail the bounds
            ok = np.all((x >= self.lo) & (x <= self.hi), axis=1) & (np.abs(log_sigma) < 50)
        if self.ar1:
            phi = theta[:, k + 1]
            ok &= np.abs(phi) < 0.99
        if not ok.any():
            return self._out(out, x, log_jac)
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
        if self.reparam is not None:
            ll = ll + log_jac[ok]
        out[ok] = np.where(np.isfinite(ll), ll, -np.inf)
        return self._out(out, x, log_jac)

    def _out(self, lp: np.ndarray, x: np.ndarray, log_jac) -> np.ndarray:
        if self.reparam is None:
            return lp
        return np.column_stack([lp, x[:, list(self.reparam.index)], log_jac])


def _start(problem: FitProblem, result: FitResult, ar1: bool, nw: int, ndim: int,
           rng: np.random.Generator) -> np.ndarray:
    """Walkers in a small ball (0.1 standard error) around the optimum, inside the bounds."""
    free = problem.free
    k = len(free)
    xb = np.array([result.parameters[n] for n in free])
    s0 = sigma0(problem, xb)
    sd = (np.sqrt(np.clip(np.diag(problem_covariance(problem, xb)), 0, None)) if k
          else np.zeros(0))
    lo, hi = problem.bounds()
    span = np.where(np.isfinite(hi - lo), hi - lo, np.maximum(np.abs(xb), 1.0))
    scale = np.where(sd > 0, sd, 1e-4 * span)
    p0 = np.empty((nw, ndim))
    p0[:, :k] = xb + 0.1 * scale * rng.standard_normal((nw, k))
    p0[:, :k] = np.clip(p0[:, :k], lo + 1e-9 * span, hi - 1e-9 * span)
    p0[:, k] = np.log(s0) + 0.01 * rng.standard_normal(nw)
    if ar1:
        p0[:, k + 1] = 0.5 + 0.01 * rng.standard_normal(nw)
    return p0


def _write_chain_file(path, sampler, reparam: KyaRidge | None) -> None:
    """Save the chain once it has run, as emcee's HDFBackend lays it out (group ``mcmc``;
    ``emcee.backends.HDFBackend(path, name="mcmc", read_only=True)`` reads it): sampling into
    the file directly opens it at every step, which costs several times the sampling of a
    relation.
    With ``reparam`` the chain is in the free coefficients (the blobs: the mapped ones and the
    log-Jacobian) and its log-probabilities are the posterior density in them, so that the
    file is in the names the report labels it with."""
    chain = sampler.get_chain()
    log_prob = sampler.get_log_prob()
    blobs = sampler.get_blobs()
    if reparam is not None:
        chain = chain.copy()
        n = len(reparam.index)
        chain[..., list(reparam.index)] = blobs[..., :n]
        log_prob = log_prob - blobs[..., n]
    nw, ndim = chain.shape[1:]
    backend = emcee.backends.HDFBackend(str(path), name="mcmc")
    backend.reset(nw, ndim)
    backend.grow(chain.shape[0], None if blobs is None else blobs[0])
    with backend.open("a") as f:
        g = f["mcmc"]
        g["chain"][...] = chain
        g["log_prob"][...] = log_prob
        if blobs is not None:
            g["blobs"][...] = blobs
        g["accepted"][...] = sampler.backend.accepted
        for i, v in enumerate(sampler.random_state):
            g.attrs[f"random_state_{i}"] = v
        g.attrs["iteration"] = chain.shape[0]


def _chain(sampler, reparam: KyaRidge | None, discard: int = 0, thin: int = 1) -> np.ndarray:
    """The flat chain in the free coefficients (mapped back from the sampled coordinates)."""
    c = sampler.get_chain(discard=discard, thin=thin)
    if reparam is not None:
        c = c.copy()
        c[..., list(reparam.index)] = sampler.get_blobs(discard=discard,
                                                       thin=thin)[..., :len(reparam.index)]
    return c.reshape(-1, c.shape[-1])


class ChainSession:
    """Keeps a chain that a time budget stopped so that ``run_mcmc(..., session=...)`` can
    continue it later with more time (identify.workflows.fit gives the budget the other
    chains left to the chains it stopped). Empty until the first run; the caller only passes
    it back."""

    def __init__(self):
        self.sampler = None
        self.state = None
        self.steps = 0
        self.tau = None
        self.seconds = 0.0
        self.tau_fn = None


def run_mcmc(problem: FitProblem, result: FitResult, *, seed: int = 0, ar1: bool = False,
             n_walkers: int | None = None, max_steps: int = MAX_STEPS,
             budget: float | None = None, chain_file: str | Path | None = None,
             moves: str = "de+laplace", reparam: KyaRidge | None = None,
             progress: Callable[[ChainProgress], None] | None = None,
             session: ChainSession | None = None) -> FitResult:
    """Sample the posterior around a least-squares result; return the result with ``mcmc`` set.

    Parameters
    ----------
    problem, result : FitProblem, FitResult
        The problem and its optimum (the starting point; it is not changed).
    seed : int
        Seeds the walkers' start and emcee's generator.
    ar1 : bool
        AR(1) noise along ``problem.sweeps``.
    max_steps : int
        Cap on the chain [steps].
    budget : float, optional
        Time budget of this chain [s] (``mfid fit`` gives each chain its share of the whole
        run's budget). The chain stops at 50 tau, ``max_steps`` or the budget,
        whichever comes first; stopped early, the summary says ``converged = False`` and
        ``stopped`` why.
    chain_file : path, optional
        Save the chain to this HDF5 file (emcee HDFBackend, group ``mcmc``), in the free
        coefficients (also with ``reparam``).
    moves : str
        ``"de+laplace"`` (the default: differential evolution and, half of the steps,
        independence proposals from the Laplace approximation at the optimum, :class:
        `LaplaceMove`; the walkers start drawn from that approximation), ``"de"``
        (differential evolution alone, from a small ball around the optimum) or
        ``"stretch"``. With ``ar1``, ``"de+laplace"`` is ``"de"``.
    reparam : KyaRidge, optional
        Sample these coordinates instead of some free coefficients (identify.fit.
        mcmc_reparam); the prior stays flat in the coefficients.
    progress : callable, optional
        Called with a :class:`ChainProgress` about once a second and when the chain stops.
    session : ChainSession, optional
        Keep the chain in it; passed again (same problem and settings), the chain it holds
        continues from where it stopped, with this call's ``budget`` (steps and seconds
        count from the first call).
    """
    t0 = time.perf_counter()
    if session is not None and session.sampler is not None:
        # emcee's memory backend grew by the whole last chunk; a chain stopped inside it has
        # spare rows that a shorter next chunk would make negative (np.empty in grow)
        b = session.sampler.backend
        b.chain, b.log_prob = b.chain[:b.iteration], b.log_prob[:b.iteration]
        if b.blobs is not None:
            b.blobs = b.blobs[:b.iteration]
        return _summary(problem, result, session, seed, ar1, reparam, chain_file, *run_chain(
            session.sampler, session.state, max_steps, budget, progress, t0, session.tau_fn,
            session.steps, session.tau), t0=t0)
    if moves not in MOVES:
        raise ValueError(f"moves must be one of {MOVES}, not {moves!r}")
    free = problem.free
    k = len(free)
    ndim = k + 1 + int(ar1)
    nw = max(32, 2 * ndim, n_walkers or 0)
    nw += nw % 2
    rng = np.random.default_rng(seed)
    xb = np.array([result.parameters[n] for n in free])
    posterior = _Posterior(problem, ar1, reparam, xb)
    move = p0 = None
    if moves == "de+laplace" and not ar1:  # phi has no Laplace approximation here
        approx = laplace(posterior, xb, reparam)
        if approx is not None:
            move = LaplaceMove(*approx)
            p0 = laplace_start(posterior, move, nw,
                                 np.random.RandomState(rng.integers(2 ** 32)))
    if p0 is None:
        p0 = _start(problem, result, ar1, nw, ndim, rng)
        if reparam is not None:
            p0[:, :k] = reparam.forward(p0[:, :k])
    sampler = emcee.EnsembleSampler(nw, ndim, posterior, vectorize=True,
                                    moves=_moves(moves, move))
    sampler.random_state = np.random.RandomState(seed).get_state()
    if reparam is not None:  # the sampled coordinates and the coefficients mapped back
        idx = list(reparam.index)

        def tau_fn():
            tz = sampler.get_autocorr_time(tol=0)
            tx = emcee.autocorr.integrated_time(sampler.get_blobs()[..., :len(idx)], tol=0)
            tx_all = tz.copy()
            tx_all[idx] = tx
            return np.concatenate([tx_all, tz[idx]])
    else:
        def tau_fn():
            return sampler.get_autocorr_time(tol=0)
    session = session if session is not None else ChainSession()
    session.sampler, session.tau_fn = sampler, tau_fn
    return _summary(problem, result, session, seed, ar1, reparam, chain_file,
                    *run_chain(sampler, p0, max_steps, budget, progress, t0, tau_fn), t0=t0)


def _summary(problem, result, session: ChainSession, seed, ar1, reparam, chain_file, state,
             steps, tau, stop, *, t0: float) -> FitResult:
    """The result with the MCMC summary of the chain in ``session`` (and its file written);
    the session keeps where the chain stopped."""
    sampler = session.sampler
    session.state, session.steps, session.tau = state, steps, tau
    session.seconds += time.perf_counter() - t0
    free = problem.free
    k = len(free)
    nw = sampler.nwalkers
    names = list(free) + ["log_sigma"] + (["phi"] if ar1 else [])
    if reparam is not None:
        names += list(reparam.labels)
    finite = bool(np.all(np.isfinite(tau)))
    tau_max = float(np.max(tau)) if finite else float(steps) / TAU_FACTOR
    discard = min(int(np.ceil(3 * tau_max)), steps // 2)
    thin = max(1, int(tau_max / 2))
    tau_of = dict(zip(names, np.broadcast_to(tau, len(names))))
    if chain_file is not None:
        _write_chain_file(chain_file, sampler, reparam)
    flat = _chain(sampler, reparam, discard=discard, thin=thin)
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
        tau={n: float(t) for n, t in tau_of.items()},
        acceptance=float(np.mean(sampler.acceptance_fraction)), n_walkers=nw, n_steps=steps,
        n_discard=discard, n_thin=thin, n_samples=n_eff, correlations=corr, noise=noise,
        seed=seed, converged=stop == "converged", seconds=session.seconds,
        chain_file=None if chain_file is None else str(chain_file),
        samples=flat[:, :k], stopped="" if stop == "converged" else stop,
        reparametrised=() if reparam is None else tuple(reparam.labels))
    return dataclasses.replace(result, mcmc=summary)
