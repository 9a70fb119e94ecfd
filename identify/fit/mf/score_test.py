"""Which held coefficients the fitted values give an effect the data ask for (a score test).

After a stage's global fit, identify.fit.mf.stages._refine frees the coefficients that had no
effect at the start only because another was 0 there (PEX4 while PEX1 = 0: E (1 - PEX4 sgn
kappa) is 0 for every PEX4). It looked only at the coefficients that moved by at least
Z_GATE standard errors, so that a shape is not freed on a move the noise made. A move can be
large and certain in the model's output and still not Z_GATE standard errors of its own: PEX1
went from 0 to 0.40 on a generated TTC session (bench/ttc_truth.py seed 21), but its standard
error was that of one of a pair correlated +0.9998 (PCX1, PEX1), and PEX4 stayed held at 0
(truth 0.15). The Fx0 optimum without it lay 507 in iid chi^2 above the one with it (3.4 % of
the objective), and the drive/brake asymmetry that PEX4 describes went into the vertical
shift: PVX1 = 0.0021 +- 0.00046 for a truth of 0, 4.7 standard errors off; with PEX4 free,
0.0002. In the 6 of 30 seeds where PEX4 stayed held, PVX1 missed its interval in all 6.

:func:`score_added` asks the data directly: for each coefficient that the screen at the fitted
values frees (and the moved ones did not), the drop of the objective that one Gauss-Newton
step with it free would give, less the drop without it (the score, or Lagrange-multiplier,
statistic of holding it), on the scale of the stage's intervals (identify.fit.mf.minima.rivals.
chi2_scale). Above the 95 % point of chi^2 with one degree of freedom it is freed in a re-fit
of its own, after the moved ones' (mf_stages._refit_with), whose likelihood-ratio test
(mf_stages._chi2_gain) decides whether it is kept.
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import pandas as pd
from scipy.stats import chi2

from identify.fit.mf.minima.rivals import chi2_scale
from identify.fit.mf.problem import StageProblem, stage_problem
from identify.fit.result import FitResult
from identify.fit.solve.engine import residual_jacobian

__all__ = ["SCORE_LEVEL", "column_gains", "score_added"]

SCORE_LEVEL = 0.95
"""A held coefficient is re-fitted when its score statistic exceeds this quantile of chi^2
with one degree of freedom (3.84)."""
NULL_REL = 1e-12
"""A column whose part orthogonal to the free ones has a squared norm below this fraction of
its own adds nothing (its gain is 0)."""


def column_gains(base: np.ndarray, new: np.ndarray, r: np.ndarray) -> np.ndarray:
    """For each column of ``new`` (n, m): how much more one Gauss-Newton step would lower
    r^T r with it free beside the columns of ``base`` (n, k) than with ``base`` alone, i.e.
    (q . r)^2 / (q . q), q the part of the column orthogonal to ``base`` (exact for a model
    linear in its coefficients; 0 where nothing is left, NULL_REL). One least-squares solve
    for all columns, instead of a step with each."""
    rhs = np.column_stack([r, new])
    rest = rhs - base @ np.linalg.lstsq(base, rhs, rcond=None)[0]
    r_perp, q = rest[:, 0], rest[:, 1:]
    qq = np.einsum("ij,ij->j", q, q)
    ok = qq > NULL_REL * np.einsum("ij,ij->j", new, new)
    return np.where(ok, (q.T @ r_perp) ** 2 / np.where(ok, qq, 1.0), 0.0)


def score_added(result: FitResult, sp: StageProblem, stage: str, trailer: pd.DataFrame,
                params: Mapping[str, float], free, exclude: Sequence[str] = ()
                ) -> dict[str, float]:
    """The coefficients (name -> score statistic, chi^2 on the intervals' scale) that the
    identifiability screen at ``result``'s values frees, that ``result`` held, that are not in
    ``exclude``, and whose freeing one Gauss-Newton step says would lower the objective beyond
    the SCORE_LEVEL point of chi^2(1) (see module). ``params``: the values the stage started
    from; ``free``: the stage's candidate list (stage_problem); ``sp``: ``result``'s problem.
    One Jacobian with every such coefficient free gives all the statistics
    (:func:`column_gains`)."""
    values = {**params, **{n: float(result.parameters[n]) for n in result.free}}
    wide = stage_problem(stage, trailer, values, free=free, like=sp)
    if wide is None:
        return {}
    names = [n for n in wide.problem.free if n not in result.free and n not in exclude]
    if not names:
        return {}
    base = list(sp.problem.free)
    both = stage_problem(stage, trailer, values, free={stage: [*base, *names]}, hold={},
                         like=sp).problem
    x = both.x0()
    jac = residual_jacobian(both, x)
    jb = jac[:, [both.free.index(n) for n in base]]
    xb = np.array([values[n] for n in base])
    se = np.array([result.stderr.get(n, np.nan) for n in base])
    scale = chi2_scale(sp.problem, xb, se, jac=jb)
    if not scale > 0:
        return {}
    gains = column_gains(jb, jac[:, [both.free.index(n) for n in names]], both.residuals(x))
    needed = chi2.ppf(SCORE_LEVEL, 1)
    return {n: float(g / scale) for n, g in zip(names, gains) if g / scale > needed}
