"""Free MF coefficients whose values rest on held ones (FitResult.conditional).

The identifiability screen holds a candidate that has no effect at the start values (QSX4 while
QSX7 = QSX8 = 0); after the fit, a coefficient that then has an effect is freed and the stage
re-fitted (identify.fit.mf.stages._refine). When that re-fit does not converge or ends higher,
the coefficient stays held at its start value, which the data did not choose, and the free
coefficients it trades with carry whatever the held value makes them: on a TTC session
generated from another tyre (MFeval's reference tyre at Formula Student size: QSX4 = 4.9,
QSX6 = 22.8, QSX7 = 0.71; the defaults 5, 10, 0) the Mx stage's QSX7 can end many standard
errors off the truth while its interval looks identifiable (docs/intervals.md); this module
lists it, with the others that rest on the held value. It does not list a coefficient that
trades with one the screen held as having no effect at all (QSX3 with QSX9), since that hold
is not AFTER_FIT.

A speed term held because the data hold one speed (ONE_SPEED) is checked the same way: its
variable is never 0 on trailer data, so it trades with the constant terms: on the generated
TTC sessions (one speed) Q_V2 is held at 0 for the truth's 0.02, and the VERTICAL_STIFFNESS
fitted lies many standard errors above the truth (identify.fit.mf.stage_specs stage
``vertical``; bench/ttc_truth.py): the stiffness the data give is the one at the test speed.
So is a shift held because the data's slip is of one sign (ONE_SIGN: RBY3 on a TTC
drive/brake run's slip angles 0, -3, -6 deg).

Their intervals are right only if the held values are exact. This module measures how much
they rest on them: the variance of each free coefficient with the held ones free as well,
over its variance with them held (a variance inflation factor from J^T J at the optimum, noise
scale cancelling). Above :data:`VIF_LIMIT`, or where freeing them leaves the coefficient
undetermined, the coefficient is recorded as conditional (identify.fit.identifiability then
counts it not identifiable on its own, with the held names in the reason).
"""
from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd

from identify.fit.identifiability import assess
from identify.fit.mf.problem import StageProblem, stage_problem
from identify.fit.result import FitResult
from identify.fit.solve.engine import residual_jacobian

__all__ = ["AFTER_FIT", "ONE_SIGN", "VIF_LIMIT", "conditional_on_held", "inflation",
           "with_conditional"]

AFTER_FIT = "effective only after the fit"
"""Marker in a held coefficient's reason (identify.fit.mf.stages._refine) that it took effect
at the fitted values but its re-fit was not taken."""
ONE_SPEED = ("data: one speed", "speed(s), 3 needed")
"""Coverage reasons (identify.fit.mf.stage_data.Coverage.missing) of a speed term held because the
data hold too few speeds. Such a term never vanishes on trailer data (its variable, |omega|
R0/V0 or Vx/V0, is the test speed's, not 0), so at one speed it trades with the constant
terms: Q_V2 (1 + Q_V2 |omega| R0/V0) scales the load law as VERTICAL_STIFFNESS does, and the
vertical stage measures only their product, the stiffness at the test speed. Other coverage
holds (one load, pressure or camber level) usually sit where their term is 0 (FNOMIN, NOMPRES,
no camber) and are not checked."""
ONE_SIGN = ("slip angles of one sign only", "slip of one sign only")
"""Coverage reasons (identify.fit.mf.stage_data.Coverage.missing) of a shift or asymmetry term held
because the data's slip is of one sign: RBY3 shifts the slip angle in By_kappa, and a TTC
drive/brake run sets 0, -3, -6 deg only. Such a term is not 0 where the data are (it moves
the curve there), so the free coefficients along its ridge carry the held value: on sessions
generated from the golden test tyre (RBY3 = -0.03, held at 0) RBY2 comes out several standard
errors above the truth while the forces stay within a fraction of a percent of it
(bench/ttc_truth.py --tir with that tyre)."""
VIF_LIMIT = 4.0
"""Variance ratio (a standard error twice as large) above which a free coefficient counts as
resting on the held ones."""
NULL_TOL = 1e-10
"""Eigenvalue of the unit-diagonal J^T J, relative to its largest, below which a direction is
undetermined."""


def inflation(J: np.ndarray, k: int) -> np.ndarray:
    """Variance inflation of the first ``k`` columns' coefficients when the other columns of
    ``J`` (points, k + h) are freed too: var(full) / var(first k alone), from J^T J (inf where
    freeing the others leaves a coefficient undetermined, nan where it was undetermined
    already, e.g. its column is 0; all nan when J is not finite)."""
    A = J.T @ J
    d = np.sqrt(np.diag(A))
    if not np.all(np.isfinite(d)):
        return np.full(k, np.nan)
    d = np.where(d > 0, d, 1.0)  # a column without effect stays 0: a null direction of its own
    A = A / np.outer(d, d)

    def diag_inverse(M):
        w, V = np.linalg.eigh(M)
        null = w <= NULL_TOL * w.max()  # all null when J is 0
        var = (V[:, ~null] ** 2 / w[~null]).sum(axis=1)
        var[(V[:, null] ** 2).sum(axis=1) > 1e-2] = np.inf
        return var

    alone = diag_inverse(A[:k, :k])
    full = diag_inverse(A)[:k]
    with np.errstate(invalid="ignore", divide="ignore"):
        out = np.where(np.isfinite(alone), full / alone, np.nan)
    return out


def conditional_on_held(result: FitResult, sp: StageProblem, stage: str,
                        trailer: pd.DataFrame, params: Mapping[str, float]) -> dict[str, str]:
    """Free coefficients of ``result`` whose values rest on the stage's coefficients held with
    the AFTER_FIT reason, held as speed terms at too few speeds (ONE_SPEED), or held as shifts
    the data's slip of one sign cannot see (ONE_SIGN) -> why (empty
    when none is so held, or the fit did not converge).

    Parameters
    ----------
    result : FitResult       the stage's fit
    sp : StageProblem        its problem (``held``: name -> reason)
    stage : str              the stage's name
    trailer : DataFrame      the trailer table the stage was fitted on
    params : mapping         every .tir value (the held ones at their held values)
    """
    held = [n for n, why in sp.held.items()
            if AFTER_FIT in why or any(r in why for r in ONE_SPEED + ONE_SIGN)]
    if not held or not result.converged or not result.free:
        return {}
    free: Sequence[str] = list(result.free)
    values = {**params, **{n: float(result.parameters[n]) for n in free}}
    full = stage_problem(stage, trailer, values, free={stage: list(free) + held}, screen=False,
                         like=sp)
    if full is None or tuple(full.problem.free[:len(free)]) != tuple(free):
        return {}
    J = residual_jacobian(full.problem, full.problem.x0())
    vif = inflation(np.asarray(J, dtype=float), len(free))
    names = ", ".join(f"{n} = {values[n]:.4g}" for n in held)
    why = "; ".join(sorted({AFTER_FIT if AFTER_FIT in sp.held[n] else sp.held[n]
                            for n in held}))
    out = {}
    for n, v in zip(free, vif):
        if v > VIF_LIMIT:  # nan (undetermined already) is another rule's
            grow = "undetermined" if np.isinf(v) else f"{np.sqrt(v):.1f}x its standard error"
            out[n] = f"rests on {names}, held ({why}; freeing them: {grow})"
    return out


def with_conditional(result: FitResult, sp: StageProblem, stage: str, trailer: pd.DataFrame,
                     params: Mapping[str, float]) -> FitResult:
    """``result`` with :attr:`FitResult.conditional` set and its identification assessed
    again (unchanged when nothing rests on a held coefficient)."""
    found = conditional_on_held(result, sp, stage, trailer, params)
    if found == dict(result.conditional):
        return result
    return assess(dataclasses.replace(result, conditional=found))
