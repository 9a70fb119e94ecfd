"""Global-search settings and result post-processing of the MF stages (identify.fit.mf.stages).

Start points (n_starts chosen deliberately: a stage has up to 29 free coefficients, so the
engine's 8 x free parameters Latin-hypercube starts over the full bounds would cost minutes and
mostly land in flat, meaningless regions): the carried-forward values, the parameter table's
defaults, and N_LHS Latin-hypercube points in a box of +/-BOX x max(|start|, |default|) around
the carried-forward values (+/-0.05 where both are 0).

Search, then solve (:func:`search`): every start is solved by least squares (SEARCH
tolerances, within SEARCH_NFEV evaluations) on an evenly spaced subsample of SUBSAMPLE points
(all points when there are fewer), where a start costs SUBSAMPLE/points of what it would on
all of them, and a start that reaches an earlier start's end point or path stops there
(MERGE_CHI2); only the distinct end points whose subsample objective is within CANDIDATE_RTOL
of the best (at most MAX_CANDIDATES) go on. On large data each candidate is carried up a
ladder of subsamples LADDER times larger each (:func:`ladder_sizes`: a small subsample's
optimum of many noisy points can lie far away in a flat direction, where the solver on all
points would crawl for its whole budget, while each rung's optimum starts the next one close
to its own), and is then solved on every point
(identify.fit.optimize.fit: MF_SOLVE tolerances, MAX_NFEV evaluations, the constrained polish
where a constraint is violated); the best of those is the stage's optimum.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
from scipy.stats import qmc

from identify.fit.mf.jacobian import CHUNK
from identify.fit.mf.stage_specs import stage_model
from identify.fit.optimize import BEST_RTOL
from identify.fit.result import FitResult
from identify.fit.solve import engine
from identify.fit.solve.engine import SEARCH
from identify.fit.solve.metric import thesis_error_by_group
from identify.fit.solve.problem import FitProblem
from identify.model.parameters import spec
from identify.model.state import OperatingState
from identify.model.symmetries import nearest_image, sign_patterns

__all__ = ["N_LHS", "MAX_NFEV", "REFIT_NFEV", "SEARCH_NFEV", "BOX", "SUBSAMPLE", "LADDER",
           "CANDIDATE_RTOL", "MAX_CANDIDATES", "CHI2_GAP", "Search", "start_points", "subsample",
           "ladder_sizes", "search", "refine_on", "prune", "final_predictions"]

N_LHS = 2
"""Latin-hypercube starts per stage besides the carried-forward and default values."""
MAX_NFEV = 100
"""Budget of model evaluations of each candidate's least-squares solve on all points
(Jacobian evaluations not counted). A candidate from the subsample search starts near the
optimum and converges in a few tens; one that crawls for longer is reported as not converged
instead of costing minutes."""
REFIT_NFEV = 40
"""Budget of a re-fit's least-squares solve on all points (identify.fit.mf.stages._refine): it
starts at the re-fit's optimum on the search's subsample, from where a re-fit the data
support converges within a few tens of evaluations at most. A re-fit that needs more (e.g.
QSX4, QSX5, QSX9 on Mx; RVY4..6 on Fy) is a product of weakly determined coefficients
running off along a flat valley, which is not taken in the end; a budget of MAX_NFEV would
only make it cost more on all points."""
SEARCH_NFEV = 200
"""Budget of each start's least-squares solve on the subsample (cheap: SUBSAMPLE points)."""
SUBSAMPLE = CHUNK
"""Points of the search's subsample: every (points/SUBSAMPLE)-th point of the stage in table
order, i.e. evenly along every sweep, so every load, pressure, camber and slip range is in it.
One of the exact Jacobian's chunks (identify.fit.mf.jacobian.CHUNK): no padding. A
subsample this small suffices because the solves on all points go on with the dogleg
(engine.DOGLEG_AFTER): a candidate from a small subsample may start in a curved valley of
all points, which the dogleg crosses where trf would crawl along it into MAX_NFEV. A larger
subsample costs more and ends at the same optima (bench/fit_cost.py times the stages,
bench/ttc_truth.py compares their ends with the truth)."""
LADDER = 4
"""Each rung of the ladder from the search's subsample to all points has this many times the
points of the one below."""
CANDIDATE_RTOL = 0.05
"""A search end point is a candidate for the solve on all points when its subsample objective
is within this fraction of the best one's (the subsample may rank close optima wrongly)."""
MAX_CANDIDATES = 2
"""At most this many candidates (the best ones) are solved on all points."""
CHI2_GAP = 25.0
"""After each rung of the ladder, a candidate whose objective exceeds the best one's by more
than CHI2_GAP in chi^2 = r^T r / s^2 (s^2 the best one's residual variance on that rung) is
dropped: on thousands of points such an optimum is worse beyond doubt (5 standard deviations
of a chi^2 difference of one parameter), and its constrained polish on all points would cost
as much as the best one's."""
DISTINCT_RTOL = 1e-4
"""Two end points are the same candidate when their objectives agree to
identify.fit.optimize.BEST_RTOL, every coefficient agrees to this fraction of max(|value|,
1e-3), or they are within MERGE_CHI2 in chi^2 (:func:`_same_optimum`)."""
BOX = 0.5
"""Half width of the start box relative to max(|start|, |default|) (0.05 absolute at 0)."""
MERGE_CHI2 = 1.0
"""A start of the search is stopped once it has reached an earlier start's end point x_e: its
iterate x within MERGE_CHI2 of x_e in chi^2, ||J_e (x - x_e)||^2 <= MERGE_CHI2 s^2 (J_e the
solver's Jacobian of the weighted residuals at x_e, s^2 = r^T r / (n - k) there), at a cost
0.5 r^T r within 0.5 MERGE_CHI2 s^2 of x_e's: within a standard error of that optimum, in its
basin, where the solve would end (its own stop is a chi^2 change below 0.02 over 5
iterations, which the last iterations of a start along a flat valley took tens of evaluations
to reach). The start then counts as ending at x_e (the same candidate). A start far below
x_e's cost has not reached it, whatever the metric says: J_e is the metric of a minimum only
where x_e is one, and a solve can stop with a vanishing gradient on a plateau (coefficients
running off to 1e22, every column of J_e near zero); a bound of x_e's cost only from above
would stop a start far below such a plateau as having reached it, and end the stage there
(tests/unit/test_fit_mf_jacobian.py::test_a_start_far_below_an_earlier_end_point_has_not_reached_it).
With the exact
Jacobian, the same test against every iterate x_t of the earlier starts' paths, in the metric
of the Jacobian J at x (||J (x - x_t)||^2 <= MERGE_CHI2 s^2, |cost - cost_t| <= 0.5 MERGE_CHI2
s^2): a start within a standard error of where another one passed, at the same cost, goes where
that one went, so a start that joins an earlier one's path in a curved valley stops there
instead of walking the rest of the valley again."""


def start_points(problem: FitProblem, n_lhs: int, seed: int) -> np.ndarray:
    """Carried-forward values, table defaults (if different) and ``n_lhs`` Latin-hypercube
    points in the +/-BOX box (clipped to the bounds), one row each."""
    x0 = problem.x0()
    lo, hi = problem.bounds()
    rows = [x0]
    # a default whose bounds apply to the magnitude takes the sign of the start (PKY1 ...)
    dflt = np.array([abs(float(spec(n).default)) * (1.0 if x >= 0 else -1.0)
                     if spec(n).magnitude_bounds else float(spec(n).default)
                     for n, x in zip(problem.free, x0)])
    dflt = np.clip(dflt, lo, hi)
    if not np.array_equal(dflt, x0):
        rows.append(dflt)
    if n_lhs > 0 and x0.size:
        half = np.where(np.maximum(np.abs(x0), np.abs(dflt)) > 0,
                        BOX * np.maximum(np.abs(x0), np.abs(dflt)), 0.05)
        a, b = np.maximum(x0 - half, lo), np.minimum(x0 + half, hi)
        u = qmc.LatinHypercube(d=x0.size, seed=np.random.default_rng(seed)).random(n_lhs)
        rows.extend(a + u * (b - a))
    return np.vstack(rows)


def subsample(n: int, size: int = SUBSAMPLE) -> np.ndarray | None:
    """Positions of an evenly spaced subsample of ``size`` of ``n`` points, or None when
    ``n <= size`` (all points are used)."""
    if n <= size:
        return None
    return np.unique(np.round(np.linspace(0, n - 1, size)).astype(int))


def ladder_sizes(n: int) -> list[int]:
    """Subsample sizes between the search's and all ``n`` points: SUBSAMPLE x LADDER^i < n
    for i >= 1 (none when n <= LADDER x SUBSAMPLE)."""
    sizes, size = [], SUBSAMPLE * LADDER
    while size < n:
        sizes.append(size)
        size *= LADDER
    return sizes


def _within_merge(J: np.ndarray, dx: np.ndarray, s2: float) -> bool:
    """A step ``dx`` within MERGE_CHI2 in chi^2 in the metric of ``J``: ||J dx||^2 <=
    MERGE_CHI2 s^2."""
    with np.errstate(over="ignore", invalid="ignore"):  # a runaway step: not within (inf)
        d = J @ dx
        return bool(d @ d <= MERGE_CHI2 * s2)


def prune(problem: FitProblem, candidates: list[np.ndarray]) -> list[np.ndarray]:
    """The candidates within CHI2_GAP of the best on ``problem`` (a rung), best first."""
    costs = np.array([problem.objective_value(x) for x in candidates])  # 0.5 r^T r
    costs = np.where(np.isfinite(costs), costs, np.inf)
    order = np.argsort(costs, kind="stable")
    best = costs[order[0]]
    s2 = engine.residual_variance(best, problem.measured.size, len(problem.free))
    return [candidates[i] for i in order if 2.0 * (costs[i] - best) <= CHI2_GAP * s2]


def refine_on(problem: FitProblem, x0: np.ndarray) -> tuple[np.ndarray, int]:
    """Least squares on ``problem`` (a rung of the ladder) from ``x0`` with the SEARCH
    tolerances within SEARCH_NFEV evaluations: (end point, model evaluations)."""
    problem, counter = engine.counted(problem)
    jac = problem.residual_jacobian if problem.jacobian is not None else None
    end = engine.least_squares(problem.residuals, x0, problem.bounds(), SEARCH, jac=jac,
                               max_nfev=SEARCH_NFEV)
    return end.x, counter.calls


@dataclass(frozen=True)
class Search:
    """The outcome of a stage's search on the subsample.

    Attributes
    ----------
    candidates : ndarray       distinct end points to solve on all points, best first (c, k)
    n_starts : int             starts searched
    starts_at_best : int       starts whose end point is the best one's optimum (the same
                               point, or within MERGE_CHI2 of it in chi^2)
    points : int               points of the subsample
    nfev : int                 model evaluations of the search (on the subsample)
    converged : bool           the best end point's solve converged (within SEARCH_NFEV)
    """

    candidates: np.ndarray
    n_starts: int
    starts_at_best: int
    points: int
    nfev: int
    converged: bool = True


class _Reached:
    """engine.least_squares ``stop`` of one start: the message of a start that has reached an
    earlier start's end point or path (see MERGE_CHI2), recorded in ``into`` (that start's
    index). Records the start's own path (``path``: iterates and costs); ``jac`` keeps the
    exact Jacobian (engine.KeptJacobian), so that the check has the Jacobian at the iterate
    (without one, end points only, in their own solver's metric)."""

    def __init__(self, ends: list[engine.Estimate], paths: list[list[tuple[np.ndarray, float]]],
                 signs: np.ndarray, jac=None):
        n_free = signs.shape[1]
        self.signs = signs  # sign_patterns of the free coefficients
        self.ends = [(j, e.x, e.jac, e.cost,
                      engine.residual_variance(e.cost, e.fun.size, n_free))
                     for j, e in enumerate(ends)
                     if e.success and e.jac is not None and e.jac.shape[1] == n_free]
        self.paths = [(j, paths[j], s2) for j, _, _, _, s2 in self.ends]
        self.path: list[tuple[np.ndarray, float]] = []
        self.into: int | None = None
        self.jac = None if jac is None else engine.KeptJacobian(jac)

    def __call__(self, x: np.ndarray, cost: float) -> str | None:
        self.path.append((np.array(x, dtype=float), cost))
        # x's mirror image nearest the end (identify.model.symmetries: the same prediction
        # and cost; the Jacobian at a mirror image is J with the flipped columns negated, so
        # the path test compares x with the path points' images nearest it in the metric of J)
        for j, xe, Je, ce, s2 in self.ends:
            if (abs(cost - ce) <= 0.5 * MERGE_CHI2 * s2
                    and _within_merge(Je, nearest_image(x, xe, self.signs) - xe, s2)):
                self.into = j
                return f"reached the end point of start {j + 1}"
        J = None if self.jac is None else self.jac.at(x)
        if J is None:
            return None
        for j, path, s2 in self.paths:
            for xt, ct in path:
                if abs(cost - ct) > 0.5 * MERGE_CHI2 * s2:
                    continue
                if _within_merge(J, x - nearest_image(xt, x, self.signs), s2):
                    self.into = j
                    return f"reached the path of start {j + 1}"
        return None


def _same_optimum(end: engine.Estimate, obj: float, x: np.ndarray, x_obj: float,
                  n_free: int) -> bool:
    """``x`` (another start's end point, objective ``x_obj``) is ``end``'s optimum (objective
    ``obj``): the same objective to identify.fit.optimize.BEST_RTOL (mirror images such as
    Mz0's (QBZ9, QBZ10) and (-QBZ9, -QBZ10) predict bit for bit the same), every coefficient
    within DISTINCT_RTOL of max(|value|, 1e-3), or within MERGE_CHI2 of it in chi^2 in the
    metric of its solver's Jacobian (||J (x - x_e)||^2 <= MERGE_CHI2 s^2, as a start's merge:
    a start stopped along a flat valley has its end's objective only to the solver's noise
    stop). The objective without identify.fit.optimize.BEST_ATOL: the search's objectives are
    0.5 r^T r of weighted residuals, which can be far below it on large sessions, where an
    absolute tolerance would take distinct basins for one (tests/unit/test_fit_mf_basins.py keeps
    two minima whose objectives differ by far less than BEST_ATOL)."""
    if abs(x_obj - obj) <= BEST_RTOL * abs(obj):
        return True
    scale = np.maximum(np.abs(end.x), 1e-3)
    if np.all(np.abs(x - end.x) <= DISTINCT_RTOL * scale):
        return True
    if end.jac is None or end.jac.shape[1] != x.size or end.fun is None:
        return False
    s2 = engine.residual_variance(end.cost, end.fun.size, n_free)
    return _within_merge(end.jac, x - end.x, s2)


def search(problem: FitProblem, starts: np.ndarray) -> Search:
    """Solve every start by least squares on ``problem`` (the stage's subsample) with the
    SEARCH tolerances and SEARCH_NFEV evaluations, and pick the candidates (see module). A
    start that reaches an earlier one's end point or path stops there and ends at its end
    point (MERGE_CHI2)."""
    problem, counter = engine.counted(problem)
    jac = problem.residual_jacobian if problem.jacobian is not None else None
    ends: list[engine.Estimate] = []
    paths: list[list[tuple[np.ndarray, float]]] = []
    signs = sign_patterns(problem.free, problem.values())
    for x0 in np.atleast_2d(starts):
        reached = _Reached(ends, paths, signs, jac)
        end = engine.least_squares(problem.residuals, x0, problem.bounds(), SEARCH,
                                   jac=reached.jac, max_nfev=SEARCH_NFEV, stop=reached)
        paths.append(reached.path)
        ends.append(end if reached.into is None else dataclasses.replace(
            ends[reached.into], message=end.message, nfev=end.nfev, njev=end.njev))
    # 0.5 r^T r at each end point: the solver's cost there (weighted least squares)
    objs = np.array([e.cost if problem.objective == "wls" else problem.objective_value(e.x)
                     for e in ends])
    objs = np.where(np.isfinite(objs), objs, np.inf)
    order = np.argsort(objs, kind="stable")
    best = objs[order[0]]
    n_free = len(problem.free)
    # a start at a mirror image of the best reached the best too (as for the candidates below)
    at_best = sum(_same_optimum(ends[order[0]], best,
                                nearest_image(e.x, ends[order[0]].x, signs), o, n_free)
                  for e, o in zip(ends, objs))
    chosen: list[tuple[engine.Estimate, float]] = []
    for i in order:
        if chosen and not objs[i] <= best + CANDIDATE_RTOL * abs(best):
            break
        # an end point or a mirror image of it (the same prediction; identify.model.symmetries)
        if any(_same_optimum(c, o, nearest_image(ends[i].x, c.x, signs), objs[i], n_free)
               for c, o in chosen):
            continue
        chosen.append((ends[i], float(objs[i])))
        if len(chosen) == MAX_CANDIDATES:
            break
    return Search(candidates=np.vstack([c.x for c, _ in chosen]), n_starts=len(ends),
                  starts_at_best=int(at_best),
                  points=int(problem.measured.size), nfev=counter.calls,
                  converged=bool(ends[order[0]].success))


def final_predictions(result: FitResult, problem: FitProblem, s: OperatingState,
                      params: Mapping[str, float], omega: np.ndarray | None = None
                      ) -> FitResult:
    """``result`` with the predictions (and errors) of the final parameter set: a later
    stage's coefficients can act on an earlier stage's points (SSZ on the Mz0 points), and the
    reported predictions must be what the written .tir gives. ``omega``: the measured wheel
    speed of the geometry stage's points."""
    model = stage_model(result.form, params, s, omega)
    pred = np.asarray(model({n: params[n] for n in result.parameters}), dtype=float)
    if np.array_equal(pred, result.predicted):
        return result
    r = (pred - result.measured) * problem.weights()
    by_p = thesis_error_by_group(pred, result.measured, result.pressure_bar)
    return dataclasses.replace(result, predicted=pred, wls=float(r @ r),
                               error_by_pressure_pct=by_p,
                               error_total_pct=float(np.mean(list(by_p.values()))))
