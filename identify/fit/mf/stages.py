"""Fit the Magic Formula slip coefficients to trailer data in stages.

Stages, in order (identify.fit.mf.stage_specs.DEFAULT_STAGES): Fx0, Fy0, Mz0 on pure-slip
points, then Fx, Fy, Mz on combined-slip points (Fx with the rolling runs' drag, Mz with every
point that has a slip ratio: identify.fit.mf.stage_specs), then Mx and My, then vertical
(the loaded radius Rl, a trailer's RL channel, on free-rolling points, with the fitted forces:
Q_RE0, VERTICAL_STIFFNESS, PFZ1, Q_FZ2, Q_V1, Q_V2, Q_FCY, the last held at 0 when not
significant, identify.fit.mf.minima.even_effect; skipped without a loaded radius or a wheel
speed, and by the workflow when the Flatplank CFz relation supplies the stiffness) and geometry
(the effective rolling radius Re = Vx/omega on free-rolling points: Q_RE0, Q_V1, DREFF, FREFF,
BREFF, with the vertical stiffness VERTICAL_STIFFNESS, PFZ1 held at the carried-forward values,
and Q_RE0, Q_V1 held where the vertical stage fitted them: a coefficient two stages list is
fitted by the first that frees it; skipped without a wheel-speed channel). Each stage

* selects its points and fits one channel (weighted least squares, each pressure weighted by
  1/sqrt(sum of the squared measurements), so the objective is the sum over pressures of the
  squared thesis errors / 100^2; FitResult reports the thesis error per pressure too);
* frees only its own coefficients (the parameter table's ``fit_default_vary`` ones, pressure
  coefficients included), minus those the data cannot identify (identify.fit.mf.screen: not
  covered by the data, no effect, not separable or negligible at the start values; after the
  global fit a coefficient that had no effect only because another was 0 at the start is
  freed and the stage re-fitted from the optimum and from the search's other candidates near
  it, whose basin can become the lower one), and holds every other value at what the earlier
  stages carried forward; the held coefficients and why are in ``MFFit.held``;
* enforces MFeval's validity conditions on the 11-point grid (identify.fit.mf.constraints)
  between the table's ranges of load, slip ratio, slip angle and camber
  (identify.fit.limits.table_limits), widened to the other fitted points' (``reach``): the
  written .tir's limits, not the start .tir's (see :func:`fit_mf`);
* evaluates the model with useMode 211 (docs/model.md, section 2).

Global search (n_starts chosen deliberately, not the engine's 8 x free parameters: a stage has
up to 29 free coefficients): the carried-forward values, the parameter table's defaults, and
``n_lhs`` (2) Latin-hypercube points in a box of +/-50 % of max(|start|, |default|) around the
carried-forward values (+/-0.05 where both are 0), each solved by least squares on an evenly
spaced subsample of the stage's points; the distinct end points near the best are then solved
on all points by the engine's local solver (identify.fit.optimize.fit) within MAX_NFEV
evaluations (identify.fit.mf.search.search); ``starts_at_best`` says how many starts reached
the best value on the subsample. The full bounds are far too wide for a few starts in 20-30
dimensions; the box is where the optimum of a carried-forward stage lies. Mirror images of an
optimum ((QBZ9, QBZ10) -> (-QBZ9, -QBZ10) and the others of identify.model.symmetries) predict
identically: the search and the rivals treat them as one minimum, and the image nearest the
start is reported (identify.fit.mf.minima.sign_images).

Derivatives: exact (JAX forward mode, identify.fit.mf.jacobian) when JAX is installed, else
finite differences; the same optimum either way.

Progress: ``fit_mf(progress=...)`` is called with one line per stage and sub-step (screen,
search, solve, re-fit) and a last line per stage with its time; the fit layer prints nothing.

Coupling: SSZ1..4 (stage Mz) act on the Mz0 points through s*Fx; ``passes`` > 1 runs the
sequence again from its result. Each FitResult's predictions (and errors) are those of the
final parameter set, i.e. exactly what the written .tir gives.
"""
from __future__ import annotations

import dataclasses
import time
from collections.abc import Collection, Mapping, Sequence

import numpy as np
import pandas as pd
from scipy.stats import chi2
from threadpoolctl import threadpool_limits

from identify.core.progress import Progress
from identify.fit.bounds import MAX_WIDENINGS, arbitrary_hits, near_bound, widen
from identify.fit.limits import table_limits, union_limits
from identify.fit.mcmc.chains import run_mcmc
from identify.fit.mcmc.reparam import kya_ridge
from identify.fit.mf import stage_data as mf_data
from identify.fit.mf.conditional import AFTER_FIT, with_conditional
from identify.fit.mf.minima.branches import with_other_branch
from identify.fit.mf.minima.even_effect import canonical_even, even_gate
from identify.fit.mf.minima.rivals import chi2_scale, with_rivals
from identify.fit.mf.minima.sign_images import canonical_signs
from identify.fit.mf.problem import (
    StageProblem,
    candidates,
    fitted_problem,
    stage_problem,
    subproblem,
)
from identify.fit.mf.result import MFFit
from identify.fit.mf.score_test import score_added
from identify.fit.mf.screen import Z_GATE
from identify.fit.mf.search import (
    CHI2_GAP,
    MAX_NFEV,
    N_LHS,
    REFIT_NFEV,
    final_predictions,
    ladder_sizes,
    prune,
    refine_on,
    search,
    start_points,
    subsample,
)
from identify.fit.mf.stage_specs import (
    DEFAULT_STAGES,
    STAGES,
    names_read,
)
from identify.fit.mf.starts import data_starts
from identify.fit.optimize import Solved, fit
from identify.fit.result import FitResult
from identify.fit.solve.engine import MF_SOLVE, residual_jacobian, residual_variance
from identify.fit.solve.problem import FitProblem
from identify.fit.status import noise_floor
from identify.model.modes import FIT_MODE
from identify.model.parameters import bounds, defaults, spec

__all__ = ["MFFit", "StageProblem", "fit_mf", "stage_problem", "stage_mcmc", "start_points",
           "DEFAULT_STAGES", "N_LHS", "MAX_NFEV"]

MAX_ROUNDS = 2
"""Refinement re-fits per stage after the global fit (see _refine)."""


def _say(progress: Progress | None, text: str) -> None:
    if progress is not None:
        progress(text)


def _global_fit(sp: StageProblem, starts: np.ndarray, progress: Progress | None,
                give_up: bool = False
                ) -> tuple[FitResult | int, list[dict[str, float]], list[Solved]]:
    """Search on the subsample, then solve the candidates on all points (see module):
    (result, the candidates solved on all points, name -> value of the free coefficients,
    best first on the last rung; their solves on all points, identify.fit.optimize.fit's
    ``record``, for identify.fit.mf.minima.rivals). ``give_up`` (a re-fit): when the search on the
    subsample did not converge, return its number of model evaluations instead of a result
    (a re-fit whose added coefficients run off along a flat valley, e.g. PEY3 -> -5000 with
    PEY1 -> 0 on a TTC session: the re-fit would not be taken, and solving it on all points
    cost minutes), and solve on all points within REFIT_NFEV instead of MAX_NFEV."""
    t0 = time.perf_counter()
    stage, n = sp.problem.form, sp.problem.measured.size
    index = subsample(n)
    sub = sp.problem if index is None else subproblem(sp, index)
    _say(progress, f"MF {stage}: search, {len(starts)} starts on "
                   f"{sub.measured.size if index is not None else 'all'} of {n} points")
    found = search(sub, starts)
    if give_up and not found.converged:
        return found.nfev, [], []
    candidates, nfev = list(found.candidates), found.nfev
    for size in ladder_sizes(n):
        _say(progress, f"MF {stage}: {len(candidates)} candidate(s) on {size} of {n} points")
        rung = subproblem(sp, subsample(n, size))
        moved = [refine_on(rung, x) for x in candidates]
        nfev += sum(k for _, k in moved) + len(moved)
        candidates = prune(rung, [x for x, _ in moved])
    _say(progress, f"MF {stage}: solve on all {n} points from {len(candidates)} candidate(s)")
    solved: list[Solved] = []
    result = fit(sp.problem, starts=np.vstack(candidates),
                 max_nfev=REFIT_NFEV if give_up else MAX_NFEV, tol=MF_SOLVE, record=solved)
    named = [dict(zip(sp.problem.free, map(float, x))) for x in candidates]
    return dataclasses.replace(result, n_starts=found.n_starts,
                               starts_at_best=found.starts_at_best,
                               seconds=time.perf_counter() - t0, nfev=result.nfev + nfev), \
        named, solved


def _rivals(problem: FitProblem, result: FitResult,
            candidates: Sequence[Mapping[str, float]]) -> list[Mapping[str, float]]:
    """The candidates of a global fit on ``problem`` (see :func:`_global_fit`) other than the
    one nearest its optimum ``result`` (relative to max(|value|, 1e-3)) whose objective on all
    points is within CHI2_GAP (chi^2, the optimum's residual variance) of the optimum's."""
    if len(candidates) < 2:
        return []
    free = result.free
    best = np.array([result.parameters[n] for n in free])
    scale = np.maximum(np.abs(best), 1e-3)
    xs = [np.array([c[n] for n in free]) for c in candidates]
    nearest = int(np.argmin([np.sum(((x - best) / scale) ** 2) for x in xs]))
    s2 = residual_variance(0.5 * result.wls, result.n_points, len(free))
    out = []
    for i, (c, x) in enumerate(zip(candidates, xs)):
        if i == nearest:
            continue
        r = problem.residuals(x)
        if float(r @ r) - result.wls <= CHI2_GAP * s2:
            out.append(c)
    return out


def _refine(result: FitResult, sp: StageProblem, stage: str, trailer: pd.DataFrame,
            params: Mapping[str, float], free, others: Sequence[Mapping[str, float]] = (),
            progress: Progress | None = None, solved: Sequence[Solved] = (), *,
            n_lhs: int = N_LHS, seed: int = 0
            ) -> tuple[FitResult, StageProblem, Sequence[Mapping[str, float]],
                       Sequence[Solved]]:
    """Rule 3 of identify.fit.mf.screen after the global fit: free the coefficients that the
    significant moves have given an effect, and re-fit from the optimum and from the global
    search's other candidates ``others`` (:func:`_global_fit`) within CHI2_GAP of it on all
    points (:func:`_rivals`; the new ones start at their carried-forward values), and from
    the defaults and ``n_lhs`` Latin-hypercube points around the optimum as the global search
    does (start_points, ``seed``); on the search's subsample first, then on all points, as the
    global fit; a re-fit that does not lower the objective is not taken. The added
    coefficients can open basins that a start at their carried-forward values does not
    reach: on generated TTC sessions (seeds 1 and 4) Mz0's re-fit with QEZ4 and QEZ5 from
    (0, 0) alone ended at QEZ5 = -1.6 (truth 0), 1.5 and 2.6 % above the minimum near the
    truth (QEZ5 = 0.13 and 0.51), which the Latin-hypercube starts reach. Two basins that the
    search found within a fraction of a per cent of each other can swap order once the added
    coefficients are free: on a generated TTC session's Fx0 (seed 2) the higher one, PCX1 =
    1.83, PEX1 = 0.69, was the lower with PEX4 held at 0, and its re-fit with PEX4 ended 8.7
    in chi^2 above the re-fit of the other (PCX1 = 1.49, PEX1 = 0.13, truth 1.6, 0.3). At most
    MAX_ROUNDS times. Returns the result, its problem, the candidates of its global fit
    and their solves there (``solved``: :func:`_global_fit`'s). The FitResult keeps the
    global search's n_starts and starts_at_best, adds
    the re-fits' seconds and model evaluations to the search's, and its message says what was
    added. In each round the coefficients the significant moves give an effect are re-fitted
    first, then those whose score statistic at the fitted values passes chi^2(1)'s 95 % point
    (identify.fit.mf.score_test), each group with its own re-fit and likelihood-ratio test
    (:func:`_refit_with`); a group not kept is not tried again."""
    added_all: list[str] = []
    rivals_used = 0
    rejected: set[str] = set()  # freed once and not kept: not tried again
    for _ in range(MAX_ROUNDS):
        progressed = False
        # first the coefficients the significant moves give an effect; then, each group
        # with its own likelihood-ratio test, those the fitted values give an effect that
        # the data ask for, whether or not what gave it moved by Z_GATE of its own standard
        # errors (identify.fit.mf.score_test): in one test a weak one rode along with a strong
        # one (a short TTC session's Mx: QSX6, score 4.5, truth 0, beside PPMX1)
        for kind in ("moved", "score"):
            if kind == "moved":
                moved = {n: float(result.parameters[n]) for n in result.free
                         if abs(result.parameters[n] - params[n]) >= Z_GATE * result.stderr[n]}
                gates = stage_problem(stage, trailer, {**params, **moved}, free=free, like=sp)
                added = [n for n in gates.problem.free
                         if n not in result.free and n not in rejected]
                held = {n: why for n, why in gates.held.items() if n not in result.free}
                held.update({n: sp.held[n] for n in gates.problem.free
                             if n in rejected and n in sp.held})
                scored: dict[str, float] = {}
            else:
                scored = score_added(result, sp, stage, trailer, params, free,
                                     exclude=tuple(rejected))
                added = list(scored)
                held = {n: why for n, why in sp.held.items() if n not in added}
            if not added:
                continue
            step = _refit_with(result, sp, stage, trailer, params, free, added, held, scored,
                               others, solved, progress, n_lhs=n_lhs, seed=seed)
            result, sp = step.result, step.sp
            if not step.kept:
                rejected.update(added)
                continue
            progressed = True
            added_all += added
            rivals_used += step.rivals
            others, solved = step.others, step.solved
        if not progressed:
            break
    if added_all:
        result = dataclasses.replace(
            result, message=f"{result.message} (then re-fitted from the global optimum"
                            + (f" and {rivals_used} other candidate(s)" if rivals_used else "")
                            + f" with {', '.join(added_all)}, which had no effect at the "
                              "start)")
    return result, sp, others, solved


@dataclasses.dataclass(frozen=True)
class _RefitStep:
    """One re-fit of :func:`_refine`: the result and problem to go on with (the re-fit's when
    ``kept``, else the optimum's with the added coefficients held and why), the global fit's
    candidates and solves when kept, and how many rival starts it took."""
    kept: bool
    result: FitResult
    sp: StageProblem
    others: Sequence[Mapping[str, float]] = ()
    solved: Sequence[Solved] = ()
    rivals: int = 0


def _refit_with(result: FitResult, sp: StageProblem, stage: str, trailer: pd.DataFrame,
                params: Mapping[str, float], free, added: list[str], held: Mapping[str, str],
                scored: Mapping[str, float], others: Sequence[Mapping[str, float]],
                solved: Sequence[Solved], progress: Progress | None, *, n_lhs: int,
                seed: int) -> _RefitStep:
    """Re-fit the stage with ``added`` freed (``held``: every other candidate held, and why)
    from the starts :func:`_refine` describes, and keep it when its likelihood-ratio gain
    passes the 95 % point of chi^2 with len(added) degrees of freedom. ``scored``: the score
    statistics of added coefficients that the score test named (for the progress line)."""
    values = {**params, **{n: float(result.parameters[n]) for n in result.free}}
    trial = stage_problem(stage, trailer, values, free=free, hold=dict(held), like=sp)
    _say(progress, f"MF {stage}: re-fit with {', '.join(added)} (effective after the fit"
                   + "".join(f"; {n}: score chi^2 {v:.3g}" for n, v in scored.items()) + ")")
    # from the optimum as the global search does: on the subsample first (the added
    # coefficients can move the optimum far), then on all points; and from the search's
    # other candidates near it (the added coefficients can make another basin the lower)
    rivals = _rivals(sp.problem, result, others)
    # and from the least-squares point a polish left for the optimum (a constrained
    # stage): with the added coefficients free it may hold the constraints itself
    unpolished = _unpolished(result, solved)
    # and from the defaults and Latin-hypercube points around the optimum, as the global
    # search (start_points): the added coefficients can open basins that a start at
    # their carried-forward values does not reach
    around = start_points(trial.problem, n_lhs, seed)
    starts = np.vstack([around[:1]] + [
        [c.get(n, float(values[n])) for n in trial.problem.free]
        for c in unpolished + rivals] + [around[1:]])
    refit, candidates, trial_solved = _global_fit(trial, starts, None, give_up=True)
    refit = _continue_refit(refit, result, trial, len(added), progress)
    spent = refit if isinstance(refit, int) else refit.nfev  # int: search not converged
    if isinstance(refit, int) or not refit.converged or refit.wls > result.wls:
        # e.g. a product of two weakly determined coefficients: keep the global optimum
        return _RefitStep(False, dataclasses.replace(result, nfev=result.nfev + spent),
                          dataclasses.replace(sp, held={**sp.held, **{
                              n: f"sensitivity: {AFTER_FIT}, and the re-fit with it did not "
                                 "converge or ended higher" for n in added}}))
    gain = _chi2_gain(trial.problem, result, refit)
    needed, names = chi2.ppf(0.95, len(added)), ", ".join(added)
    if gain < needed:
        _say(progress, f"MF {stage}: {names} held: the re-fit lowered chi^2 by "
                       f"{gain:.2f}, not significant")
        return _RefitStep(False, dataclasses.replace(result, nfev=result.nfev + spent),
                          dataclasses.replace(sp, held={**sp.held, **{
                              n: f"sensitivity: {AFTER_FIT}, and freeing {names} lowered "
                                 f"chi^2 by {gain:.2f} only (95 %: {needed:.2f})"
                              for n in added}}))
    kept = dataclasses.replace(
        refit, n_starts=result.n_starts, starts_at_best=result.starts_at_best,
        seconds=result.seconds + refit.seconds, nfev=result.nfev + refit.nfev)
    return _RefitStep(True, kept, trial, candidates, trial_solved, len(rivals))


def _chi2_gain(problem: FitProblem, result: FitResult, refit: FitResult) -> float:
    """How much lower ``refit``'s objective is than ``result``'s (``problem``: the re-fit's,
    with the added coefficients free, on the points of both), in chi^2 on the scale of
    ``refit``'s intervals (identify.fit.mf.minima.rivals.chi2_scale): a likelihood-ratio statistic
    for the coefficients ``refit`` adds, its variance that of the larger model, as in the F
    test of nested models. On the smaller model's scale a misfit that only the added
    coefficients can remove inflates the variance and hides its own removal: on a TTC session
    of the golden test tyre (tests/data/tir/testA_61.tir, seed 5, raw samples) the Fy stage
    without RVY4..6 ended 22 % off the data (its least-squares point broke Gyk > 0 on the
    validity grid, and the polish left it for a point 15 times higher); the re-fit with them
    lowered the objective 290-fold, which that scale (residual variance and sweep-jackknife
    ratio of the misfit) counted as chi^2 5.8, not significant."""
    xb = np.array([refit.parameters[n] for n in problem.free])
    se = np.array([refit.stderr.get(n, np.nan) for n in problem.free])
    scale = chi2_scale(problem, xb, se)
    return float((result.wls - refit.wls) / scale) if scale > 0 else np.inf


def _unpolished(result: FitResult, solved: Sequence[Solved]) -> list[dict[str, float]]:
    """The least-squares point (name -> value of the free coefficients) that ``result``'s
    optimum was polished from, as its global fit's record ``solved`` has it (none when the
    optimum is its least-squares point, or a polish shared by several starts). On the golden
    tyre's TTC session (tests/data/tir/testA_61.tir, seed 4) the Fy stage's least-squares
    optimum without RVY4..6 violated a validity condition and the polish left it for a
    feasible point 94 times higher in chi^2 (RBY1 = 0, RBY4 = 6e6); the re-fit with RVY4..6
    from there ended at 38 % on Fy."""
    x = [result.parameters[n] for n in result.free]
    return [dict(zip(rec.problem.free, map(float, rec.outcome.lsq.x))) for rec in solved
            if rec.outcome.polished and tuple(rec.problem.free) == tuple(result.free)
            and np.array_equal(rec.outcome.x, x)][:1]


def _continue_refit(refit: FitResult | int, result: FitResult, trial: StageProblem,
                    n_added: int, progress: Progress | None) -> FitResult | int:
    """A re-fit of :func:`_refine` that stopped at its budget (REFIT_NFEV) already far below
    the optimum without the added coefficients, by more than the 95 % point of chi^2 with
    ``n_added`` degrees of freedom on the optimum's residual variance (the data say the added
    coefficients matter), solved on to convergence from where it stopped (MAX_NFEV more);
    anything else is returned as it is. On a TTC session generated from another tyre (the
    golden test tyre, tests/data/tir/testA_61.tir, seed 0) the Fy stage's re-fit with RVY4..6
    stopped at its budget 160 times below the optimum in chi^2 and was dropped: RVY4..6 stayed
    at their defaults, RBY2 went to its bound, and Fy missed the truth by 10 %; solved on, it
    converged within 0.8 % of the data."""
    if isinstance(refit, int) or refit.converged or not refit.wls < result.wls:
        return refit
    s2 = residual_variance(0.5 * result.wls, result.n_points, len(result.free))
    if not (result.wls - refit.wls) / s2 > chi2.ppf(0.95, n_added):
        return refit
    _say(progress, f"MF {result.form}: the re-fit stopped at its budget, its objective "
                   f"{result.wls / refit.wls:.3g} times below the optimum's; solved on")
    x = np.array([[refit.parameters[n] for n in trial.problem.free]])
    more = fit(trial.problem, starts=x, max_nfev=MAX_NFEV, tol=MF_SOLVE)
    return dataclasses.replace(more, nfev=refit.nfev + more.nfev,
                               seconds=refit.seconds + more.seconds)


def _nothing_free(sp: StageProblem) -> str:
    """Why a stage with points has nothing to fit: every candidate coefficient is held."""
    n = sp.problem.measured.size
    held = ", ".join(f"{k} ({why})" for k, why in list(sp.held.items())[:3])
    more = f" and {len(sp.held) - 3} more" if len(sp.held) > 3 else ""
    return (f"{n} point(s), but no coefficient is identifiable from them"
            + (f": held {held}{more}" if held else ""))


def _skip_reason(stage: str, trailer: pd.DataFrame) -> str:
    """Why ``stage`` has no points in ``trailer``."""
    quantity = STAGES[stage].quantity
    if quantity not in mf_data.DERIVED:
        return "no points in the trailer table for this stage"
    if quantity == "Rl" and "rl" not in trailer.columns:
        return "no loaded-radius (rl) channel in the trailer data"
    if "omega" not in trailer.columns:
        return ("no wheel-speed (omega) channel in the trailer data: the effective rolling "
                "radius Re = Vx/omega cannot be measured" if quantity == "Re" else
                "no wheel-speed (omega) channel in the trailer data: the loaded radius's "
                "free radius needs it")
    radius = " and a loaded radius" if quantity == "Rl" else ""
    return (f"no free-rolling points with a wheel speed{radius} (runs without a kappa sweep, "
            f"|kappa| <= {mf_data.FREE_KAPPA:g}, omega > 0, Vx >= {mf_data.FREE_MIN_SPEED:g} "
            "m/s)")


def fit_mf(trailer: pd.DataFrame, base: Mapping[str, float], *,
           stages: Sequence[str] = DEFAULT_STAGES, seed: int = 0, fittyp: int = 61,
           free: Mapping[str, Sequence[str]] | Collection[str] | None = None,
           n_lhs: int = N_LHS, screen: bool = True, passes: int = 1,
           reach: Mapping[str, float] | None = None,
           progress: Progress | None = None) -> MFFit:
    """Fit the MF slip coefficients stage by stage.

    Parameters
    ----------
    trailer : DataFrame
        Trailer table: run, Vx [m/s], alpha [rad], kappa [-], gamma [rad], p [Pa], Fz [N] and
        the channels Fx, Fy [N], Mz, Mx, My [N m] of the stages asked for (ISO-W).
    base : mapping
        Start values of every .tir key (``read_tir(path).params()``); missing keys take the
        parameter table's defaults. Not modified.
    stages : sequence of str
        Stages to fit, in order (default Fx0, Fy0, Mz0, Fx, Fy, Mz, Mx, My, vertical,
        geometry).
    seed : int
        Seed of the Latin-hypercube starts (stage i uses seed + i).
    fittyp : int
        FITTYP of the result (61 or 62); the force and moment equations are the same.
    free : mapping or collection, optional
        See :func:`stage_problem`.
    n_lhs : int
        Latin-hypercube starts per stage (besides carried-forward and default values).
    screen : bool
        Apply the identifiability rules (see :func:`stage_problem`).
    passes : int
        Times the stage sequence is run. The stages are coupled where a later stage's
        coefficients act on an earlier stage's points (SSZ1..4 act on Mz at kappa = 0 through
        s*Fx, so Mz0 sees the Mz stage's arm); each further pass starts every stage from the
        previous pass (carried-forward values only: the global search is pass 1's) and
        converges the blocks together. The results are the last pass's; their ``seconds``
        and ``nfev`` count every pass. ``mfid fit`` runs 2 (FitSettings.mf_passes).
    reach : mapping, optional
        Validity limits [SI] (FZMIN ... CAMMAX) that the written .tir will also state: the
        ranges of the other relations' fitted points (identify.workflows.tir_assembly.
        relation_reach). The validity grid then spans their union with the table's
        (identify.fit.limits.union_limits), so that the conditions hold wherever the file
        claims validity.
    progress : callable, optional
        progress(text) per stage and sub-step, and a line with each stage's time (see
        module).

    Returns
    -------
    MFFit
        Its ``params`` carry the table's ranges as FZMIN/FZMAX, KPUMIN/KPUMAX,
        ALPMIN/ALPMAX, CAMMIN/CAMMAX where the table spans one
        (identify.fit.limits.table_limits), widened to ``reach``: the validity grid the
        stages were held to, and the limits the written .tir states
        (identify.workflows.tir_assembly.apply_limits). The start .tir's limits, MFeval's
        defaults of +-1.5 in slip ratio and slip angle, reach far beyond any trailer sweep;
        held there, Gx_alpha > 0 and Gy_kappa > 0 bound the combined-slip shape factors RCX1
        and RCY1 near 1, which the bundled tyre (1.05 each) breaks at slip angles beyond its
        sessions' +-12 deg: its generated TTC sessions at noise 1e-4 (seeds 0 and 3) were
        fitted at RCX1 1.024, RCY1 1.035, REX1 -0.59, REY1 -0.155 (truth -0.4, -0.1), about
        1 standard error of a 1 % session each; with the data's limits (seed 0) at 1.048,
        1.049, -0.42, -0.103 (docs/intervals.md).
    """
    # one BLAS thread: the solver's SVDs are small, and on a busy machine a second thread
    # made each of them 30-100x slower (measured: 12087 x 15, 0.49 s with 2 threads, 0.014 s
    # with 1, on the 2-core machine under load)
    with threadpool_limits(limits=1, user_api="blas"):
        return _fit_mf(trailer, base, stages=stages, seed=seed, fittyp=fittyp, free=free,
                       n_lhs=n_lhs, screen=screen, passes=passes, reach=reach or {},
                       progress=progress)


PASS_GAIN = 0.1
"""A later pass solves a stage again only when a Gauss-Newton step from its values would lower
its objective by more than this many residual variances s^2 (chi^2 by 0.2)."""


def gauss_newton_gain(problem: FitProblem, x: np.ndarray) -> float:
    """0.5 ||P_J r||^2 / s^2 at ``x``: what a Gauss-Newton step would remove from the cost
    0.5 r^T r, in residual variances (r the weighted residuals, J their Jacobian, P_J the
    projection on its columns, s^2 = r^T r / (n - k))."""
    r = problem.residuals(x)
    J = residual_jacobian(problem, x)
    step = np.linalg.lstsq(J, -r, rcond=None)[0]
    s2 = residual_variance(0.5 * float(r @ r), r.size, x.size)
    return 0.5 * float(np.sum((J @ step) ** 2)) / s2 if s2 > 0 else 0.0


def _pass_again(stage: str, trailer: pd.DataFrame, params: Mapping[str, float],
                before: tuple[FitResult, StageProblem], label: str, pass_no: int,
                progress: Progress | None) -> tuple[FitResult, StageProblem, int]:
    """A later pass of a stage something it reads has moved in: the same free coefficients
    and holds as before, at the current values; solved locally when a Gauss-Newton step would
    gain more than PASS_GAIN s^2, else kept; a solve that stops at its budget (a crawl from an
    optimum the inputs barely moved) keeps the values of the pass before. Returns the result,
    the problem and the model evaluations this pass spent (counting J as one)."""
    result, old = before
    sp = stage_problem(stage, trailer, params, free={stage: list(result.free)}, hold={},
                       like=old)
    # its candidates are the free set, which no hold names: the pass before's holds and
    # reasons stand
    sp = dataclasses.replace(sp, held=dict(old.held))
    x0 = sp.problem.x0()
    gain = gauss_newton_gain(sp.problem, x0)
    if gain <= PASS_GAIN:
        _say(progress, f"{label}: kept (a solve would gain {gain:.2g} s^2)")
        return result, sp, 2
    _say(progress, f"{label}: solve on all {sp.problem.measured.size} points (a "
                   f"Gauss-Newton step would gain {gain:.3g} s^2)")
    again = fit(sp.problem, starts=x0[None, :], max_nfev=MAX_NFEV, tol=MF_SOLVE)
    if again.converged:
        return dataclasses.replace(again, n_starts=result.n_starts,
                                   starts_at_best=result.starts_at_best,
                                   rivals=result.rivals), sp, again.nfev + 2
    _say(progress, f"{label}: the solve stopped at its budget; the values of the pass before "
                   "are kept")
    return dataclasses.replace(result, message=(
        f"{result.message} (kept: pass {pass_no + 1} stopped at its budget)")), sp, \
        again.nfev + 2


def _widened(result: FitResult, sp: StageProblem, stage: str, trailer: pd.DataFrame,
              params: Mapping[str, float], label: str, progress: Progress | None,
              starts: Mapping[str, float]) -> tuple[FitResult, StageProblem, int]:
    """``result`` with no free coefficient at an arbitrary bound (identify.fit.bounds): each
    arbitrary end the optimum reaches is widened and the stage solved again from there, at
    most MAX_WIDENINGS times; a coefficient still at an arbitrary end then is held at its
    start value ``starts[name]``, the fit's start before any stage (the data do not bound it:
    its value would be the range's,
    not the data's) and the others solved again. Returns the result, its problem and the
    model evaluations spent. A solve with widened bounds that does not converge within
    MAX_NFEV (coefficients running off along a flat valley: a TTC session's PPY5 to -37,
    PKY4 to 70) is not taken: the coefficients it widened are held instead."""
    spent = 0
    for _ in range(MAX_WIDENINGS):
        hits = arbitrary_hits(result.free, result.parameters, result.bounds)
        if not hits or not result.converged:
            return result, sp, spent
        wide = dict(sp.wide)
        wide.update({n: widen(*result.bounds[n], side) for n, side in hits.items()})
        _say(progress, f"{label}: at an arbitrary bound: "
                       f"{', '.join(f'{n} ({side})' for n, side in hits.items())}; "
                       "bounds widened, solved again")
        values = {**params, **{n: float(result.parameters[n]) for n in result.free}}
        again = stage_problem(stage, trailer, values, free={stage: list(result.free)}, hold={},
                              like=sp, wide=wide)
        again = dataclasses.replace(again, held=dict(sp.held))
        solved = fit(again.problem, starts=again.problem.x0()[None, :], max_nfev=MAX_NFEV,
                     tol=MF_SOLVE)
        spent += solved.nfev
        if not solved.converged:  # runs off within its budget: not bounded by the data
            _say(progress, f"{label}: the solve with widened bounds stopped at its budget")
            return _hold_unbounded(result, sp, stage, trailer, params, hits, label, progress,
                                   spent, starts)
        moved = ", ".join(f"{n} to [{wide[n][0]:.4g}, {wide[n][1]:.4g}]" for n in hits)
        result = dataclasses.replace(
            solved, n_starts=result.n_starts, starts_at_best=result.starts_at_best,
            rivals=result.rivals,
            message=f"{solved.message} (arbitrary bounds widened: {moved})")
        sp = again
    hits = arbitrary_hits(result.free, result.parameters, result.bounds)
    if hits and result.converged:
        return _hold_unbounded(result, sp, stage, trailer, params, hits, label, progress, spent,
                               starts)
    return result, sp, spent


def _hold_unbounded(result: FitResult, sp: StageProblem, stage: str, trailer: pd.DataFrame,
                    params: Mapping[str, float], hits: Mapping[str, str], label: str,
                    progress: Progress | None, spent: int, starts: Mapping[str, float]
                    ) -> tuple[FitResult, StageProblem, int]:
    """The stage solved again with the coefficients ``hits`` (name -> the side of the
    arbitrary bound they ran to after every widening) held at their values in ``starts``
    (the fit's start before any stage: a later pass starts from the pass before, which may
    have left them next to the bound), or the parameter table's default where that is at
    the table's bound."""
    why = {n: f"runs to its arbitrary {side} bound {result.bounds[n][side == 'upper']:.4g} "
              "and beyond when widened: the data do not bound it; held at its start value"
              for n, side in hits.items()}
    _say(progress, f"{label}: {', '.join(hits)} not bounded by the data: held at the start")
    free = [n for n in result.free if n not in hits]
    values = {**params, **{n: float(result.parameters[n]) for n in free}}
    for n in hits:  # the fit's start, not what an earlier pass left next to the bound
        values[n] = float(starts.get(n, values[n]))
        if near_bound(values[n], *bounds(n, values[n])):
            values[n] = float(spec(n).default)
    again = stage_problem(stage, trailer, values, free={stage: list(result.free)},
                          hold={**{n: w for n, w in sp.held.items()}, **why}, like=sp)
    again = dataclasses.replace(again, held={**sp.held, **why})
    if not again.problem.free:
        return result, sp, spent
    solved = fit(again.problem, starts=again.problem.x0()[None, :], max_nfev=MAX_NFEV,
                 tol=MF_SOLVE)
    return dataclasses.replace(solved, n_starts=result.n_starts,
                               starts_at_best=result.starts_at_best,
                               held={**result.held, **why},
                               message=f"{solved.message} (held, not bounded by the data: "
                                       f"{', '.join(hits)})"), again, spent + solved.nfev


def _stage_points(trailer: pd.DataFrame, sp: StageProblem, stage: str) -> pd.DataFrame:
    """The operating points of a stage (MFFit.points): its rows of ``trailer``, as its problem
    already took them (StageProblem.points)."""
    rows = sp.points.pts if sp.points is not None else trailer.iloc[sp.rows]
    return rows[["Fz", "kappa", "alpha", "gamma", "Vx", "p"]
                + (["omega"] if STAGES[stage].quantity in mf_data.DERIVED else [])]


SPEED_STAGES = ("My", "vertical", "geometry")
"""The stages whose equations read the speed (QSY3, QSY4; Q_V1, Q_V2): for the others, sweeps
at other speeds repeat the same conditions (identify.fit.status.noise_floor)."""


def _with_floor(result: FitResult, sp: StageProblem, trailer: pd.DataFrame,
                fnomin: float) -> FitResult:
    """``result`` with the noise floor of its points (identify.fit.status.noise_floor): the
    scatter of repeated sweeps (at every speed but in SPEED_STAGES) and of neighbouring
    samples along each sweep."""
    col = (sp.points.col if sp.points is not None else
           {c: trailer.iloc[sp.rows][c].to_numpy(float)
            for c in ("Fz", "kappa", "alpha", "gamma", "Vx")})
    floor = noise_floor(result.measured, result.predicted, result.pressure_bar,
                        sp.problem.sweeps, conditions=col, fnomin=fnomin,
                        by_speed=result.form in SPEED_STAGES)
    return dataclasses.replace(result, noise_floor_pct=floor.pct, floor_source=floor.source)


def _untaken(stage: str, free, taken: Mapping[str, str]) -> tuple[object, dict[str, str]]:
    """``free`` for ``stage`` without the coefficients an earlier stage of the pass fitted
    (``taken``: name -> that stage), and those names -> why the stage holds them. A
    coefficient two stages list is fitted once, by the first that frees it (Q_RE0: the
    vertical stage's loaded radius, before the geometry stage's effective radius)."""
    owned = {n: f"fitted in the {taken[n]} stage" for n in STAGES[stage].coefficients
             if n in taken}
    if not owned:
        return free, {}
    names = [n for n in candidates(STAGES[stage], free) if n not in owned]
    return {**(free if isinstance(free, Mapping) else {}), stage: names}, owned


def _fit_mf(trailer, base, *, stages, seed, fittyp, free, n_lhs, screen, passes, reach,
            progress) -> MFFit:
    t0 = time.perf_counter()
    unknown = [s for s in stages if s not in STAGES]
    if unknown:
        raise ValueError(f"unknown MF stage(s) {unknown}; known: {', '.join(STAGES)}")
    if fittyp not in (61, 62):
        raise ValueError(f"fittyp must be 61 or 62, not {fittyp}")
    if passes < 1:
        raise ValueError(f"passes must be >= 1, not {passes}")
    mf_data.check_columns(trailer, tuple(sorted({STAGES[s].quantity for s in stages})))
    # a freely rolling run's kappa is noise: 0 (stage_problem takes it so too; done once
    # here, its builds find nothing to change and copy no table)
    sweeps = mf_data.run_sweeps(trailer)  # every stage's selection (stage_problem)
    trailer = mf_data.rolling_kappa(trailer, sweeps)
    params = {k: float(v) for k, v in defaults().items() if not isinstance(v, str)}
    params.update({k: float(v) for k, v in base.items() if not isinstance(v, str)})
    params["FITTYP"] = float(fittyp)
    # the force stages' starts where the defaults miss the measured tyre (an FSAE slick)
    scaled = data_starts(trailer, params)
    for name, value in scaled.items():
        _say(progress, f"MF start: {name} = {value:.4g} from the data (was "
                       f"{params[name]:.4g})")
    params.update(scaled)
    starts = dict(params)  # what a coefficient the data do not bound is held at
    # the validity grid: where the .tir claims validity
    params.update(union_limits(table_limits(trailer), reach))
    spent: dict[str, tuple[float, int]] = {}  # seconds and evaluations of earlier passes
    # per stage: its result, problem and the values of every name its prediction read when
    # it was fitted; a later pass solves only a stage some of whose inputs changed since
    done: dict[str, tuple[FitResult, StageProblem, dict[str, float]]] = {}
    for pass_no in range(passes):
        results, held, skipped, points, problems = [], {}, {}, {}, []
        taken: dict[str, str] = {}  # coefficient -> the stage of this pass that fitted it
        for i, stage in enumerate(stages):
            t_stage = time.perf_counter()
            stage_free, owned = _untaken(stage, free, taken)
            label = f"MF {stage}" + (f" (pass {pass_no + 1})" if passes > 1 else "")
            if stage in done and all(params.get(n) == v for n, v in done[stage][2].items()):
                result, sp, _ = done[stage]
                _say(progress, f"{label}: unchanged (nothing it reads has moved)")
                results.append(result)
                problems.append(sp)
                held[stage] = {**owned, **sp.held}
                taken.update({n: stage for n in result.free})
                points[stage] = _stage_points(trailer, sp, stage)
                continue
            if stage in done:  # a later pass: the free set and holds of the pass before
                result, sp, new_nfev = _pass_again(stage, trailer, params, done[stage][:2],
                                                   label, pass_no, progress)
            else:
                _say(progress, f"{label}: points and identifiability screen")
                sp = stage_problem(stage, trailer, params, free=stage_free, screen=screen,
                                   sweeps=sweeps)
                if sp is None or not sp.problem.free:
                    skipped[stage] = (_skip_reason(stage, trailer) if sp is None else
                                      _nothing_free(sp))
                    _say(progress, f"{label}: skipped, {skipped[stage]}")
                    continue
                result, others, solved = _global_fit(
                    sp, start_points(sp.problem, n_lhs, seed + i), progress)
                if screen:
                    result, sp, others, solved = _refine(result, sp, stage, trailer, params,
                                                         stage_free, others, progress, solved,
                                                         n_lhs=n_lhs, seed=seed + i)
                    result, sp = even_gate(result, sp, stage, trailer, params, stage_free,
                                           progress)
                result, branch = with_other_branch(result, sp, label, progress)
                result = with_rivals(result, sp, branch + list(others), label, progress,
                                     solved)
                new_nfev = result.nfev
            result, sp, wider_nfev = _widened(result, sp, stage, trailer, params, label,
                                              progress, starts)
            new_nfev += wider_nfev
            # what it held as unbounded by the data, at the value it held it at
            params.update({n: float(result.parameters[n]) for n in result.held
                           if n in result.parameters})
            result = canonical_signs(result, params)
            result = canonical_even(result)
            if screen:  # what rests on coefficients held since the re-fit with them failed
                result = with_conditional(result, sp, stage, trailer, params)
            # the stage's whole wall time: screen (and the Jacobian's compile), search, solves,
            # every pass
            before_s, before_n = spent.get(stage, (0.0, 0))
            result = dataclasses.replace(result,
                                         seconds=before_s + time.perf_counter() - t_stage,
                                         nfev=before_n + new_nfev)
            spent[stage] = (result.seconds, result.nfev)
            params.update({n: float(result.parameters[n]) for n in result.free})
            read = names_read(stage, params, sp.state, sp.omega)
            done[stage] = (result, sp, {n: params[n] for n in read if n in params})
            results.append(result)
            problems.append(sp)
            held[stage] = {**owned, **sp.held}
            taken.update({n: stage for n in result.free})
            points[stage] = _stage_points(trailer, sp, stage)
            _say(progress, f"{label}: {time.perf_counter() - t_stage:.1f} s, "
                           f"{result.n_points} points, {len(result.free)} free, "
                           f"{result.nfev} evaluations, "
                           f"{'converged' if result.converged else 'NOT converged'}")
    results = [_with_floor(final_predictions(r, sp.problem, sp.state, params, sp.omega), sp,
                           trailer, float(params["FNOMIN"]))
               for r, sp in zip(results, problems)]
    settings = {"seed": seed, "fittyp": fittyp, "use_mode": FIT_MODE, "n_lhs": n_lhs,
                "max_nfev": MAX_NFEV, "passes": passes, "stages": list(stages),
                "screen": screen, "objective": "wls", "data_starts": scaled}
    return MFFit(params=params, results=tuple(results), held=held, skipped=skipped,
                 settings=settings, points=points, seconds=time.perf_counter() - t0)


def stage_mcmc(trailer: pd.DataFrame, mf: MFFit, stage: str, *, seed: int = 0,
               ar1: bool = False, reparam: bool = True, **kwargs) -> FitResult:
    """MCMC uncertainty (identify.fit.mcmc.chains.run_mcmc) of one fitted stage of ``mf``.

    The stage's problem is rebuilt at the final values ``mf.params`` with the stage's free
    coefficients; the returned FitResult is the stage's with ``mcmc`` set. With ``reparam``
    the Fy0 stage samples the cornering stiffness at three loads in place of PKY1, PKY2, PKY4
    (identify.fit.mcmc.reparam; same posterior, far shorter autocorrelation times on a load
    range below the stiffness peak). ``kwargs`` go to run_mcmc (n_walkers, max_steps, budget,
    chain_file, progress).
    """
    result = mf.result(stage)
    sp = fitted_problem(trailer, mf.params, result)
    ridge = None
    if reparam and stage == "Fy0":
        free = sp.problem.free
        ridge = kya_ridge(free, np.array([result.parameters[n] for n in free]), sp.state.fz,
                          mf.params, dpi=sp.state.dpi, gamma_star=sp.state.gamma_star)
    return run_mcmc(sp.problem, result, seed=seed, ar1=ar1, reparam=ridge, **kwargs)
