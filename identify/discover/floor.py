"""The noise floor of a problem without sweeps (a characteristic table).

A table has no within-sweep variogram, and the base model's own residuals hold the very
effect discovery is looking for, so the floor never comes from them. In order of preference:

1. **replicates**: points measured at the same conditions (pressure, load, speed, camber,
   slip ...) twice or more with different values (identical copies of a row are not
   replicates); the pure-error variance is the scatter within those groups,
   s^2 = sum (y_i - mean_g)^2 / (N_replicated - G), on the weighted values;
2. **the richest candidate model**: the problem with every remaining candidate freed (those the
   points cannot determine held at neutral), s^2 = RSS / (n - p);
3. the final model's residual variance, when the problem has no candidate left.

The floor is the thesis error of noise of that level (:func:`noise_floor_pct`), and it is
capped at the error of the best model found: a floor above an achieved error is an estimate
that the data already contradict (too few degrees of freedom), never a reason to look further.
"""
from __future__ import annotations

import numpy as np

from identify.discover.library import Candidate
from identify.discover.objective import Objective
from identify.fit.solve.problem import FitProblem, with_fixed, with_free

__all__ = ["replicate_sigma", "richest_sigma", "table_floor_sigma", "CONDITION_KEYS"]

CONDITION_KEYS = ("Fz_N", "Vx_mps", "gamma_deg", "alpha_rad", "kappa", "quantity", "mode")
"""Per-point conditions (``FitProblem.extra``) that make two points replicates when equal."""


def _condition_groups(problem: FitProblem) -> np.ndarray:
    """Group number of each point's conditions (pressure and the extra condition arrays,
    SI values rounded to 6 decimals)."""
    n = problem.measured.size
    cols = [np.unique(np.round(problem.pressure_bar, 6), return_inverse=True)[1]]
    for key in CONDITION_KEYS:
        v = problem.extra.get(key)
        if v is None or np.ndim(v) == 0 or np.size(v) != n:
            continue
        v = np.asarray(v)
        v = np.nan_to_num(np.round(v.astype(float), 6), nan=-1e300) if v.dtype.kind in "fiu" \
            else v.astype(str)
        cols.append(np.unique(v, return_inverse=True)[1])
    return np.unique(np.stack(cols, axis=1), axis=0, return_inverse=True)[1].ravel()


def replicate_sigma(problem: FitProblem) -> tuple[float, int] | None:
    """(pure-error std of the weighted values, its degrees of freedom), or None without
    replicated conditions (or fewer than 2 degrees of freedom)."""
    g = _condition_groups(problem)
    y = problem.measured * problem.weights()
    cnt = np.bincount(g)
    mean = np.bincount(g, y) / cnt
    dev = y - mean[g]
    # a group whose values are all equal holds copies of one row (a table listed twice),
    # not repeated measurements
    spread = np.bincount(g, np.abs(dev)) > 0
    rep = (cnt[g] >= 2) & spread[g]
    dof = int(rep.sum() - np.count_nonzero((cnt >= 2) & spread))
    if dof < 2:
        return None
    ss = float(np.sum(dev[rep] ** 2))
    return float(np.sqrt(ss / dof)), dof


def richest_sigma(problem: FitProblem, x: np.ndarray, candidates: list[Candidate],
                  index) -> tuple[float, int] | None:
    """(residual std of the weighted residuals, degrees of freedom) of the problem with every
    candidate freed (coefficients the points cannot determine held at neutral), or None
    without candidates or degrees of freedom."""
    if not candidates:
        return None
    start = {k: v for c in candidates for k, v in c.coefficients.items()}
    bounds = {k: b for c in candidates for k, b in c.bounds.items()}
    rich = with_free(problem, start, bounds)
    known = dict(zip(problem.free, x))
    x0 = np.array([known.get(k, rich.parameters[k].value) for k in rich.free])
    obj = Objective(rich, index)
    keep = obj.identifiable(x0)
    if not keep.all():
        rich = with_fixed(rich, [n for n, k in zip(rich.free, keep) if not k], x0)
        x0 = x0[keep]
        obj = Objective(rich, index)
    dof = problem.measured.size - len(rich.free)
    if dof < 1 or len(rich.free) <= len(problem.free):
        return None
    sol = obj.solve(x0)
    return float(np.sqrt(sol.rss / dof)), dof


def table_floor_sigma(problem: FitProblem, x: np.ndarray, candidates: list[Candidate],
                      index) -> tuple[float, str] | None:
    """(std of the weighted noise, source) for a table (module doc), or None."""
    rep = replicate_sigma(problem)
    if rep is not None:
        return rep[0], f"replicated conditions, {rep[1]} dof"
    rich = richest_sigma(problem, x, candidates, index)
    if rich is not None:
        return rich[0], f"richest candidate model, {rich[1]} dof"
    return None
