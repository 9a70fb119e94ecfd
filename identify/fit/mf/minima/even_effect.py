"""Coefficients whose effect is even in their value (identify.fit.mf.stage_specs.EVEN_START).

The vertical stage's side-force term of the load law, -(Q_FCY Fy/Fz0)^2, is the one: the model
depends on Q_FCY only through u = Q_FCY^2. Two things follow.

* -q predicts exactly as q: the fitted value is reported as |q| (:func:`canonical_even`).
* The linearised interval of q is wrong near 0. The data determine u, with a standard error
  s_u = 2 |q| s_q; for a tyre without the term (u = 0) the fit ends at u ~ |N(0, s_u)|, and the
  interval q +- 1.96 s_q then excludes 0 whenever u > 0.98 s_u: a third of the seeds (4 of 10 on
  the bundled tyre's generated TTC sessions, 3 of them outside). So the term is kept only when
  u is significant, u >= Z_GATE s_u, i.e. |q| >= 2 Z_GATE s_q; otherwise it is held at 0 and
  the stage solved again from its optimum (:func:`even_gate`). A tyre without the term then
  keeps it (falsely) with probability 2.3 %, and the golden test tyre's Q_FCY = 0.2 has
  |q| / s_q above 100.
"""
from __future__ import annotations

import dataclasses
from collections.abc import Mapping

import numpy as np
import pandas as pd

from identify.core.progress import Progress
from identify.fit.mf.minima.sign_images import flipped
from identify.fit.mf.problem import StageProblem, stage_problem
from identify.fit.mf.screen import Z_GATE
from identify.fit.mf.search import MAX_NFEV
from identify.fit.mf.stage_specs import EVEN_START
from identify.fit.optimize import fit
from identify.fit.result import FitResult
from identify.fit.solve.engine import MF_SOLVE

__all__ = ["canonical_even", "even_gate", "not_significant"]


def canonical_even(result: FitResult) -> FitResult:
    """``result`` with each even coefficient as |q| (EVEN_START: the load law's
    (Q_FCY Fy/Fz0)^2 predicts the same at -q as at q, bit for bit: the square only clears the
    sign bit), its correlations' signs flipped with it
    (identify.fit.mf.minima.sign_images.flipped)."""
    return flipped(result, [n for n in EVEN_START
                            if n in result.free and result.parameters[n] < 0])


def not_significant(result: FitResult) -> dict[str, str]:
    """The even coefficients of ``result`` whose square u = q^2 is within Z_GATE of its
    standard error 2 |q| s_q of 0 (|q| < 2 Z_GATE s_q; a coefficient without a finite standard
    error counts as not significant), -> the reason they are held at 0."""
    out = {}
    for n in EVEN_START:
        if n not in result.free:
            continue
        q, se = abs(float(result.parameters[n])), float(result.stderr.get(n, np.nan))
        if not q >= 2 * Z_GATE * se:  # NaN standard error: not significant
            out[n] = (f"not significant: fitted |{n}| = {q:.3g} +/- {se:.2g}, its square (the "
                      f"model's {n}^2) within {Z_GATE:g} standard errors of 0; held at 0")
    return out


def even_gate(result: FitResult, sp: StageProblem, stage: str, trailer: pd.DataFrame,
              params: Mapping[str, float], free, progress: Progress | None = None
              ) -> tuple[FitResult, StageProblem]:
    """Hold the even coefficients that :func:`not_significant` names at 0 and solve the stage
    again from its optimum (one local solve, within MAX_NFEV). The re-fit is taken whatever
    its objective (it is the optimum without a term the data do not support); its FitResult
    keeps the global search's n_starts and starts_at_best, adds the seconds and model
    evaluations, and its message says what was held. ``params``: the values the stage
    started from; ``free``: the stage's candidate list (stage_problem)."""
    drop = not_significant(result)
    if not drop:
        return result, sp
    if progress is not None:
        progress(f"MF {stage}: {', '.join(drop)} held at 0 (not significant); solved again")
    values = {**params, **{n: float(result.parameters[n]) for n in result.free},
              **{n: 0.0 for n in drop}}
    trial = stage_problem(stage, trailer, values, free=free, hold={**sp.held, **drop},
                          like=sp)
    again = fit(trial.problem, starts=trial.problem.x0()[None, :], max_nfev=MAX_NFEV,
                tol=MF_SOLVE)
    names = ", ".join(drop)
    return dataclasses.replace(
        again, n_starts=result.n_starts, starts_at_best=result.starts_at_best,
        seconds=result.seconds + again.seconds, nfev=result.nfev + again.nfev,
        message=f"{again.message} ({names} held at 0 after the fit: not significant)"), trial
