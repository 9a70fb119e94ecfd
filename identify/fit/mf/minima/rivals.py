"""Second minima of an MF stage: other local minima of its objective as good as the reported
one, within the 95 % region of a coefficient (FitResult.rivals; identify.fit.identifiability
names the coefficients they leave undetermined; docs/intervals.md).
"""
from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np

from identify.core.progress import Progress
from identify.fit.identifiability import RIVAL_CHI2
from identify.fit.mf.problem import StageProblem
from identify.fit.mf.search import REFIT_NFEV
from identify.fit.optimize import Solved, fit, replay, snapped
from identify.fit.result import FitResult, Rival
from identify.fit.solve.engine import MF_SOLVE, covariance, residual_jacobian, residual_variance
from identify.model.symmetries import nearest_image, sign_patterns

__all__ = ["chi2_scale", "with_rivals"]


def with_rivals(result: FitResult, sp: StageProblem, candidates: Sequence[Mapping[str, float]],
                label: str, progress: Progress | None, solved: Sequence[Solved] = ()
                ) -> FitResult:
    """``result`` with the other minima the data cannot rule out (FitResult.rivals).

    Every candidate of the global search that ended more than one standard error from the
    optimum in some coefficient is solved again on all points (locally, REFIT_NFEV); a converged
    end whose objective is within RIVAL_CHI2 of the optimum's, in chi^2 on the scale of the
    reported intervals (iid chi^2 divided by the median ratio of the stage's variances to the
    iid ones), and that lies outside the reported 95 % interval (t(0.975, dof) standard errors)
    of some coefficient is a rival. A linearised interval describes the minimum the search
    reported; where the data hold a second one as good, the coefficients that differ are not
    determined on their own (identify.fit.identifiability: "another minimum within the 95 %
    region"). On a generated TTC session's Fx0 stage two such basins lie on either side of the
    truth (docs/intervals.md). ``solved``: the candidates' solves in the global fit on the same
    problem (identify.fit.optimize.fit's ``record``), replayed where they tell the outcome of
    the solve within REFIT_NFEV (identify.fit.optimize.replay) instead of solved again."""
    free = result.free
    if not free or not result.converged or not candidates:
        return result
    xb = np.array([result.parameters[n] for n in free])
    se = np.array([result.stderr.get(n, np.nan) for n in free])
    if not np.all(np.isfinite(se) & (se > 0)):
        return result
    # the reported 95 % intervals (FitResult.interval), the ones identify.fit.identifiability
    # checks a rival against
    lo, hi = np.array([result.interval(n) for n in free]).T
    problem = sp.problem
    signs = sign_patterns(free, problem.values())
    scale = None  # s^2 x the intervals' inflation over iid: computed at the first far end
    found: list[Rival] = []
    ends: list[np.ndarray] = []
    spent = 0
    solved = list(solved)
    for c in candidates:
        x0 = np.array([float(c.get(n, result.parameters[n])) for n in free])
        x0 = nearest_image(x0, xb, signs)
        if np.all(np.abs(x0 - xb) <= se):
            continue
        converged, xe, wls, nfev = _solve(problem, x0, solved)
        spent += nfev
        if not converged:
            continue
        xr = nearest_image(xe, xb, signs)  # a mirror image of the optimum is no rival
        far = (xr < lo) | (xr > hi)
        if not far.any():
            continue
        if scale is None:
            scale = chi2_scale(problem, xb, se)
        dchi2 = (wls - result.wls) / scale if scale > 0 else np.inf
        if dchi2 > RIVAL_CHI2:
            continue
        if any(np.all(np.abs(xr - seen) <= se) for seen in ends):
            continue  # the same rival again
        ends.append(xr)
        found.append(Rival({n: float(v) for n, v, f in zip(free, xr, far) if f}, float(dchi2)))
    if found and progress is not None:
        progress(f"{label}: {len(found)} other minimum(s) within the 95 % region: "
                 + "; ".join(", ".join(f"{n} = {v:.4g}" for n, v in f.values.items())
                             + f" (chi^2 {f.dchi2:+.2f})" for f in found))
    return dataclasses.replace(result, rivals=tuple(found), nfev=result.nfev + spent)


def _solve(problem, x0: np.ndarray, solved: list[Solved]
           ) -> tuple[bool, np.ndarray, float, int]:
    """The local solve of a candidate on all points from ``x0`` (identify.fit.optimize.fit
    within REFIT_NFEV): converged, end point, r^T r there, model evaluations spent; from
    its recorded solve where that tells (identify.fit.optimize.replay: the same numbers)."""
    out = replay(solved, problem, x0, REFIT_NFEV, MF_SOLVE)
    if out is None:
        end = fit(problem, starts=x0[None, :], max_nfev=REFIT_NFEV, tol=MF_SOLVE)
        return (end.converged, np.array([end.parameters[n] for n in end.free]), end.wls,
                end.nfev)
    if not out.ok:
        return False, out.x, np.nan, 0
    x = snapped(problem, out.x)  # the reported optimum, as fit's Diagnosis.x
    r = problem.residuals(x)
    return True, x, float(r @ r), 1


def chi2_scale(problem, xb: np.ndarray, se: np.ndarray, jac: np.ndarray | None = None
               ) -> float:
    """s^2 x the median ratio of the variances ``se``^2 to the iid ones at ``xb``: an objective
    difference divided by it is chi^2 on the scale of the reported intervals. ``jac``: the
    Jacobian of ``problem``'s weighted residuals at ``xb``, when the caller has it."""
    r = problem.residuals(xb)
    s2 = residual_variance(0.5 * float(r @ r), r.size, xb.size)
    jac = residual_jacobian(problem, xb) if jac is None else jac
    # a rank-deficient J^T J's pseudo-inverse can leave a rounding-negative diagonal entry: no
    # variance there (NaN, left out below) rather than a RuntimeWarning in the user's console
    with np.errstate(invalid="ignore"):
        iid = np.sqrt(np.diag(covariance(jac, r)))
    ok = np.isfinite(iid) & (iid > 0)
    return s2 * (float(np.median((se[ok] / iid[ok]) ** 2)) if ok.any() else 1.0)
