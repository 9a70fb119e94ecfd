"""95 % profile intervals of the MF stages' coefficients (FitResult.profile).

The interval value +/- t standard errors (FitResult.wald_interval) rests on the objective being
quadratic in the coefficients over the interval: the least-squares cost rises by d^2 / (G^-1)_jj
when coefficient j is moved by d from the optimum and the others are refitted (G = J^T J of
the weighted residuals). Where the Magic Formula's shape factors trade against each other along
a curved valley, it is not: on a generated TTC session (seed 10, the Fx0 stage; PCX1 = 1.90 +-
0.10, truth 1.6) the cost with PCX1 held at the truth, the others refitted, rose by 2.5 in units
where the 95 % end lies at t^2 = 4.6, where the quadratic approximation puts 8.2; QEZ5 of Mz0
(seed 13, -1.94 +- 0.18, truth 0) rose by 2.6 instead of 121: the linearised intervals missed
the truth by 3 and 11 standard errors where the data did not (docs/intervals.md).

For each coefficient j the profile interval is where the refitted cost reaches the rise that the
quadratic approximation gives at the ends of the linearised interval,

    T_j = q_j^2 se_j^2 / (G^-1)_jj,

q_j Student's t at the coefficient's degrees of freedom and se_j its standard error (the staged
sweep jackknife: identify.fit.mf.uncertainty). The threshold carries the ratio of the jackknife
variance to the iid one (se_j^2 / (s^2 (G^-1)_jj)), so that where the cost is quadratic the
profile interval is the linearised one exactly. An end only moves outwards, where the profile
is flatter than the approximation: the cost at the linearised end, on the approximation's line
of conditional optima and after one Gauss-Newton step from it, and then in the first refit
with j held, has risen by less than (1 - QUADRATIC)^2 T_j. Further refits (from two starts)
step by the ratio of the distance to the square root of the rise (exact for a quadratic cost)
until it is within TOLERANCE of T_j. Where the profile is steeper the linearised end is kept:
the variance ratio is read at the optimum, and narrowing on it cost 7 of 291 intervals their
truth on the Formula Student tyre (docs/intervals.md). An end past a bound is the bound; an
end whose refits do not converge stays linearised (counted in the progress line). Only the
identifiable coefficients get a profile (:func:`_profiled`). The refits of one stage are
budgeted (:data:`STAGE_REFITS`): every end is screened first, the flattest are refitted first,
and the ends the budget does not reach keep their linearised ends (counted in the progress
line), so that a real session whose costs are flat along many coefficients cannot spend
minutes here; a count of refits, not seconds, keeps the intervals the same on any machine.
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from concurrent.futures import Executor, Future

import numpy as np
import pandas as pd

from identify.core.progress import Progress
from identify.fit.identifiability import unidentified
from identify.fit.mf.problem import fitted_problem
from identify.fit.mf.result import MFFit
from identify.fit.optimize import fit
from identify.fit.result import FitResult
from identify.fit.solve import engine
from identify.fit.solve.problem import FitProblem, with_fixed

__all__ = ["QUADRATIC", "STAGE_REFITS", "ProfileEnds", "profile_ends", "profile_intervals"]

QUADRATIC = 0.1
"""The linearised end is kept unless sqrt(rise / T_j) there is below 1 - QUADRATIC (the end
would move out by more than ~10 % of the half-width)."""
TOLERANCE = 0.05
"""Relative tolerance on sqrt(rise / T_j) of an end found by refits."""
MAX_REFITS = 6
"""Refits per end at most."""
MAX_GROWTH = 4.0
"""Largest factor by which one step moves the end outwards (a flat cost)."""
STEP_RCOND = 1e-5
"""Relative singular value (of the column-scaled Jacobian) below which the screening
Gauss-Newton step of :func:`_steepness` leaves a direction alone: the undetermined ones (Fy's
RVY4 with a standard error 2e4 times its value) would otherwise take it far out."""
STAGE_REFITS = 150
"""Refits one stage's profile intervals may take in all (each at most 2 starts x
PROFILE_NFEV evaluations): the flattest ends first, the rest keep their linearised ends. A
generated TTC session takes 0-30 per stage (see docs/intervals.md); a real session whose
costs are flat along many coefficients could otherwise take minutes per stage."""
PROFILE_NFEV = 60
"""Budget of each refit's least-squares solve: they start next to their optimum (the
quadratic approximation's conditional optimum)."""


def _rise(problem: FitProblem, j: int, value: float, start: np.ndarray, base: float
          ) -> float | None:
    """Least-squares cost with free coefficient ``j`` held at ``value``, the others refitted
    from each row of ``start`` (full coefficient vectors; the lowest end counts), less
    ``base``; None when the refit does not converge. The solves stop where the cost falls
    by less than 1e-2 s^2 (engine.SEARCH): a T_j is at least q^2 s^2, so the rise is known
    to better than 0.3 % of it."""
    start = np.atleast_2d(start)
    at = start[0].copy()
    at[j] = value
    held = with_fixed(problem, [problem.free[j]], at)
    starts = np.delete(start, j, axis=1)
    if starts.shape[1] == 0:
        r = held.residuals(np.zeros(0))
        return float(r @ r) - base
    end = fit(held, starts=starts, max_nfev=PROFILE_NFEV, tol=engine.SEARCH)
    if not end.converged:
        return None
    return float(end.wls) - base


def _steepness(problem: FitProblem, p: np.ndarray, j: int, base: float, threshold: float
               ) -> float:
    """sqrt(rise / threshold) at the linearised end ``p`` (the quadratic approximation's
    conditional optimum with coefficient ``j`` at the end): the lower of the cost on that line
    and after one Gauss-Newton step of the others from it. Below 1 - QUADRATIC the profile is
    flatter than the approximation there and the end moves out. Where the cost is quadratic
    ``p`` is the refitted optimum and the step does not move it; in a curved valley the line
    leaves the valley floor and the step falls back towards it (seed 10's PEX1: the rise on
    the line was within 10 % of T_j, the profile's a fraction of it). Infinite without a
    threshold."""
    if not threshold > 0:
        return math.inf
    r = problem.residuals(p)
    g = math.sqrt(max(float(r @ r) - base, 0.0) / threshold)
    others = np.delete(np.arange(p.size), j)
    if g < 1.0 - QUADRATIC or not others.size:
        return g
    Js, scale = engine.column_scaled(engine.residual_jacobian(problem, p)[:, others])
    step = np.linalg.lstsq(Js, -r, rcond=STEP_RCOND)[0] / scale
    lo, hi = problem.bounds()
    q = p.copy()
    q[others] = np.clip(p[others] + step, lo[others], hi[others])
    r2 = problem.residuals(q)
    return min(g, math.sqrt(max(float(r2 @ r2) - base, 0.0) / threshold))


def _refit_end(problem: FitProblem, x: np.ndarray, j: int, side: int, half: float,
               threshold: float, direction: np.ndarray, base: float) -> tuple[float | None, int]:
    """One end (``side`` -1 or +1) of coefficient ``j``'s profile interval whose screen found
    the cost flatter (see module), and the refits it took; None for the end when a refit did
    not converge (the caller keeps the linearised end)."""
    lo, hi = problem.bounds()
    limit = hi[j] if side > 0 else lo[j]
    wald = x[j] + side * half
    d = half
    for k in range(MAX_REFITS):
        v = x[j] + side * d
        at_limit = math.isfinite(limit) and (v - limit) * side >= 0
        if at_limit:
            v, d = float(limit), abs(float(limit) - x[j])
        # two starts: the others where the quadratic approximation puts them, and where
        # they are (a cost with two valleys: the profile follows the lower; seed 10's RVY5
        # held at -1.9 rose by 4.2 T from the first and 1.7 T from the second)
        start = np.clip(np.vstack([x + (v - x[j]) * direction, x]), lo, hi)
        rise = _rise(problem, j, v, start, base)
        if rise is None:
            return None, k + 1
        g = math.sqrt(max(rise, 0.0) / threshold)
        if k == 0 and g >= 1.0 - QUADRATIC:
            return wald, 1
        if abs(g - 1.0) <= TOLERANCE or (at_limit and g < 1.0):
            return v, k + 1
        # outwards only: the linearised end stays the nearest
        d = max(half, d * min(1.0 / g, MAX_GROWTH) if g > 0 else d * MAX_GROWTH)
    return x[j] + side * d, MAX_REFITS


@dataclasses.dataclass(frozen=True)
class ProfileEnds:
    """The 95 % intervals :func:`profile_ends` found, and what it did to find them.

    Attributes
    ----------
    ends : dict of str -> (float, float)
        Each profiled coefficient's interval.
    unconverged : int
        Ends left linearised because a refit did not converge.
    over_budget : int
        Ends whose screen found the cost flatter but left linearised: the stage's refits
        were spent (:data:`STAGE_REFITS`).
    refits : int
        Refits done (each a least-squares solve with one coefficient held, two starts).
    """

    ends: dict
    unconverged: int = 0
    over_budget: int = 0
    refits: int = 0


def profile_ends(problem: FitProblem, x: np.ndarray, names: Sequence[str],
                 stderr: dict[str, float], quantile: dict[str, float],
                 budget: int = STAGE_REFITS, screened=None) -> ProfileEnds:
    """The 95 % profile intervals of ``names`` (free coefficients of ``problem``) at its
    optimum ``x`` (see module), from their standard errors and t quantiles.

    Every end is screened first (:func:`_steepness`); the ends found flatter are then refitted,
    the flattest first, until ``budget`` refits are spent; the rest keep their linearised
    ends (counted in ``over_budget``).

    Parameters
    ----------
    problem : FitProblem
        The problem ``x`` solves (its constraints and bounds hold in every refit).
    x : ndarray
        The optimum, in ``problem.free`` order.
    names : sequence of str
        The coefficients to profile.
    stderr, quantile : dict
        Each name's standard error and the t quantile of its interval (FitResult.stderr,
        FitResult.quantile).
    budget : int
        Refits allowed in all (:data:`STAGE_REFITS`).
    screened : callable, optional
        Called with the screen (:class:`_Screen`) before any refit.
    """
    J = engine.residual_jacobian(problem, x)
    Js, scale = engine.column_scaled(J)
    Ginv = np.linalg.pinv(Js.T @ Js) / np.outer(scale, scale)
    r = problem.residuals(x)
    base = float(r @ r)
    lo, hi = problem.bounds()
    ends: dict[str, list[float]] = {}
    flatter = []  # (steepness, name, side, j, half, threshold, direction) of the ends to refit
    for name in names:
        j = problem.free.index(name)
        gjj = Ginv[j, j]
        se, q = float(stderr[name]), float(quantile[name])
        if not (gjj > 0 and se > 0 and math.isfinite(se) and math.isfinite(q)):
            continue
        half = q * se
        threshold = half ** 2 / gjj
        direction = Ginv[:, j] / gjj  # the others' conditional optimum per unit of j
        ends[name] = [x[j] - half, x[j] + half]
        for k, side in enumerate((-1, 1)):
            limit = hi[j] if side > 0 else lo[j]
            if math.isfinite(limit) and (x[j] + side * half - limit) * side >= 0:
                ends[name][k] = float(limit)  # the coefficient does not go past its bound
                continue
            g = _steepness(problem, np.clip(x + side * half * direction, lo, hi), j, base,
                           threshold)
            if g < 1.0 - QUADRATIC:
                flatter.append((g, name, k, j, half, threshold, direction))
    screen = _Screen(ends, sorted(flatter, key=lambda e: e[0]), base)
    if screened is not None:
        screened(screen)
    return _spend(screen, lambda i, flat: _refit_flatter(problem, x, flat, base), budget)


@dataclasses.dataclass(frozen=True)
class _Screen:
    """:func:`profile_ends` before its refits: the linearised ends (at a bound where one is
    passed), the ends found flatter, flattest first, as (steepness, name, side index, j,
    half-width, threshold, direction), and the cost at the optimum."""

    ends: dict
    flatter: list
    base: float


def _refit_flatter(problem: FitProblem, x: np.ndarray, flat: tuple, base: float
                   ) -> tuple[float | None, int]:
    """:func:`_refit_end` of one flatter end of a :class:`_Screen`."""
    _g, _name, k, j, half, threshold, direction = flat
    return _refit_end(problem, x, j, 2 * k - 1, half, threshold, direction, base)


def _spend(screen: _Screen, refit, budget: int) -> ProfileEnds:
    """The refits of :func:`profile_ends` within ``budget``: ``refit(i, flat)`` is
    :func:`_refit_flatter` of the i-th flatter end."""
    ends = {n: list(v) for n, v in screen.ends.items()}
    unconverged = over_budget = refits = 0
    for i, flat in enumerate(screen.flatter):
        if refits + MAX_REFITS > budget:  # an end may take MAX_REFITS: never over budget
            over_budget += 1
            continue
        end, used = refit(i, flat)
        refits += used
        if end is None:
            unconverged += 1
        else:
            ends[flat[1]][flat[2]] = float(end)
    return ProfileEnds({n: (a, b) for n, (a, b) in ends.items()}, unconverged, over_budget,
                       refits)


def _profiled(r: FitResult) -> list[str]:
    """The free coefficients of ``r`` that get a profile interval: the identifiable ones
    (identify.fit.identifiability.unidentified). A coefficient without a usable linearised
    interval has a near-null direction at the optimum, where the jackknife's variance ratio
    that scales the threshold is least trustworthy: on the Formula Student tyre such profiles
    came out far narrower than their bounds and missed the truth (QSX7 of Mx, Fx0's PEX1)."""
    why = unidentified(r)
    return [n for n in r.free if n not in why]


def _stage_problem(trailer: pd.DataFrame, params: dict, r: FitResult
                   ) -> tuple[FitProblem, np.ndarray] | None:
    """The problem of stage ``r`` built again at the staged fit's values ``params`` and its
    optimum; None when it cannot be built as it was fitted. From picklable arguments alone,
    so that a worker process builds the same problem (:func:`profile_intervals`)."""
    sp = fitted_problem(trailer, params, r)
    if sp is None or sp.problem.free != r.free:
        return None
    return sp.problem, np.array([float(params[n]) for n in r.free])


def _stage_screen(trailer: pd.DataFrame, params: dict, r: FitResult, names: list[str]
                  ) -> _Screen | None:
    """:func:`profile_ends`' screen of stage ``r`` (a job of :func:`profile_intervals`)."""
    built = _stage_problem(trailer, params, r)
    if built is None:
        return None
    problem, x = built
    screen: list[_Screen] = []
    profile_ends(problem, x, names, dict(r.stderr), {n: r.quantile(n) for n in names},
                 budget=0, screened=screen.append)
    return screen[0]


def _stage_refit(trailer: pd.DataFrame, params: dict, r: FitResult, flat: tuple, base: float
                 ) -> tuple[float | None, int]:
    """:func:`_refit_flatter` of one end of stage ``r`` (a job of :func:`profile_intervals`)."""
    problem, x = _stage_problem(trailer, params, r)
    return _refit_flatter(problem, x, flat, base)


def profile_intervals(trailer: pd.DataFrame, mf: MFFit, progress: Progress | None = None, *,
                      pool: Executor | None = None) -> MFFit:
    """``mf`` with the 95 % interval (FitResult.profile) of every identifiable coefficient of
    every converged stage (:func:`_profiled`), after its standard errors are final
    (identify.fit.mf.uncertainty.propagate).

    Parameters
    ----------
    trailer : DataFrame
        The table ``mf`` was fitted on.
    mf : MFFit
        The staged fit.
    progress : callable, optional
        Gets one line per stage.
    pool : Executor, optional
        Worker processes (identify.core.workers.process_pool) that take the stages' screens
        and refits, which do not depend on each other (:func:`_pooled`); the results are
        those of the serial loop (each screen and refit is computed from its own picklable
        arguments alone), reported in stage order. None: one stage after the other, here.
    """
    params = dict(mf.params)
    names = [_profiled(r) if r.converged else [] for r in mf.results]
    found: dict[int, ProfileEnds | None] = {}
    if pool is not None and any(names):
        found = _pooled(pool, trailer, params, mf.results, names)
    results = []
    for i, r in enumerate(mf.results):
        if i in found:
            ends_found = found[i]
        elif names[i] and (built := _stage_problem(trailer, params, r)) is not None:
            problem, x = built
            ends_found = profile_ends(problem, x, names[i], dict(r.stderr),
                                      {n: r.quantile(n) for n in names[i]})
        else:
            ends_found = None
        if ends_found is None:
            results.append(r)
            continue
        ends = ends_found.ends
        if progress is not None:
            wald = {n: r.wald_interval(n) for n in ends}
            moved = sum(1 for n, (a, b) in ends.items() if a < wald[n][0] or b > wald[n][1])
            progress(f"MF [{r.form}]: 95 % intervals of {len(ends)} coefficients, {moved} "
                     f"widened to the objective's profile ({ends_found.refits} refits)"
                     + (f", {ends_found.unconverged} end(s) left linearised (refit did not "
                        "converge)" if ends_found.unconverged else "")
                     + (f", {ends_found.over_budget} flatter end(s) left linearised (the "
                        f"stage's {STAGE_REFITS} refits spent)" if ends_found.over_budget
                        else ""))
        results.append(dataclasses.replace(r, profile=ends))
    return dataclasses.replace(mf, results=tuple(results))


def _pooled(pool: Executor, trailer: pd.DataFrame, params: dict, results, names
            ) -> dict[int, ProfileEnds | None]:
    """Every stage's :func:`profile_ends` with the work in ``pool``: the stages' screens, then
    every refit the budget is sure to spend (the first STAGE_REFITS // MAX_REFITS flatter ends
    of a stage, whatever the refits before them take), each a job, so that a stage with many
    flatter ends does not run alone; the budget is then spent in order as
    :func:`profile_ends` spends it, the rest of it here. The same intervals as one process."""
    screens = {i: pool.submit(_stage_screen, trailer, params, results[i], names[i])
               for i in range(len(results)) if names[i]}
    sure = STAGE_REFITS // MAX_REFITS
    jobs: dict[int, tuple[_Screen | None, list[Future]]] = {}
    for i, job in screens.items():
        screen = job.result()
        jobs[i] = (screen, [] if screen is None else [
            pool.submit(_stage_refit, trailer, params, results[i], flat, screen.base)
            for flat in screen.flatter[:sure]])
    found: dict[int, ProfileEnds | None] = {}
    for i, (screen, refits) in jobs.items():
        if screen is None:
            found[i] = None
            continue

        def refit(k, flat, i=i, screen=screen, refits=refits):
            if k < len(refits):
                return refits[k].result()
            return _stage_refit(trailer, params, results[i], flat, screen.base)
        found[i] = _spend(screen, refit, STAGE_REFITS)
    return found
