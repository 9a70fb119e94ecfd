"""The estimation engine: one bounded least-squares solver, one constrained polish, one
covariance, one finite-difference Jacobian.

Every fit (relations, MF stages, discovery's base fits and refits) solves through
:func:`least_squares`; the settings that differ between them are named :class:`Tolerances`
presets, so the difference between a strict fit and a discovery refit is visible in one place.

* :func:`least_squares` -- scipy's trust-region reflective solver within bounds, returning a
  frozen :class:`Estimate` (the fields scipy's ``OptimizeResult`` documents). Given an exact
  Jacobian it is passed to the solver (``jac=``); otherwise scipy's forward differences.
* :func:`polish` -- SLSQP on a scalar objective with bounds and inequality constraints (the
  thesis metric, or a least-squares point that violates a general constraint).
* :func:`covariance` -- s^2 (J^T J)^+ from a given Jacobian of weighted residuals (sigma known:
  s^2 = 1; otherwise s^2 = r^T r / (n - k)), or cluster-robust over sweeps (the sandwich or
  the delete-one-cluster jackknife); written in :mod:`identify.fit.solve.covariance`, with the
  degrees of freedom of the intervals, and re-exported here.
* :func:`fd_jacobian` -- central differences, for where the solver's Jacobian is not available
  (a polish moved the point; derivatives with respect to coefficients that are not fitted).
* :func:`residual_jacobian` -- d(weighted residuals)/d(free parameters) of a
  :class:`~identify.fit.solve.problem.FitProblem`: the problem's exact Jacobian when it has one,
  :func:`fd_jacobian` otherwise.
* :class:`CountingModel` -- counts model evaluations (scipy's ``nfev`` leaves out the ones its
  finite-difference Jacobians cost).
"""
from __future__ import annotations

import contextlib
import dataclasses
import inspect
import warnings
from collections.abc import Callable, Mapping
from dataclasses import dataclass

import numpy as np
from scipy import optimize

try:  # the engine of scipy.optimize.approx_fprime, which takes a vectorised map (workers)
    from scipy.optimize._numdiff import approx_derivative as _approx_derivative
except ImportError:  # pragma: no cover - a scipy without it: approx_fprime point by point
    _approx_derivative = None

from identify.fit.solve.covariance import (
    CLUSTER_KINDS,
    ESSENTIAL_RTOL,
    column_scaled,
    covariance,
    interval_dof,
    jackknife_covariance,
    jackknife_defined,
    jackknife_dof,
    jackknife_steps,
    jackknife_with_dof,
    pseudo_solve,
    residual_variance,
    standard_errors,
    t_quantile,
)
from identify.fit.solve.gauss_newton import Steps, gauss_newton_step, interior_steps
from identify.fit.solve.problem import FitProblem, penalised
from identify.fit.solve.trf_svd import qr_svd

__all__ = ["CLUSTER_KINDS", "CRAWL_STATUS", "DISCOVERY", "DOGLEG_AFTER", "ESSENTIAL_RTOL",
           "FEASIBLE_TOL", "LAPLACE", "MF_SOLVE", "NOISE_STATUS", "SEARCH", "STOP_STATUS",
           "STRICT", "CountingModel", "Estimate", "KeptJacobian", "Tolerances",
           "column_scaled", "counted", "covariance", "covariance_of", "fd_jacobian", "fd_steps",
           "interval_dof",
           "jackknife_covariance", "jackknife_defined", "jackknife_dof", "jackknife_steps",
           "jackknife_with_dof", "least_squares", "polish", "problem_covariance",
           "pseudo_solve", "residual_jacobian", "residual_variance", "standard_errors",
           "t_quantile", "violation"]


@dataclass(frozen=True)
class Tolerances:
    """Stopping rules of the local solvers.

    Attributes
    ----------
    xtol, ftol, gtol : float
        scipy ``least_squares`` tolerances on the step, the relative cost change and the
        scaled gradient [-].
    nfev_per_parameter : int
        Default budget of a least-squares solve: nfev_per_parameter x (free parameters + 1)
        residual evaluations (scipy's count: finite-difference Jacobian evaluations excluded).
    interior : float
        A start on a finite bound is moved this fraction of the range into the box before the
        solve (0: scipy's own minimal move, ~1e-10 relative).
    polish_ftol : float
        SLSQP's tolerance on the objective change of the constrained polish.
    polish_maxiter : int
        SLSQP's iteration limit.
    noise_ftol : float
        A least-squares solve also stops (status 5) once its cost 0.5 r^T r has fallen by less
        than noise_ftol x s^2 over the last ``noise_window`` iterations, s^2 = r^T r / (n - k)
        the residual variance: the remaining change of chi^2 = r^T r / s^2 is then of the
        order of 2 noise_ftol, i.e. the parameters are within a small fraction of their
        standard errors of the optimum, where xtol/ftol at round-off let a solver crawl along
        a flat valley of noisy data for hundreds of evaluations. 0: off. Needs scipy >= 1.16
        (least_squares' callback); ignored by older versions.
    noise_window : int
    crawl_ftol : float
        A solve with ``noise_ftol`` > 0 that runs out of its budget while its cost still falls,
        but by less than crawl_ftol x s^2 over the last ``noise_window`` iterations (chi^2 by
        less than 2 crawl_ftol), is crawling along a valley the data do not determine: it is
        reported converged (status 7) at that point, with the drop in its message, instead of
        failed: a solve drifting along coefficients whose standard errors exceed their values
        (e.g. the geometry stage's DREFF, FREFF, BREFF) would otherwise fail a
        stage whose fit is as good as the data allow.
    qr_svd : bool
        Take the solver's SVDs through a QR decomposition (identify.fit.solve.trf_svd: the same
        steps to round-off, without forming U); the MF stages' solves.
    dogleg_after : int
        A solve still going after this many evaluations of the trust-region reflective
        method goes on from there with scipy's dogleg method ("dogbox") for the rest of its
        budget (0: never; see DOGLEG_AFTER). Solves that converge within it are unchanged.
    decrement_stop : bool
        With ``noise_ftol`` > 0 and an exact Jacobian: the solve also stops (status 5) at an
        iterate where the Gauss-Newton decrement, the fall of the cost that the model
        linearised there predicts for its full unbounded step (0.5 ||P_J r||^2, P_J the
        projection on the columns of the Jacobian), is below noise_ftol x s^2: the noise
        stop's bound on what is left, read from one iterate instead of waited for over
        ``noise_window`` (the bounds only shrink the step, so the test errs on going on).
        Tried only where the last iteration lowered the cost by less than DECREMENT_GATE
        times that (a QR decomposition of the Jacobian each).
    gauss_newton : bool
        With ``noise_ftol`` > 0 and an exact Jacobian: the solve starts with full
        Gauss-Newton steps inside the bounds (identify.fit.solve.gauss_newton), which end it where
        the decrement is below noise_ftol x s^2 and otherwise hand their last iterate to the
        trust-region solver (with the rest of the budget; at most half of it is theirs).
    """

    xtol: float
    ftol: float
    gtol: float
    nfev_per_parameter: int
    interior: float = 0.0
    polish_ftol: float = 1e-11
    polish_maxiter: int = 300
    noise_ftol: float = 0.0
    noise_window: int = 5
    crawl_ftol: float = 0.05
    qr_svd: bool = False
    dogleg_after: int = 0
    decrement_stop: bool = False
    gauss_newton: bool = False

    def budget(self, n_free: int, max_nfev: int | None = None) -> int:
        """The evaluation budget of one solve: ``max_nfev`` or the per-parameter default."""
        return int(max_nfev or self.nfev_per_parameter * (n_free + 1))


DOGLEG_AFTER = 50
"""Evaluations after which the MF stages' solves switch from trust-region reflective to the
dogleg (Tolerances.dogleg_after). In a curved valley with a near-null direction, trf's
regularised step hardly moves along it; the dogleg takes the Gauss-Newton step whenever it
fits the trust region. Such valleys arise on large sessions, e.g. Mz0 along QBZ9 (Br of the
residual torque, nearly without effect where the data are), where trf can crawl through a
solve's whole budget while the dogleg reaches the optimum. A solve that ends by its own tests
within DOGLEG_AFTER evaluations never switches, so where the stages converge promptly the fit
is the trust-region reflective one. bench/fit_cost.py counts each stage's evaluations (its
nfev column; --ttc SEED for a generated TTC session)."""


STRICT = Tolerances(xtol=1e-15, ftol=1e-15, gtol=1e-15, nfev_per_parameter=200)
"""Relation and MF-stage fits (identify.fit.optimize.fit): the solver runs to round-off, so that
the reported optimum is the optimum (the thesis acceptance compares it with the best of five
differential-evolution runs to 0.5 %, and noise-free recovery to 1e-6 relative)."""

SEARCH = Tolerances(xtol=1e-8, ftol=1e-8, gtol=1e-8, nfev_per_parameter=60, noise_ftol=1e-2,
                    qr_svd=True, dogleg_after=DOGLEG_AFTER, decrement_stop=True,
                    gauss_newton=True)
"""The MF stages' global search on a subsample (identify.fit.mf.search.search): each start only
has to reach its basin (1e-8 relative, or a cost that changes by less than 1e-2 s^2 over 5
iterations, chi^2 by < 0.02, or a Gauss-Newton decrement below 1e-2 s^2: decrement_stop);
the candidates are then solved on all points with MF_SOLVE, which takes any point of a basin
to the same optimum, so the search need not be tighter than the basin (the evaluations it
costs: the nfev column of bench/fit_cost.py). Each start begins with full Gauss-Newton steps
(gauss_newton, as MF_SOLVE), which reach the bottom of an interior basin in fewer evaluations
than trust-region steps (bench/fit_cost.py --passes 2 gives the stages' cost in evaluations
of their points). A start may end a coefficient the data do not fix on a degenerate value
(Fx0 at PKX2 = 0); the staged jackknife carries only what a stage's data determine
(identify.fit.mf.uncertainty._determined), so no rounding from it reaches later stages."""

MF_SOLVE = dataclasses.replace(STRICT, noise_ftol=1e-4, qr_svd=True, dogleg_after=DOGLEG_AFTER,
                               decrement_stop=True, gauss_newton=True)
"""The MF stages' solves on all points (identify.fit.mf.stages): STRICT, and stopped once the
cost falls by less than 1e-4 s^2 over 5 iterations, or the Gauss-Newton decrement is below
1e-4 s^2 (chi^2 by < 2e-4: a small fraction of a standard error from the optimum, so the
stop moves no coefficient by more than a small fraction of its standard error). On large
sessions STRICT alone can spend a solve's whole budget on changes of the cost far below the
noise; the decrement ends a solve as soon as the linearised model says the rest is
negligible, where the five-iteration window and scipy's round-off tests must first see it.
The solves start with the Gauss-Newton phase (gauss_newton; identify.fit.solve.gauss_newton).
bench/fit_cost.py reports each stage's evaluations (its nfev column) and cost."""

LAPLACE = Tolerances(xtol=1e-8, ftol=1e-8, gtol=1e-8, nfev_per_parameter=60)
"""The MCMC likelihood's maximum near the least-squares optimum (identify.fit.mcmc.laplace.
likelihood_mode, with its own budget of 30 evaluations): a few Gauss-Newton steps, 1e-8
relative (scipy's defaults); it only centres the Laplace proposals, which leave the posterior
invariant whatever their centre."""

DISCOVERY = Tolerances(xtol=1e-10, ftol=1e-10, gtol=1e-10, nfev_per_parameter=60,
                       interior=1e-9)
"""Discovery's base fits, refits and held-out fold fits (identify.discover.objective): hundreds of
solves per run whose F tests and held-out errors need the residual sum of squares to ~1e-10
relative, far below the noise; starts on a bound move 1e-9 of the range inside."""


@dataclass(frozen=True)
class Estimate:
    """The outcome of one local solve (the fields of scipy's ``OptimizeResult``).

    Attributes
    ----------
    x : ndarray                 solution (free parameters)
    cost : float                objective at x: 0.5 r^T r for least squares, the scalar
                                objective for a polish
    fun : ndarray or None       residuals at x (None after a polish of a scalar objective)
    jac : ndarray or None       their Jacobian at x, (n, k) (None after a polish)
    nfev, njev : int            the solver's function and Jacobian evaluation counts (scipy's:
                                finite-difference evaluations are not in nfev)
    status : int                > 0 converged, 0 budget exhausted, < 0 failed (scipy's
                                least-squares codes, NOISE_STATUS (5) for a solve stopped by
                                Tolerances.noise_ftol, STOP_STATUS (6) by its ``stop``,
                                CRAWL_STATUS (7) at its budget by Tolerances.crawl_ftol; a
                                polish maps SLSQP's exit modes: success -> 2, the iteration
                                limit -> 0, mode m otherwise -> -m)
    message : str
    success : bool              status > 0
    active_mask : ndarray       -1 on the lower bound, 1 on the upper, 0 inside (int, (k,))
    """

    x: np.ndarray
    cost: float
    fun: np.ndarray | None
    jac: np.ndarray | None
    nfev: int
    njev: int
    status: int
    message: str
    success: bool
    active_mask: np.ndarray


def _interior(x0: np.ndarray, lo: np.ndarray, hi: np.ndarray, frac: float) -> np.ndarray:
    x0 = np.clip(np.asarray(x0, dtype=float), lo, hi)
    if frac <= 0:
        return x0
    span = hi - lo
    x0 = np.where((x0 == lo) & np.isfinite(hi), x0 + frac * span, x0)
    return np.where((x0 == hi) & np.isfinite(lo), x0 - frac * span, x0)


def least_squares(residuals: Callable[[np.ndarray], np.ndarray], x0: np.ndarray,
                  bounds: tuple[np.ndarray, np.ndarray], tol: Tolerances = STRICT, *,
                  jac: Callable[[np.ndarray], np.ndarray] | None = None,
                  max_nfev: int | None = None,
                  stop: Callable[[np.ndarray, float], str | None] | None = None) -> Estimate:
    """Minimise 0.5 ||residuals(x)||^2 within ``bounds`` (trust-region reflective).

    Parameters
    ----------
    residuals : callable
        x (k,) -> r (n,), weighted residuals [-].
    x0 : ndarray
        Start (clipped to the bounds; see ``Tolerances.interior``).
    bounds : (ndarray, ndarray)
        Lower and upper bounds of x (+/-inf for none).
    tol : Tolerances
    jac : callable, optional
        x -> d r / d x, (n, k): an exact Jacobian. Default: scipy's forward differences.
    max_nfev : int, optional
        Budget of residual evaluations; default ``tol.budget(k)``.
    stop : callable, optional
        stop(x, cost) after every iteration: a message ends the solve there (status
        STOP_STATUS, e.g. a multi-start's start that has reached another start's end point,
        identify.fit.mf.search.search); None goes on. Needs scipy >= 1.16; ignored before.
    """
    lo, hi = (np.asarray(b, dtype=float) for b in bounds)
    x0 = _interior(x0, lo, hi, tol.interior)
    if x0.size == 0:
        r = np.asarray(residuals(x0), dtype=float)
        return Estimate(x=x0, cost=float(0.5 * r @ r), fun=r, jac=np.zeros((r.size, 0)),
                        nfev=1, njev=0, status=1, message="nothing to fit", success=True,
                        active_mask=np.zeros(0, dtype=int))
    extra = {}
    noise = _NoiseStop(tol, x0.size) if tol.noise_ftol > 0 else None
    if noise is not None and jac is not None and tol.decrement_stop:
        jac = noise.kept = jac if isinstance(jac, KeptJacobian) else KeptJacobian(jac)
    caller = _Stop(noise, stop)
    if (noise is not None or stop is not None) and _HAS_CALLBACK:
        extra["callback"] = caller
    budget = tol.budget(x0.size, max_nfev)
    ahead = None  # the Gauss-Newton phase (Tolerances.gauss_newton)
    if tol.gauss_newton and jac is not None and tol.noise_ftol > 0:
        ahead = interior_steps(residuals, jac, x0, lo, hi, noise_ftol=tol.noise_ftol,
                               max_nfev=budget // 2, stop=stop)
        if ahead.converged or ahead.stopped is not None:
            return _from_steps(ahead, tol)
        x0, budget = ahead.x, budget - ahead.nfev
    first = min(budget, tol.dogleg_after) if tol.dogleg_after else budget

    def solve(x_start, method, nfev):
        # the QR route replaces trf's SVD; scipy's dogbox takes lstsq steps and has none
        with qr_svd() if tol.qr_svd and method == "trf" else contextlib.nullcontext():
            return optimize.least_squares(residuals, x_start,
                                          jac=jac if jac is not None else "2-point",
                                          bounds=(lo, hi), method=method, x_scale="jac",
                                          xtol=tol.xtol, ftol=tol.ftol, gtol=tol.gtol,
                                          max_nfev=nfev, **extra)

    res = solve(x0, "trf", first)
    if res.status == 0 and first < budget:  # still going at dogleg_after: the dogleg on
        more = solve(res.x, "dogbox", budget - res.nfev)
        more.nfev, more.njev = more.nfev + res.nfev, (more.njev or 0) + (res.njev or 0)
        res = more
    if ahead is not None:  # the trust-region solve went on from the phase's last iterate
        res.nfev, res.njev = res.nfev + ahead.nfev, (res.njev or 0) + ahead.njev
    status, message = int(res.status), str(res.message)
    if caller.message is not None:
        status, message = STOP_STATUS, caller.message
    elif noise is not None and noise.fired == "decrement":
        status, message = NOISE_STATUS, _decrement_message(tol)
    elif noise is not None and noise.fired:
        status = NOISE_STATUS
        message = (f"the cost fell by less than {tol.noise_ftol:g} x the residual variance "
                   f"over {tol.noise_window} iterations")
    elif noise is not None and status == 0 and (drop := noise.last_drop()) is not None \
            and drop < tol.crawl_ftol:
        status = CRAWL_STATUS
        message = (f"stopped at its budget crawling along a flat valley: the cost fell by "
                   f"{drop:.2g} x the residual variance over the last {tol.noise_window} "
                   f"iterations (below {tol.crawl_ftol:g})")
    return Estimate(x=res.x, cost=float(res.cost), fun=res.fun, jac=np.atleast_2d(res.jac),
                    nfev=int(res.nfev), njev=int(res.njev or 0), status=status,
                    message=message, success=bool(status > 0),
                    active_mask=np.asarray(res.active_mask, dtype=int))


def _decrement_message(tol: Tolerances) -> str:
    """The message of a solve ended by the Gauss-Newton decrement (the decrement stop or the
    Gauss-Newton phase)."""
    return (f"the Gauss-Newton step would lower the cost by less than {tol.noise_ftol:g} x "
            "the residual variance")


def _from_steps(steps: Steps, tol: Tolerances) -> Estimate:
    """The Estimate of a least-squares solve that the Gauss-Newton phase ended (converged by
    the decrement, or by the caller's ``stop``)."""
    if steps.stopped is not None:
        status, message = STOP_STATUS, steps.stopped
    else:
        status, message = NOISE_STATUS, _decrement_message(tol)
    return Estimate(x=steps.x, cost=steps.cost, fun=steps.fun, jac=np.atleast_2d(steps.jac),
                    nfev=steps.nfev, njev=steps.njev, status=status, message=message,
                    success=status > 0, active_mask=np.zeros(steps.x.size, dtype=int))


_HAS_CALLBACK = "callback" in inspect.signature(optimize.least_squares).parameters
NOISE_STATUS = 5
"""Estimate.status of a least-squares solve stopped by Tolerances.noise_ftol."""
STOP_STATUS = 6
"""Estimate.status of a least-squares solve ended by its ``stop`` callable."""
CRAWL_STATUS = 7
"""Estimate.status of a least-squares solve that ran out of its budget crawling (see
Tolerances.crawl_ftol)."""


class _Stop:
    """scipy least_squares callback: the noise stop, then the caller's ``stop``."""

    def __init__(self, noise: _NoiseStop | None, stop):
        self.noise, self.stop, self.message = noise, stop, None

    def __call__(self, intermediate_result) -> None:
        if self.stop is not None:
            self.message = self.stop(np.asarray(intermediate_result.x),
                                     float(intermediate_result.cost))
            if self.message is not None:
                raise StopIteration
        if self.noise is not None:
            self.noise(intermediate_result)


class KeptJacobian:
    """An exact Jacobian x -> J that keeps its last evaluation, for a solver callback that
    needs J at the iterate it is told of (scipy's trf evaluates J at an accepted iterate just
    before its callback): the noise stop's decrement, the MF search's merge test
    (identify.fit.mf.search). One wrapper serves both (engine.least_squares keeps a given
    one)."""

    def __init__(self, jac: Callable[..., np.ndarray]):
        self.jac = jac
        self._x: np.ndarray | None = None
        self._J: np.ndarray | None = None

    def __call__(self, x: np.ndarray, *args) -> np.ndarray:
        J = self.jac(x, *args)
        self._x, self._J = np.array(x, dtype=float), J
        return J

    def at(self, x: np.ndarray) -> np.ndarray | None:
        """The Jacobian last evaluated, if it was at ``x``; else None."""
        return self._J if self._x is not None and np.array_equal(self._x, x) else None


DECREMENT_GATE = 3.0
"""Tolerances.decrement_stop: the Gauss-Newton decrement is taken only at an iterate whose
iteration lowered the cost by less than DECREMENT_GATE x noise_ftol x s^2. Converging
linearly at a rate rho, what is left is ~ rho / (1 - rho) times the last fall (at most that
fall for rho <= 1/2), so no iterate where the decrement test can pass is skipped for long;
away from the optimum the decomposition is not paid. A larger gate decomposes at more
iterates for no earlier stop; a gate near 1 can pass over the iterate where the test would
first succeed and stop a few evaluations later (bench/fit_cost.py counts the evaluations)."""


class _NoiseStop:
    """scipy least_squares callback: StopIteration once the cost has fallen by less than
    noise_ftol x s^2 over the last noise_window iterations (see Tolerances.noise_ftol), or
    (Tolerances.decrement_stop, the solver's exact Jacobian a :class:`KeptJacobian` in
    ``kept``) once the Gauss-Newton decrement is below that."""

    def __init__(self, tol: Tolerances, n_free: int):
        self.tol, self.k, self.costs = tol, n_free, []
        self.fired: str | None = None  # "window" or "decrement" once it has stopped a solve
        self.kept: KeptJacobian | None = None  # the exact Jacobian (decrement_stop)
        self.s2 = 0.0  # s^2 at the last iterate (costs[-1]); 0 where unknown (penalised)

    def last_drop(self) -> float | None:
        """The cost's fall over the last noise_window iterations in units of s^2 at the last
        iterate (None before that many iterations, or at a zero cost). The noise stop's test
        and, at the end of a solve, the crawl test (Tolerances.crawl_ftol)."""
        w = self.tol.noise_window
        if len(self.costs) <= w or not self.s2 > 0:
            return None
        return (self.costs[-1 - w] - self.costs[-1]) / self.s2

    def decrement(self, x: np.ndarray, r: np.ndarray) -> float | None:
        """The Gauss-Newton decrement 0.5 ||P_J r||^2 at ``x`` (residuals ``r``) from the
        Jacobian kept at x (identify.fit.solve.gauss_newton.gauss_newton_step, the Gauss-Newton
        phase's own); None without a finite, nonzero one at x."""
        J = None if self.kept is None else self.kept.at(x)
        step = None if J is None else gauss_newton_step(np.asarray(J, dtype=float),
                                                        np.asarray(r, dtype=float))
        return None if step is None else step[1]

    def __call__(self, intermediate_result) -> None:
        self.costs.append(float(intermediate_result.cost))
        # s^2 is unknown where a residual is a non-finite model value's penalty: no noise test
        # there (a penalised plateau changes by little relative to the penalty's s^2)
        self.s2 = (0.0 if penalised(intermediate_result.fun)
                   else residual_variance(self.costs[-1], intermediate_result.fun.size, self.k))
        drop = self.last_drop()
        if drop is not None and drop < self.tol.noise_ftol:
            self.fired = "window"
            raise StopIteration
        near = self.tol.noise_ftol * self.s2
        if (self.kept is not None and len(self.costs) >= 2 and near > 0
                and self.costs[-2] - self.costs[-1] < DECREMENT_GATE * near):
            d = self.decrement(np.asarray(intermediate_result.x),
                               np.asarray(intermediate_result.fun))
            if d is not None and d < near:
                self.fired = "decrement"
                raise StopIteration


FEASIBLE_TOL = 1e-8
"""A constraint whose violation (:func:`violation`) is at most FEASIBLE_TOL holds (the MF
validity margins are minima over a grid, whose kinks can keep SLSQP ~1e-10 outside them for
good)."""


def violation(values: np.ndarray) -> float:
    """The largest violation of constraint values ``values`` (each must be >= 0): 0 when every
    one holds (+inf holds), inf where one is NaN or -inf. The one feasibility measure of the
    fits (identify.fit.optimize, the polish's stall test)."""
    low = float(np.asarray(values, dtype=float).min(initial=0.0))
    return np.inf if np.isnan(low) else max(0.0, -low)


class _PolishStall:
    """SLSQP callback: StopIteration once the objective has changed by less than
    ``tol.polish_ftol`` (SLSQP's own ftol, absolute) over the last ``tol.noise_window``
    iterations at an iterate where every constraint holds to FEASIBLE_TOL. SLSQP's own test
    also asks its constraint violation to be below ftol, which a kink of a min-over-grid
    margin can deny for good: a candidate at its constrained optimum, a hair outside a
    margin, would stay there for SLSQP's whole iteration limit and a restart.
    ``feasible_margin`` z -> constraint values (None: no constraints)."""

    def __init__(self, tol: Tolerances, feasible_margin):
        self.tol, self.margin = tol, feasible_margin
        self.f: list[float] = []
        self.fired, self.z = False, None

    def __call__(self, intermediate_result) -> None:
        fun = getattr(intermediate_result, "fun", None)
        if fun is None:  # a scipy that calls back with x alone (and may not halt): off
            return
        self.f.append(float(fun))
        w = self.tol.noise_window
        if len(self.f) <= w or np.ptp(self.f[-1 - w:]) >= self.tol.polish_ftol:
            return
        z = np.array(intermediate_result.x, dtype=float)
        if self.margin is not None and violation(self.margin(z)) > FEASIBLE_TOL:
            return
        self.fired, self.z = True, z
        raise StopIteration


def _slsqp_status(out) -> int:
    """SLSQP's exit mode in the least-squares convention (see Estimate.status)."""
    mode = int(out.status)
    if mode == 0:
        return 2  # SLSQP stops on the change of the objective: the ftol criterion
    return 0 if mode == 9 else -mode


def polish(objective: Callable[[np.ndarray], float], x1: np.ndarray,
           bounds: tuple[np.ndarray, np.ndarray], tol: Tolerances = STRICT, *,
           constraints: Callable[[np.ndarray], np.ndarray] | None = None,
           gradient: Callable[[np.ndarray], np.ndarray] | None = None,
           metric: np.ndarray | None = None,
           local_constraints: Callable[[np.ndarray], Callable[[np.ndarray], np.ndarray]]
           | None = None) -> Estimate:
    """SLSQP on a scalar objective from ``x1`` with bounds and inequality constraints.

    The variables are scaled by max(|x1|, 1e-3) (SLSQP is sensitive to scaling), or, given a
    ``metric``, transformed so that the metric is the identity (see :func:`_whitening`); the
    result is clipped to the bounds.

    Parameters
    ----------
    objective : callable
        x -> scalar to minimise.
    x1 : ndarray
        Start, usually a least-squares solution.
    bounds : (ndarray, ndarray)
    tol : Tolerances
        ``polish_ftol`` and ``polish_maxiter`` apply.
    constraints : callable, optional
        x -> g (m,), every element must be >= 0.
    gradient : callable, optional
        x -> d objective / d x (k,), exact; default SLSQP's forward differences.
    metric : ndarray (k, k), optional
        An approximation of the objective's Hessian at ``x1``: for a least-squares objective
        0.5 r^T r the Gauss-Newton matrix J^T J of the least-squares solve that gave ``x1``.
        SLSQP's quasi-Newton model starts as the identity in its variables; in whitened
        variables that is this metric, so that the first step is a Gauss-Newton step instead
        of a gradient step, and SLSQP need not first build the curvature the least-squares
        solve already knows from its own iterations. Finite bounds become linear constraints.
    local_constraints : callable, optional
        x -> a function equal to ``constraints`` near x (FitProblem.local_constraints). With a
        ``metric``, the constraints' Jacobian is then SLSQP's own forward differences (the
        same steps, scipy.optimize.approx_fprime) of that function at each iterate: on the MF
        validity grid it evaluates the few grid points that set each minimum instead of
        thousands, 1 + k times per iteration.
    """
    lo, hi = (np.asarray(b, dtype=float) for b in bounds)
    T = None if metric is None else _whitening(metric)
    if T is None:
        scale = np.maximum(np.abs(x1), 1e-3)

        def to_x(z):
            return z * scale
        z0 = x1 / scale
        cons = ([{"type": "ineq", "fun": (lambda z: constraints(to_x(z)))}]
                if constraints is not None else [])
        grad = ((lambda z: np.asarray(gradient(to_x(z))) * scale) if gradient is not None
                else None)
        box = list(zip(lo / scale, hi / scale))
    else:
        def to_x(z):
            return x1 + T @ z
        z0 = np.zeros(x1.size)
        # x stays within finite bounds: linear constraints in z with their exact Jacobian
        lower, upper = np.isfinite(lo), np.isfinite(hi)
        rows = np.vstack([T[lower], -T[upper]])
        cons = [{"type": "ineq",
                 "fun": (lambda z: np.concatenate([(to_x(z) - lo)[lower],
                                                   (hi - to_x(z))[upper]])),
                 "jac": (lambda z: rows)}] if rows.shape[0] else []
        if constraints is not None:
            con = {"type": "ineq", "fun": (lambda z: constraints(to_x(z)))}
            if local_constraints is not None:
                def con_jac(z):
                    near = local_constraints(to_x(z))
                    return _forward_differences(lambda z1: near(to_x(z1)), z,
                                                getattr(near, "batch", None), to_x)
                con["jac"] = con_jac
            cons.append(con)
        grad = ((lambda z: T.T @ np.asarray(gradient(to_x(z)))) if gradient is not None
                else None)
        box = None

    def scaled(z):
        return objective(to_x(z))

    stall = _PolishStall(tol, None if constraints is None else (lambda z: constraints(to_x(z))))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        out = optimize.minimize(scaled, z0, jac=grad, method="SLSQP", bounds=box,
                                constraints=cons, callback=stall,
                                options={"ftol": tol.polish_ftol, "maxiter": tol.polish_maxiter})
    x = np.clip(to_x(stall.z if stall.fired else out.x), lo, hi)
    status, message, success = _slsqp_status(out), str(out.message), bool(out.success)
    if stall.fired:
        status, message, success = 2, (
            f"the objective changed by less than {tol.polish_ftol:g} over "
            f"{tol.noise_window} iterations, every constraint held to {FEASIBLE_TOL:g}"), True
    return Estimate(x=x, cost=float(objective(x)), fun=None, jac=None, nfev=int(out.nfev),
                    njev=int(getattr(out, "njev", 0) or 0), status=status,
                    message=message, success=success,
                    active_mask=np.where(x <= lo, -1, np.where(x >= hi, 1, 0)))


_SLSQP_STEP = float(np.sqrt(np.finfo(float).eps))
"""SLSQP's finite-difference step in its variables (scipy's default ``eps``)."""


def _forward_differences(fun: Callable[[np.ndarray], np.ndarray], z: np.ndarray,
                         batch: Callable[[np.ndarray], np.ndarray] | None,
                         to_x: Callable[[np.ndarray], np.ndarray]) -> np.ndarray:
    """scipy.optimize.approx_fprime(z, fun, _SLSQP_STEP) as a 2-D array: the same steps and
    differences (scipy's own), with the stepped points evaluated in one call of ``batch``
    (x rows (m, k) -> (m, constraints), equal to ``fun`` row by row: Constraint.batched)
    when there is one. ``to_x`` maps each stepped z to the x that ``batch`` takes, the map
    ``fun`` applies, point by point, so that every x is the one ``fun`` would see."""
    if batch is None or _approx_derivative is None:
        return np.atleast_2d(optimize.approx_fprime(z, fun, _SLSQP_STEP))

    def every_step(_fun, steps):
        return list(batch(np.array([to_x(z1) for z1 in steps])))

    z = np.asarray(z, dtype=float)
    return np.atleast_2d(_approx_derivative(fun, z, method="2-point", abs_step=_SLSQP_STEP,
                                            f0=fun(z), workers=every_step))


def _whitening(metric: np.ndarray) -> np.ndarray | None:
    """T with T^T metric T = identity (x = x1 + T z): metric = V diag(w) V^T, T = V w^-1/2,
    eigenvalues floored at 1e-12 x the largest (a direction the data do not determine gets a
    long but finite step). None for a metric that is not finite or not positive."""
    M = np.asarray(metric, dtype=float)
    if M.size == 0 or not np.all(np.isfinite(M)):
        return None
    w, V = np.linalg.eigh(0.5 * (M + M.T))
    if not w[-1] > 0:
        return None
    return V / np.sqrt(np.maximum(w, 1e-12 * w[-1]))


def fd_steps(x: np.ndarray, rel_step: float = 1e-6, floor: float = 1e-4) -> np.ndarray:
    """The central-difference steps of :func:`fd_jacobian`: rel_step x max(|x_j|, floor)."""
    return rel_step * np.maximum(np.abs(np.asarray(x, dtype=float)), floor)


def fd_jacobian(fun: Callable[[np.ndarray], np.ndarray], x: np.ndarray,
                bounds: tuple[np.ndarray, np.ndarray] | None = None, *,
                rel_step: float = 1e-6, floor: float = 1e-4) -> np.ndarray:
    """Central-difference Jacobian d fun / d x, (n, k).

    Step of x_j: h_j = rel_step x max(|x_j|, floor); a step that would cross a bound stops on
    it (the difference is then divided by the steps actually taken). One column per x_j,
    2 k evaluations of ``fun``; non-finite derivatives are 0.
    """
    x = np.asarray(x, dtype=float)
    lo, hi = ((np.full(x.size, -np.inf), np.full(x.size, np.inf)) if bounds is None
              else (np.asarray(b, dtype=float) for b in bounds))
    steps = fd_steps(x, rel_step, floor)
    cols = []
    for j, h in enumerate(steps):
        xp, xm = x.copy(), x.copy()
        xp[j] = min(x[j] + h, hi[j])
        xm[j] = max(x[j] - h, lo[j])
        with np.errstate(all="ignore"):
            cols.append((np.asarray(fun(xp), dtype=float) - np.asarray(fun(xm), dtype=float))
                        / (xp[j] - xm[j]))
    if not cols:
        return np.zeros((np.asarray(fun(x)).size, 0))
    G = np.column_stack(cols)
    return np.where(np.isfinite(G), G, 0.0)


def residual_jacobian(problem: FitProblem, x: np.ndarray) -> np.ndarray:
    """d(weighted residuals)/d(free parameters) of ``problem`` at ``x``, (n, k): the exact one
    when the problem has a Jacobian (FitProblem.jacobian), central differences otherwise."""
    exact = problem.residual_jacobian(x)
    if exact is not None:
        return exact
    return fd_jacobian(problem.residuals, x, problem.bounds())


def covariance_of(problem: FitProblem, x: np.ndarray, jac: np.ndarray | None = None,
                  fun: np.ndarray | None = None) -> tuple[np.ndarray, str, int, np.ndarray]:
    """:func:`covariance` of ``problem``'s free parameters at ``x``, as the problem asks
    (``FitProblem.covariance``): the delete-one-sweep jackknife over ``problem.clusters()``
    where it is defined (:func:`jackknife_defined`), else iid with sigma known when the
    problem's weights are 1/sigma (``problem.sigma`` set), estimated from the residuals
    otherwise; with the name of the one used, its number of clusters
    (``FitProblem.covariance_used``: FitResult.covariance, .clusters) and the degrees of
    freedom of each standard error (:func:`interval_dof`: FitResult.dof).

    ``jac``/``fun``: the Jacobian of the weighted residuals and the residuals at ``x`` when the
    caller has them (the least-squares solver's); by default :func:`residual_jacobian` (exact or
    central differences) and ``problem.residuals(x)`` -- for a point the solver did not return
    (a polish moved it; a start for MCMC)."""
    J = residual_jacobian(problem, x) if jac is None else jac
    r = problem.residuals(x) if fun is None else fun
    clusters = problem.clusters()
    # the jackknife, its degrees of freedom and whether it is defined from one decomposition
    both = None if clusters is None else jackknife_with_dof(J, r, clusters)
    defined = clusters is None or both is not None
    if both is None:
        how = {"sigma_known": problem.sigma is not None, "clusters": None}
        both = covariance(J, r, **how), interval_dof(J, **how)
    return (both[0], *problem.covariance_used(jackknife_defined=defined), both[1])


def problem_covariance(problem: FitProblem, x: np.ndarray, jac: np.ndarray | None = None,
                       fun: np.ndarray | None = None) -> np.ndarray:
    """The covariance of :func:`covariance_of` alone."""
    return covariance_of(problem, x, jac, fun)[0]


class CountingModel:
    """A model that counts its evaluations (``calls``); the values pass through unchanged.

    Jacobian callables are not model evaluations and are not counted.
    """

    def __init__(self, model: Callable[[Mapping[str, float]], np.ndarray]):
        self.model = model
        self.calls = 0

    def __call__(self, values: Mapping[str, float]) -> np.ndarray:
        self.calls += 1
        return self.model(values)


def counted(problem: FitProblem) -> tuple[FitProblem, CountingModel]:
    """A copy of ``problem`` whose model counts its evaluations, and the counter."""
    model = CountingModel(problem.model)
    return dataclasses.replace(problem, model=model), model
