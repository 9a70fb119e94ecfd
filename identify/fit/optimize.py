"""Global-then-local constrained fitting (the fmincon equivalent).

A Latin-hypercube multi-start over the bounds, each start polished by a local solver:
``scipy.optimize.least_squares`` (trust-region reflective, bounds) for weighted least squares
without general constraints, SLSQP (bounds + inequality constraints) otherwise. The best start
wins; the result records how many starts reached it, which bounds and constraints are active,
standard errors and correlations from the Jacobian at the optimum.
"""
from __future__ import annotations

import time
import warnings

import numpy as np
from scipy import optimize
from scipy.stats import qmc

from identify.fit.problem import FitProblem
from identify.fit.result import FitResult

BEST_RTOL = 1e-6
BEST_ATOL = 1e-8
"""Two starts reached 'the same' optimum when their objectives agree to BEST_RTOL relative
plus BEST_ATOL absolute (the objectives are O(1): % for the thesis metric, normalised squared
errors for weighted least squares; 1e-8 only matters for exact, noise-free data)."""


TIE_ATOL = 1e-20
"""Absolute part of the tolerance within which two starts' objectives are the same optimum
when choosing which to report (the earliest); stricter than BEST_ATOL so that noise-free fits
do not report a start that stopped short of the exact optimum."""


def _sampling_box(problem: FitProblem) -> tuple[np.ndarray, np.ndarray]:
    """Finite box for the start points: the bounds, or initial +/- max(|initial|, 1) where a
    bound is infinite."""
    lo, hi = problem.bounds()
    x0 = problem.x0()
    span = np.maximum(np.abs(x0), 1.0)
    return np.where(np.isfinite(lo), lo, x0 - span), np.where(np.isfinite(hi), hi, x0 + span)


def _starts(problem: FitProblem, n_starts: int, seed: int) -> np.ndarray:
    lo, hi = _sampling_box(problem)
    k = len(lo)
    sample = qmc.LatinHypercube(d=k, seed=np.random.default_rng(seed)).random(n_starts - 1)
    pts = lo + sample * (hi - lo)
    return np.vstack([np.clip(problem.x0(), *problem.bounds()), pts])


def _least_squares(problem: FitProblem, x0: np.ndarray, max_nfev: int | None = None):
    lo, hi = problem.bounds()
    return optimize.least_squares(problem.residuals, x0, bounds=(lo, hi), method="trf",
                                  x_scale="jac", xtol=1e-15, ftol=1e-15, gtol=1e-15,
                                  max_nfev=max_nfev or 200 * (len(x0) + 1))


def _polish(problem: FitProblem, x1: np.ndarray) -> tuple[np.ndarray, bool, str]:
    """SLSQP on the true objective with bounds and constraints, from x1."""
    lo, hi = problem.bounds()
    scale = np.maximum(np.abs(x1), 1e-3)  # SLSQP is sensitive to scaling: optimise x / scale

    def scaled(z):
        return problem.objective_value(z * scale)

    cons = ([{"type": "ineq", "fun": (lambda z: problem.constraint_values(z * scale))}]
            if problem.constraints else [])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        out = optimize.minimize(scaled, x1 / scale, method="SLSQP",
                                bounds=list(zip(lo / scale, hi / scale)), constraints=cons,
                                options={"ftol": 1e-11, "maxiter": 300})
    x = np.clip(out.x * scale, lo, hi)
    if not problem.constraints and problem.objective_value(x) > problem.objective_value(x1):
        return x1, True, "least-squares pre-solve kept (SLSQP did not improve)"
    return x, bool(out.success), str(out.message)


def _local(problem: FitProblem, x0: np.ndarray, cache: list | None = None,
           max_nfev: int | None = None
           ) -> tuple[np.ndarray, bool, str]:
    """Local solve from x0. Weighted least squares without constraints: trust-region
    reflective. Otherwise a least-squares pre-solve (the thesis metric's smooth companion,
    constraints ignored) followed by SLSQP on the true objective with bounds and constraints;
    starts whose pre-solves land on the same point share one polish (``cache``)."""
    return _finish(problem, _least_squares(problem, x0, max_nfev), cache)


def _finish(problem: FitProblem, res, cache: list | None = None,
            bound: float = np.inf) -> tuple[np.ndarray, bool, str]:
    """The rest of :func:`_local` after the least-squares solve ``res``. Weighted least
    squares: a pre-solve that violates no constraint is the constrained optimum; one that does
    is polished unless its cost already reaches ``bound`` (the best feasible objective found
    so far: polishing only raises it) or it exhausted its budget."""
    if problem.objective == "wls":
        if res.status == 0 or not problem.constraints \
                or problem.constraint_values(res.x).min(initial=0.0) >= 0.0:
            return res.x, bool(res.status > 0), str(res.message)
        if res.cost >= bound:
            return res.x, False, ("not polished: infeasible least-squares optimum no better "
                                  "than a feasible start")
    if cache is not None:
        for x_ls, outcome in cache:
            if np.allclose(x_ls, res.x, rtol=1e-8, atol=1e-12):
                return outcome
    outcome = _polish(problem, res.x)
    if cache is not None:
        cache.append((res.x, outcome))
    return outcome


def _jacobian(problem: FitProblem, x: np.ndarray) -> np.ndarray:
    """Central-difference Jacobian of the weighted residuals, columns = free parameters."""
    lo, hi = problem.bounds()
    cols = []
    for j in range(len(x)):
        h = 1e-6 * max(abs(x[j]), 1e-4)
        xp, xm = x.copy(), x.copy()
        xp[j] = min(x[j] + h, hi[j]) if np.isfinite(hi[j]) else x[j] + h
        xm[j] = max(x[j] - h, lo[j]) if np.isfinite(lo[j]) else x[j] - h
        cols.append((problem.residuals(xp) - problem.residuals(xm)) / (xp[j] - xm[j]))
    return np.column_stack(cols) if cols else np.zeros((problem.measured.size, 0))


def covariance(problem: FitProblem, x: np.ndarray) -> np.ndarray:
    """Covariance of the free parameters: s^2 (J^T J)^-1 with s^2 = chi^2/(n - k)."""
    r = problem.residuals(x)
    J = _jacobian(problem, x)
    n, k = J.shape
    dof = max(n - k, 1)
    # known sigma: the weights already carry the noise scale; otherwise estimate it
    s2 = 1.0 if problem.sigma is not None else float(r @ r) / dof
    return s2 * np.linalg.pinv(J.T @ J)


def fit(problem: FitProblem, *, n_starts: int | None = None, seed: int = 0,
        starts: np.ndarray | None = None, max_nfev: int | None = None) -> FitResult:
    """Solve ``problem`` globally: multi-start Latin hypercube, local polish, best of all.

    Parameters
    ----------
    n_starts : int, optional
        Number of starts including the initial values; default max(16, 8 * free parameters).
    seed : int
        Seed of the Latin hypercube.
    starts : ndarray, optional
        Explicit start points, shape (starts, free parameters), used instead of the initial
        values + Latin hypercube (``n_starts`` and ``seed`` are then ignored); clipped to the
        bounds.
    max_nfev : int, optional
        Budget of model evaluations (Jacobian ones not counted) of each start's least-squares
        solve; default 200 * (free parameters + 1). A start that exhausts it counts as not
        converged.
    """
    t0 = time.perf_counter()
    free = problem.free
    k = len(free)
    n_starts = n_starts or max(16, 8 * k)
    if starts is not None:
        starts = np.clip(np.atleast_2d(np.asarray(starts, dtype=float)), *problem.bounds())
    if k == 0:
        xs, oks, msgs = [np.zeros(0)], [True], ["nothing to fit"]
    else:
        cache: list = []
        # all least-squares solves first, then the polishes from the lowest cost up, so that
        # (weighted least squares) a start that cannot beat a feasible optimum is not polished
        pre = [_least_squares(problem, x0, max_nfev)
               for x0 in (_starts(problem, n_starts, seed) if starts is None else starts)]
        done: dict[int, tuple] = {}
        bound = np.inf
        for i in np.argsort([r.cost for r in pre], kind="stable"):
            x, ok, msg = _finish(problem, pre[i], cache, bound)
            feasible = problem.constraint_values(x).min(initial=0.0) >= -1e-8
            done[i] = (x, ok and feasible, msg if feasible else "constraint violated: " + msg)
            if ok and feasible and problem.objective == "wls":
                bound = min(bound, problem.objective_value(x))
        xs, oks, msgs = (list(v) for v in zip(*(done[i] for i in range(len(pre)))))
    objs = np.array([problem.objective_value(x) if ok else np.inf for x, ok in zip(xs, oks)])
    if not np.isfinite(objs).any():  # nothing converged: report the least bad start
        objs = np.array([problem.objective_value(x) for x in xs])
    best = int(np.argmin(objs))
    gap = np.abs(objs - objs[best])
    at_best = int(np.sum(gap <= BEST_RTOL * abs(objs[best]) + BEST_ATOL))
    # starts that reach the same best value (a symmetric or multi-branch optimum): report the
    # earliest in start order, so the initial values choose the branch, not round-off
    if np.isfinite(objs[best]):
        best = int(np.flatnonzero(gap <= BEST_RTOL * abs(objs[best]) + TIE_ATOL)[0])
    xb = xs[best]
    lo, hi = problem.bounds()
    span = np.where(np.isfinite(hi - lo), hi - lo, np.maximum(np.abs(xb), 1.0))
    # a parameter within 1e-7 of its range from a bound is on it: report the bound exactly
    xb = np.where(np.abs(xb - lo) <= 1e-7 * span, lo, xb)
    xb = np.where(np.abs(xb - hi) <= 1e-7 * span, hi, xb)
    at_bound = tuple(n for n, x, a, b in zip(free, xb, lo, hi) if x == a or x == b)
    active = []
    if problem.constraints:
        vals = problem.values(xb)
        for c in problem.constraints:
            g = np.atleast_1d(np.asarray(c.fun(vals), dtype=float))
            if g.size and g.min() <= 1e-7 * max(1.0, float(np.max(np.abs(g)))):
                active.append(c.name)
    cov = covariance(problem, xb) if k else np.zeros((0, 0))
    # a parameter on an active bound has no meaningful symmetric error
    sd = np.sqrt(np.clip(np.diag(cov), 0, None))
    corr = {}
    for i in range(k):
        for j in range(i + 1, k):
            den = sd[i] * sd[j]
            corr[f"{free[i]}|{free[j]}"] = float(cov[i, j] / den) if den > 0 else float("nan")
    pred = problem.predict(xb)
    r = problem.residuals(xb)
    by_p = problem.thesis_by_pressure(xb)
    return FitResult(
        relation=problem.relation, form=problem.form, objective=problem.objective,
        parameters=problem.values(xb), free=free,
        stderr={n: float(s) for n, s in zip(free, sd)},
        bounds={n: (float(a), float(b)) for n, a, b in zip(free, lo, hi)},
        at_bound=at_bound, active_constraints=tuple(active),
        error_total_pct=float(np.mean(list(by_p.values()))), error_by_pressure_pct=by_p,
        wls=float(r @ r), n_points=int(problem.measured.size), converged=bool(oks[best]),
        message=msgs[best], n_starts=len(xs), starts_at_best=at_best, correlations=corr,
        predicted=pred, measured=problem.measured, pressure_bar=problem.pressure_bar,
        seconds=time.perf_counter() - t0)
