"""Refit a candidate and confirm it twice: the F test (cluster-robust Wald under cluster-robust
noise) at its Holm level, and the held-out error over the problem's folds
(:func:`identify.discover.design.folds`). A candidate is kept only when both agree.
"""
from __future__ import annotations

import numpy as np
from scipy import stats

from identify.discover.library import Candidate
from identify.discover.objective import Objective
from identify.discover.prepared_problem import Working, total_error_pct
from identify.discover.result import Trial
from identify.fit.solve.engine import covariance, pseudo_solve
from identify.fit.solve.problem import FitProblem, with_fixed, with_free

__all__ = ["confirm", "fold_errors"]


def fold_errors(w: Working, problem: FitProblem, x: np.ndarray) -> list[float]:
    """Held-out thesis error of each fold, fitting on the other folds from ``x``.

    Parameters the training points cannot determine (a quadratic pressure term with two
    pressure levels left) are held at their values in ``x``, the fit on all points.
    """
    obj = Objective(problem, w.objective.index, w.objective.phi)
    out = []
    for held in w.folds:
        train = obj.subset(~held)
        keep = train.identifiable(x)
        if keep.all():
            xf = train.solve(x).x
        else:
            fixed = with_fixed(problem, [n for n, k in zip(problem.free, keep) if not k], x)
            sub = Objective(fixed, w.objective.index, w.objective.phi, ~held)
            xf = x.copy()
            xf[keep] = sub.solve(x[keep]).x
        out.append(total_error_pct(problem, problem.predict(xf), held))
    return out


def _test(w: Working, ext: FitProblem, sol, cand: Candidate) -> tuple[str, float, float, dict]:
    """(test name, statistic, p-value, stderr) of the candidate's coefficients after the refit."""
    q = cand.dof
    J, r = sol.jac, sol.r
    n, k = J.shape
    pos = [ext.free.index(c) for c in cand.coefficients]
    if w.noise.kind == "cluster":
        idx = w.objective.index
        C = len(idx)
        cov = covariance(J, r, clusters=idx)
        dev = np.array([sol.x[i] - cand.coefficients[c] for i, c in zip(pos, cand.coefficients)])
        block = cov[np.ix_(pos, pos)]
        stat = float(dev @ pseudo_solve(block, dev)) / q
        p = float(stats.f.sf(stat, q, C - 1))
        return "cluster-robust Wald", stat, p, {c: float(np.sqrt(cov[i, i]))
                                                for i, c in zip(pos, cand.coefficients)}
    dof = max(n - k, 1)
    stat = max(w.sol.rss - sol.rss, 0.0) / q / (sol.rss / dof)
    p = float(stats.f.sf(stat, q, dof))
    cov = covariance(J, r)  # s^2 = rss / (n - k)
    return "F", stat, p, {c: float(np.sqrt(cov[i, i])) for i, c in zip(pos, cand.coefficients)}


def confirm(w: Working, cand: Candidate, step: tuple[float, ...], factor: int, alpha: float
             ) -> tuple[Trial, tuple | None]:
    """Refit with ``cand`` freed (from its one-step estimate ``step``), then the F test at the
    Holm level ``factor`` and the held-out errors. Returns the trial and, when accepted, what
    replaces the working problem (problem, objective, solution, fold errors)."""
    vals = w.problem.values(w.x)
    start = {k: vals[k] + dv for k, dv in zip(cand.coefficients, step)}
    ext = with_free(w.problem, start, dict(cand.bounds))
    obj = Objective(ext, w.objective.index, w.objective.phi)
    x_cur = dict(zip(w.problem.free, w.x))
    x0 = np.array([x_cur.get(k, ext.parameters[k].value) for k in ext.free])
    sol = obj.solve(x0)
    if sol.rss > w.sol.rss:  # the one-step start was poor: start at the neutral values
        x1 = np.array([x_cur.get(k, cand.coefficients.get(k, 0.0)) for k in ext.free])
        alt = obj.solve(x1)
        sol = alt if alt.rss < sol.rss else sol
    test, stat, p, se = _test(w, ext, sol, cand)
    p_adj = min(1.0, factor * p)
    if w.fold_errors is None:
        w.fold_errors = fold_errors(w, w.problem, w.x)
    ext_folds = fold_errors(w, ext, sol.x)
    before, after = float(np.mean(w.fold_errors)), float(np.mean(ext_folds))
    err0, err1 = w.error_pct(), total_error_pct(ext, ext.predict(sol.x))
    passes_f, passes_h = p_adj <= alpha, after < before
    reason = ("accepted: F test and held-out error agree" if passes_f and passes_h else
              "rejected: " + "; ".join(
                  ([f"{test} p = {p_adj:.3g} (Holm) > {alpha}"] if not passes_f else [])
                  + ([f"held-out error {before:.3g} % -> {after:.3g} % does not drop"]
                     if not passes_h else [])))
    values = {k: float(sol.x[ext.free.index(k)]) for k in cand.coefficients}
    trial = Trial(cand.name, w.name, values, se, test, stat, p, p_adj, err0, err1, before,
                  after, w.fold_scheme, passes_f and passes_h, reason)
    return trial, ((ext, obj, sol, ext_folds) if trial.accepted else None)
