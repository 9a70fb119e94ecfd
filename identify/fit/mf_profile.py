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
sweep jackknife: identify.fit.mf_uncertainty). The threshold carries the ratio of the jackknife
variance to the iid one (se_j^2 / (s^2 (G^-1)_jj)), so that where the cost is quadratic the
profile interval is the linearised one exactly, and elsewhere it follows the cost: wider,
narrower or lopsided. Each end is found from the linearised end by refits with j held
(the others start where the quadratic approximation puts them), stepping by the ratio of the
distance to the square root of the rise (exact for a quadratic cost). Where the cost at the
linearised end, on the approximation's line of conditional optima and after one Gauss-Newton
step from it, or the first refit, is within QUADRATIC of the threshold the linearised end is
kept; an end that would pass a
bound stops at it; an end whose refits do not converge stays linearised (counted in the
progress line).
"""
from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence

import numpy as np
import pandas as pd

from identify.core.progress import Progress
from identify.fit import engine
from identify.fit.identifiability import unidentified
from identify.fit.mf_result import MFFit
from identify.fit.mf_stages import stage_problem
from identify.fit.optimize import fit
from identify.fit.problem import FitProblem
from identify.fit.result import FitResult

__all__ = ["QUADRATIC", "profile_ends", "profile_intervals"]

QUADRATIC = 0.1
"""Relative tolerance on sqrt(rise / T_j) at the linearised end within which the cost counts as
quadratic and the linearised end is kept (an end moved by less than ~10 % of the half-width)."""
TOLERANCE = 0.05
"""Relative tolerance on sqrt(rise / T_j) of an end found by refits."""
MAX_REFITS = 6
"""Refits per end at most."""
MAX_GROWTH = 4.0
"""Largest factor by which one step moves the end outwards (a flat cost)."""
STEP_RCOND = 1e-5
"""Relative singular value (of the column-scaled Jacobian) below which the screening
Gauss-Newton step of :func:`_quadratic` leaves a direction alone: the undetermined ones (Fy's
RVY4 with a standard error 2e4 times its value) would otherwise take it far out."""
PROFILE_NFEV = 60
"""Budget of each refit's least-squares solve: they start next to their optimum (the
quadratic approximation's conditional optimum)."""
KEEP_REASONS = ("95 % interval wider than its bounds", "another minimum within the 95 % region")
"""Reasons a coefficient is not identifiable that its profile interval answers (it may come out
narrower than the bounds, or hold the other minimum); coefficients with any other reason (at a
bound, no finite standard error, a correlation above 0.99, resting on held ones) get none."""


def _rise(problem: FitProblem, j: int, value: float, start: np.ndarray, base: float
          ) -> float | None:
    """Least-squares cost with free coefficient ``j`` held at ``value``, the others refitted
    from each row of ``start`` (full coefficient vectors; the lowest end counts), less
    ``base``; None when the refit does not converge. The solves stop where the cost falls
    by less than 1e-2 s^2 (engine.SEARCH): a T_j is at least q^2 s^2, so the rise is known
    to better than 0.3 % of it."""
    name = problem.free[j]
    params = problem.parameters.copy()
    params[name].set(value=value, vary=False)
    held = dataclasses.replace(problem, parameters=params)
    starts = np.delete(np.atleast_2d(start), j, axis=1)
    if starts.shape[1] == 0:
        r = held.residuals(np.zeros(0))
        return float(r @ r) - base
    end = fit(held, starts=starts, max_nfev=PROFILE_NFEV, tol=engine.SEARCH)
    if not end.converged:
        return None
    return float(end.wls) - base


def _quadratic(problem: FitProblem, p: np.ndarray, j: int, base: float, threshold: float
               ) -> bool:
    """The cost is quadratic enough at the linearised end ``p`` (the quadratic approximation's
    conditional optimum with coefficient ``j`` at the end) to keep it without refits: the
    rise there, and after one Gauss-Newton step of the others from it, within QUADRATIC of
    the threshold (in its square root). Where the cost is quadratic ``p`` is the refitted
    optimum and the step does not move it; in a curved valley the line leaves the valley
    floor and the step falls back towards it (seed 10's PEX1: the rise on the line was
    within 10 % of T_j, the profile's a fraction of it)."""
    if not threshold > 0:
        return False
    r = problem.residuals(p)
    if abs(math.sqrt(max(float(r @ r) - base, 0.0) / threshold) - 1.0) > QUADRATIC:
        return False
    others = np.delete(np.arange(p.size), j)
    if others.size:
        Js, scale = engine.column_scaled(engine.residual_jacobian(problem, p)[:, others])
        step = np.linalg.lstsq(Js, -r, rcond=STEP_RCOND)[0] / scale
        lo, hi = problem.bounds()
        q = p.copy()
        q[others] = np.clip(p[others] + step, lo[others], hi[others])
        r2 = problem.residuals(q)
        if float(r2 @ r2) < float(r @ r):
            r = r2
    return abs(math.sqrt(max(float(r @ r) - base, 0.0) / threshold) - 1.0) <= QUADRATIC


def _end(problem: FitProblem, x: np.ndarray, j: int, side: int, half: float,
         threshold: float, direction: np.ndarray, base: float) -> float | None:
    """One end (``side`` -1 or +1) of coefficient ``j``'s profile interval (see module); None
    when a refit did not converge (the caller keeps the linearised end)."""
    lo, hi = problem.bounds()
    limit = hi[j] if side > 0 else lo[j]
    d = half
    v = x[j] + side * d
    if not (math.isfinite(limit) and (v - limit) * side >= 0) and _quadratic(
            problem, np.clip(x + (v - x[j]) * direction, lo, hi), j, base, threshold):
        return v
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
            return None
        g = math.sqrt(max(rise, 0.0) / threshold) if threshold > 0 else math.inf
        if abs(g - 1.0) <= (QUADRATIC if k == 0 else TOLERANCE):
            return x[j] + side * half if k == 0 and not at_limit else v
        if at_limit and g < 1.0:
            return v  # the cost stays below the threshold up to the bound
        d = d * min(1.0 / g, MAX_GROWTH) if g > 0 else d * MAX_GROWTH
    return x[j] + side * d


def profile_ends(problem: FitProblem, x: np.ndarray, names: Sequence[str],
                 stderr: dict[str, float], quantile: dict[str, float]
                 ) -> tuple[dict[str, tuple[float, float]], int]:
    """The 95 % profile intervals of ``names`` (free coefficients of ``problem``) at its
    optimum ``x`` (see module), from their standard errors and t quantiles; and the number of
    ends left linearised because a refit did not converge.

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
    """
    J = engine.residual_jacobian(problem, x)
    Js, scale = engine.column_scaled(J)
    Ginv = np.linalg.pinv(Js.T @ Js) / np.outer(scale, scale)
    r = problem.residuals(x)
    base = float(r @ r)
    out: dict[str, tuple[float, float]] = {}
    linear = 0
    for name in names:
        j = problem.free.index(name)
        gjj = Ginv[j, j]
        se, q = float(stderr[name]), float(quantile[name])
        if not (gjj > 0 and se > 0 and math.isfinite(se) and math.isfinite(q)):
            continue
        half = q * se
        threshold = half ** 2 / gjj
        direction = Ginv[:, j] / gjj  # the others' conditional optimum per unit of j
        ends = []
        for side in (-1, 1):
            e = _end(problem, x, j, side, half, threshold, direction, base)
            if e is None:
                linear += 1
                e = x[j] + side * half
            ends.append(float(e))
        out[name] = (ends[0], ends[1])
    return out, linear


def _profiled(r: FitResult) -> list[str]:
    """The free coefficients of ``r`` that get a profile interval (KEEP_REASONS)."""
    why = unidentified(r)
    return [n for n in r.free if why.get(n) is None or why[n] in KEEP_REASONS]


def profile_intervals(trailer: pd.DataFrame, mf: MFFit, progress: Progress | None = None
                      ) -> MFFit:
    """``mf`` with the 95 % profile interval (FitResult.profile) of every coefficient of every
    converged stage (but those :func:`_profiled` leaves out), after its standard errors are
    final (identify.fit.mf_uncertainty.propagate).

    Parameters
    ----------
    trailer : DataFrame
        The table ``mf`` was fitted on.
    mf : MFFit
        The staged fit.
    progress : callable, optional
        Gets one line per stage.
    """
    results = []
    for r in mf.results:
        names = _profiled(r) if r.converged else []
        hold = {n: "held in the fit" for n in r.parameters if n not in r.free}
        sp = stage_problem(r.form, trailer, mf.params, free={r.form: list(r.parameters)},
                           hold=hold) if names else None
        if sp is None or sp.problem.free != r.free:
            results.append(r)
            continue
        x = np.array([float(mf.params[n]) for n in r.free])
        ends, linear = profile_ends(sp.problem, x, names, dict(r.stderr),
                                    {n: r.quantile(n) for n in names})
        if progress is not None:
            moved = sum(1 for n, e in ends.items() if e != r.wald_interval(n))
            progress(f"MF [{r.form}]: profile intervals of {len(ends)} coefficients, "
                     f"{moved} not quadratic"
                     + (f", {linear} end(s) left linearised (refit did not converge)"
                        if linear else ""))
        results.append(dataclasses.replace(r, profile=ends))
    return dataclasses.replace(mf, results=tuple(results))
