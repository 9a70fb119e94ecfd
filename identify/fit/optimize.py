"""Global-then-local constrained fitting (the fmincon equivalent).

A Latin-hypercube multi-start over the bounds, each start solved by the engine
(:mod:`identify.fit.solve.engine`): least squares (trust-region reflective, bounds) for weighted
least squares, followed, where general constraints are violated or the objective is the thesis
metric, by SLSQP on the true objective (bounds + inequality constraints). The best start wins;
the result records how many starts reached it, which bounds and constraints are active,
standard errors and correlations from the Jacobian at the optimum, and how many model
evaluations the whole search took.
"""
from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass

import numpy as np
from scipy.stats import qmc

from identify.fit.result import FitResult
from identify.fit.solve import engine
from identify.fit.solve.engine import STRICT, Estimate, Tolerances
from identify.fit.solve.metric import thesis_error_by_group
from identify.fit.solve.problem import PENALTY, FitProblem

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


@dataclass(frozen=True)
class Outcome:
    """One start's local solve.

    Attributes
    ----------
    x : ndarray          where the start ended (free parameters)
    ok : bool            converged (and feasible)
    message : str
    status : int         status of the solver that produced x (Estimate.status convention)
    lsq : Estimate       the start's least-squares solve (x is lsq.x unless ``polished``)
    polished : bool      a polish moved x away from the least-squares solution
    """

    x: np.ndarray
    ok: bool
    message: str
    status: int
    lsq: Estimate
    polished: bool = False


def _jacobian_fn(problem: FitProblem):
    """The exact residual Jacobian for the solver, or None (finite differences)."""
    return problem.residual_jacobian if problem.jacobian is not None else None


def _solve(problem: FitProblem, x0: np.ndarray, max_nfev: int | None,
           tol: Tolerances) -> Estimate:
    """One start's least-squares solve (the exact Jacobian when the problem has one)."""
    return engine.least_squares(problem.residuals, x0, problem.bounds(), tol,
                                jac=_jacobian_fn(problem), max_nfev=max_nfev)


def _polish(problem: FitProblem, lsq: Estimate, tol: Tolerances) -> Outcome:
    """SLSQP on the true objective with bounds and constraints, from the least-squares x."""
    # weighted least squares: SLSQP in the metric of the solver's own Jacobian at lsq.x
    # (J^T J, the Gauss-Newton Hessian of 0.5 r^T r; see engine.polish)
    metric = (lsq.jac.T @ lsq.jac if problem.objective == "wls" and lsq.jac is not None
              and lsq.jac.shape[1] == lsq.x.size else None)
    objective, gradient = problem.objective_value, (problem.objective_gradient
                                                    if problem.jacobian is not None else None)
    if problem.objective == "wls" and gradient is not None:
        objective, gradient = _sharing_residuals(problem)

    def run(x1):
        return engine.polish(objective, x1, problem.bounds(), tol,
                             constraints=(problem.constraint_values if problem.constraints
                                          else None),
                             gradient=gradient,
                             metric=metric,
                             local_constraints=(problem.local_constraints
                                                if any(c.local is not None
                                                       for c in problem.constraints)
                                                else None))

    pol = run(lsq.x)
    if pol.status == 0:
        # SLSQP's iteration limit: it can creep along a flat valley of the thesis metric in
        # the scaling of its start; one restart from where it stopped (rescaled there) ends
        # by its ftol criterion when that point is the optimum (a simulated CFx fit at the
        # true quadratic-load coefficients was reported "not converged" without it)
        again = run(pol.x)
        if again.cost <= pol.cost:
            pol = again
    if not pol.success and problem.constraints and _dominated(problem, pol.x, lsq.x):
        return Outcome(lsq.x, False, f"{pol.message} (the polish ended neither lower in the "
                       "objective nor feasible: the least-squares point is kept)",
                       pol.status, lsq)
    if not problem.constraints and pol.cost > problem.objective_value(lsq.x):
        return Outcome(lsq.x, True, "least-squares pre-solve kept (SLSQP did not improve)",
                       lsq.status, lsq)
    return Outcome(pol.x, pol.success, pol.message, pol.status, lsq,
                   polished=not np.array_equal(pol.x, lsq.x))


def _sharing_residuals(problem: FitProblem):
    """(objective, gradient) of a weighted least-squares ``problem`` with an exact Jacobian:
    its objective_value and objective_gradient, the same numbers, except that the gradient
    takes the residuals of the objective's last evaluation when it is asked at the same x
    (SLSQP asks for the gradient where it has just evaluated the objective: one model
    evaluation fewer per iteration)."""
    last: list = [None, None]

    def objective(x: np.ndarray) -> float:
        r = problem.residuals(x)
        last[:] = [np.array(x, dtype=float), r]
        return float(0.5 * r @ r)

    def gradient(x: np.ndarray) -> np.ndarray:
        J = problem.model_jacobian(x)
        same = last[0] is not None and np.array_equal(last[0], x)
        r = last[1] if same else problem.residuals(x)
        return J.T @ (r * problem.weights())
    return objective, gradient


def _violation(problem: FitProblem, x: np.ndarray) -> float:
    """The largest violation of ``problem``'s constraints at ``x``: 0 when every one holds
    (+inf holds), inf where one is NaN or -inf. The one feasibility measure of this module
    (:func:`_finish`, :func:`_search`, :func:`_dominated`): engine.violation."""
    return engine.violation(problem.constraint_values(x))


def _dominated(problem: FitProblem, x: np.ndarray, ref: np.ndarray) -> bool:
    """Whether ``x`` (a failed polish's end) gains nothing over ``ref``: neither a lower
    objective nor feasibility where ``ref`` violates. A point that still violates is no
    gain for violating less: it holds no validity guarantee either, and a failed SLSQP
    trades the objective for it without bound. On the golden tyre's TTC session (seed 0,
    tests/data/tir/testA_61.tir) the Fy stage's polish failed ("Inequality constraints
    incompatible") still violating, a little less, at RBY4 = 7e8 and an objective 1e10 times
    the least-squares point's; the re-fit with RVY4..6 started there and the stage failed."""
    fx, fr = problem.objective_value(x), problem.objective_value(ref)
    vx, vr = _violation(problem, x), _violation(problem, ref)
    return (not fx < fr) and not (vx == 0.0 < vr)


def _finish(problem: FitProblem, lsq: Estimate, cache: list, bound: float,
            tol: Tolerances) -> tuple[Outcome, bool]:
    """A start after its least-squares solve ``lsq``. Weighted least squares: a solution that
    violates no constraint is the constrained optimum; one that does is polished unless its
    cost already reaches ``bound`` (the best feasible objective found so far: polishing only
    raises it) or it exhausted its budget. The thesis metric: always polished (SLSQP on the
    metric itself). Starts whose least-squares solves land on the same point share one
    polish (``cache``). With the outcome: whether it is the one the start would have as the
    only start (its least-squares solve, or its own polish: not skipped by ``bound``, not
    shared with an earlier start), which :class:`Solved` records."""
    if problem.objective == "wls":
        if lsq.status == 0 or not problem.constraints or _violation(problem, lsq.x) == 0.0:
            return Outcome(lsq.x, lsq.success, lsq.message, lsq.status, lsq), True
        if lsq.cost >= bound:
            return Outcome(lsq.x, False, "not polished: infeasible least-squares optimum no "
                           "better than a feasible start", lsq.status, lsq), False
    for x_ls, outcome in cache:
        if np.allclose(x_ls, lsq.x, rtol=1e-8, atol=1e-12):
            return outcome, False
    outcome = _polish(problem, lsq, tol)
    cache.append((lsq.x, outcome))
    return outcome, True


@dataclass(frozen=True)
class Solved:
    """A start of :func:`fit` whose outcome did not depend on the other starts
    (:func:`_finish`), recorded for :func:`replay`.

    Attributes
    ----------
    problem : FitProblem   the problem given to fit
    start : ndarray        the start, clipped to the bounds
    tol : Tolerances
    budget : int           the least-squares solve's budget (Tolerances.budget)
    outcome : Outcome      its outcome in fit (``ok`` after fit's constraint check)
    """

    problem: FitProblem
    start: np.ndarray
    tol: Tolerances
    budget: int
    outcome: Outcome


def replay(solved: list[Solved], problem: FitProblem, start: np.ndarray,
           max_nfev: int | None = None, tol: Tolerances = STRICT) -> Outcome | None:
    """The outcome ``fit(problem, starts=start[None, :], max_nfev=max_nfev, tol=tol)`` would
    have, from a recorded start of an earlier fit of the same problem (a solve is
    deterministic: the same problem, start and tolerances take the same steps; the budget only
    ends them): its outcome when it used fewer evaluations than both budgets (or the budgets
    are equal); not converged (``ok`` False) when it used more than ``max_nfev`` and the
    tolerances have no noise stop (the solve would stop at that budget, status 0; with a
    noise stop, the callback after a rejected step at the budget could end it as converged,
    and so could the crawl test, Tolerances.crawl_ftol); None when nothing recorded tells
    (solve it)."""
    x0 = np.clip(np.asarray(start, dtype=float), *problem.bounds())
    budget = tol.budget(x0.size, max_nfev)
    for rec in solved:
        if rec.problem is not problem or rec.tol != tol or not np.array_equal(rec.start, x0):
            continue
        used = rec.outcome.lsq.nfev
        if used < min(budget, rec.budget) or budget == rec.budget:
            return rec.outcome
        if used > budget and tol.noise_ftol <= 0:
            return dataclasses.replace(rec.outcome, ok=False, status=0,
                                       message="the evaluation budget would end it")
    return None


def _search(problem: FitProblem, points: np.ndarray, max_nfev: int | None,
            tol: Tolerances, record: list[Solved] | None = None,
            original: FitProblem | None = None) -> list[Outcome]:
    """Every start's local solve: all least-squares solves first, then the polishes from the
    lowest cost up, so that (weighted least squares) a start that cannot beat a feasible
    optimum is not polished. ``record``: the starts whose outcome is their own
    (:class:`Solved`, of ``original``, the problem before counting) are appended to it."""
    pre = [_solve(problem, x0, max_nfev, tol) for x0 in points]
    if not problem.free:
        return [Outcome(pre[0].x, True, pre[0].message, pre[0].status, pre[0])]
    cache: list = []
    done: dict[int, Outcome] = {}
    bound = np.inf
    for i in np.argsort([e.cost for e in pre], kind="stable"):
        out, own = _finish(problem, pre[i], cache, bound, tol)
        if _violation(problem, out.x) > engine.FEASIBLE_TOL:
            out = dataclasses.replace(out, ok=False, message="constraint violated: "
                                      + out.message)
        done[i] = out
        if record is not None and own:
            record.append(Solved(original, points[i], tol, tol.budget(len(problem.free),
                                                                      max_nfev), out))
        if out.ok and problem.objective == "wls":
            bound = min(bound, problem.objective_value(out.x))
    return [done[i] for i in range(len(pre))]


def _select(problem: FitProblem, outcomes: list[Outcome]) -> tuple[int, int]:
    """(index of the reported start, starts at the best value). The best converged start
    wins (the least bad one when none converged); among starts at the same best value the
    earliest in start order is reported, so the initial values choose the branch of a
    symmetric or multi-branch optimum, not round-off."""
    objs = np.array([problem.objective_value(o.x) if o.ok else np.inf for o in outcomes])
    if not np.isfinite(objs).any():
        objs = np.array([problem.objective_value(o.x) for o in outcomes])
    best = int(np.argmin(objs))
    gap = np.abs(objs - objs[best])
    at_best = int(np.sum(gap <= BEST_RTOL * abs(objs[best]) + BEST_ATOL))
    if np.isfinite(objs[best]):
        best = int(np.flatnonzero(gap <= BEST_RTOL * abs(objs[best]) + TIE_ATOL)[0])
    return best, at_best


@dataclass(frozen=True)
class Diagnosis:
    """The reported optimum and what is known about it.

    Attributes
    ----------
    x : ndarray                    the optimum, parameters within 1e-7 of their range from a
                                   bound put on it exactly
    at_bound, active : tuple of str
    cov : ndarray                  covariance of the free parameters (k, k)
    jacobian_source : str          "solver" (the least-squares solver's at its solution),
                                   "exact" (FitProblem.jacobian) or "central differences"
    covariance : str               which covariance (engine.covariance_of)
    clusters : int                 its number of sweeps (0: iid)
    dof : ndarray                  degrees of freedom of each standard error (k,)
    """

    x: np.ndarray
    at_bound: tuple[str, ...]
    active: tuple[str, ...]
    cov: np.ndarray
    jacobian_source: str
    covariance: str = "iid"
    clusters: int = 0
    dof: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))


def snapped(problem: FitProblem, x: np.ndarray) -> np.ndarray:
    """``x`` with the parameters within 1e-7 of their range from a bound put on it exactly
    (the reported optimum, Diagnosis.x)."""
    lo, hi = problem.bounds()
    span = np.where(np.isfinite(hi - lo), hi - lo, np.maximum(np.abs(x), 1.0))
    xb = np.where(np.abs(x - lo) <= 1e-7 * span, lo, x)
    return np.where(np.abs(xb - hi) <= 1e-7 * span, hi, xb)


def _diagnose(problem: FitProblem, out: Outcome) -> Diagnosis:
    """Bounds hit, active constraints and the covariance at the chosen start's optimum.

    The covariance comes from the least-squares solver's Jacobian when the optimum is the
    least-squares solution itself (s^2 from its residuals); when a polish moved the point, from
    the exact Jacobian if the problem has one, central differences otherwise.
    """
    free = problem.free
    lo, hi = problem.bounds()
    xb = snapped(problem, out.x)
    at_bound = tuple(n for n, x, a, b in zip(free, xb, lo, hi) if x == a or x == b)
    active = []
    if problem.constraints:
        vals = problem.values(xb)
        for c in problem.constraints:
            g = np.atleast_1d(np.asarray(c.fun(vals), dtype=float))
            if g.size and g.min() <= 1e-7 * max(1.0, float(np.max(np.abs(g)))):
                active.append(c.name)
    if not free:
        cov, kind, clusters = np.zeros((0, 0)), *problem.covariance_used()
        dof, source = np.zeros(0), "solver"
    elif not out.polished:
        cov, kind, clusters, dof = engine.covariance_of(problem, xb, jac=out.lsq.jac,
                                                        fun=out.lsq.fun)
        source = "solver"
    else:
        cov, kind, clusters, dof = engine.covariance_of(problem, xb)
        source = "exact" if problem.jacobian is not None else "central differences"
    return Diagnosis(xb, at_bound, tuple(active), cov, source, kind, clusters, dof)


def _assemble(problem: FitProblem, outcomes: list[Outcome], best: int, at_best: int,
              diag: Diagnosis, counter: engine.CountingModel, t0: float) -> FitResult:
    """The FitResult of the chosen start; ``nfev`` is the counter's total after the last
    model evaluation (the predictions at the optimum)."""
    free = problem.free
    lo, hi = problem.bounds()
    xb, cov = diag.x, diag.cov
    stderr, corr = engine.standard_errors(free, cov)
    pred = problem.predict(xb)
    with np.errstate(invalid="ignore"):
        r = (pred - problem.measured) * problem.weights()
    r = np.where(np.isfinite(r), r, PENALTY)  # as FitProblem.residuals, without evaluating again
    by_p = thesis_error_by_group(pred, problem.measured, problem.pressure_bar)
    out = outcomes[best]
    return FitResult(
        relation=problem.relation, form=problem.form, objective=problem.objective,
        parameters=problem.values(xb), free=free,
        stderr=stderr,
        bounds={n: (float(a), float(b)) for n, a, b in zip(free, lo, hi)},
        at_bound=diag.at_bound, active_constraints=diag.active,
        error_total_pct=float(np.mean(list(by_p.values()))), error_by_pressure_pct=by_p,
        wls=float(r @ r), n_points=int(problem.measured.size), converged=bool(out.ok),
        message=out.message, n_starts=len(outcomes), starts_at_best=at_best,
        correlations=corr, predicted=pred, measured=problem.measured,
        pressure_bar=problem.pressure_bar, seconds=time.perf_counter() - t0, nfev=counter.calls,
        status=out.status, covariance=diag.covariance, clusters=diag.clusters,
        dof=dict(zip(free, map(float, diag.dof))),
        # what the polish cost: r^T r at the least-squares point it left (0.5 r^T r solved)
        unconstrained_wls=(2.0 * float(out.lsq.cost) if out.polished
                           and problem.objective == "wls" and problem.constraints
                           else math.nan))


def fit(problem: FitProblem, *, n_starts: int | None = None, seed: int = 0,
        starts: np.ndarray | None = None, max_nfev: int | None = None,
        tol: Tolerances = STRICT, record: list[Solved] | None = None) -> FitResult:
    """Solve ``problem`` globally: multi-start Latin hypercube, local solves, best of all.

    Search (every start's least-squares solve and polish), select (the best start, ties to the
    earliest), diagnose (bounds, constraints, covariance), assemble (FitResult).

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
        Budget of each start's least-squares solve, in residual evaluations (scipy's count:
        finite-difference Jacobian evaluations are not in it); default
        ``tol.budget(free parameters)``. A start that exhausts it counts as not converged.
    tol : Tolerances
        Solver tolerances (default :data:`identify.fit.solve.engine.STRICT`).
    record : list, optional
        The starts whose outcome is their own are appended to it (:class:`Solved`), so that a
        later single-start fit of the same problem from one of them can be replayed
        (:func:`replay`) instead of solved again.

    Returns
    -------
    FitResult
        ``nfev`` counts every model evaluation the fit made (every start, finite-difference
        Jacobians, polishes, selection and diagnosis); ``status`` is the reported start's
        solver status.
    """
    t0 = time.perf_counter()
    original = problem
    problem, counter = engine.counted(problem)
    k = len(problem.free)
    if k == 0:
        points = np.zeros((1, 0))
    elif starts is not None:
        points = np.clip(np.atleast_2d(np.asarray(starts, dtype=float)), *problem.bounds())
    else:
        points = _starts(problem, n_starts or max(16, 8 * k), seed)
    outcomes = _search(problem, points, max_nfev, tol, record, original)
    best, at_best = _select(problem, outcomes)
    diag = _diagnose(problem, outcomes[best])
    return _assemble(problem, outcomes, best, at_best, diag, counter, t0)
