"""Global-search settings and result post-processing of the MF stages (identify.fit.mf_stages).

Start points (n_starts chosen deliberately: a stage has up to 29 free coefficients, so the
engine's 8 x free parameters Latin-hypercube starts over the full bounds would cost minutes and
mostly land in flat, meaningless regions): the carried-forward values, the parameter table's
defaults, and N_LHS Latin-hypercube points in a box of +/-BOX x max(|start|, |default|) around
the carried-forward values (+/-0.05 where both are 0), each solved within MAX_NFEV
evaluations.
"""
from __future__ import annotations

import dataclasses
from typing import Mapping

import numpy as np
from scipy.stats import qmc

from identify.fit.metric import thesis_error_by_group
from identify.fit.mf_stage_defs import stage_model
from identify.fit.problem import FitProblem
from identify.fit.result import FitResult
from identify.model.parameters import spec
from identify.model.state import OperatingState

__all__ = ["N_LHS", "MAX_NFEV", "BOX", "start_points", "canonical_br", "final_predictions"]

N_LHS = 2
"""Latin-hypercube starts per stage besides the carried-forward and default values."""
MAX_NFEV = 100
"""Budget of model evaluations per start's least-squares solve (Jacobian evaluations not
counted). Starts near the optimum converge in 15-60; a start that crawls through a flat
region for longer is reported as not converged instead of costing minutes."""
BOX = 0.5
"""Half width of the start box relative to max(|start|, |default|) (0.05 absolute at 0)."""


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


def canonical_br(result: FitResult, start: Mapping[str, float]) -> FitResult:
    """Mz depends on Br = QBZ9*LKY/LMUY + QBZ10*By*Cy only through cos(atan(Br*alpha)), so
    (QBZ9, QBZ10) and (-QBZ9, -QBZ10) predict identically (bit for bit); return the one
    nearer the start values (relative to max(|start|, 1e-3))."""
    pair = ("QBZ9", "QBZ10")
    if not set(pair) <= set(result.free):
        return result
    q = np.array([result.parameters[n] for n in pair])
    s = np.array([float(start[n]) for n in pair])
    scale = np.maximum(np.abs(s), 1e-3)
    if np.sum(((q - s) / scale) ** 2) <= np.sum(((-q - s) / scale) ** 2):
        return result
    values = {n: (-v if n in pair else v) for n, v in result.parameters.items()}
    corr = {k: (-c if len(set(pair) & set(k.split("|"))) == 1 else c)
            for k, c in result.correlations.items()}
    return dataclasses.replace(result, parameters=values, correlations=corr)


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
