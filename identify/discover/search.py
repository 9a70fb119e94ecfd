"""The forward-stepwise search: score -> add the best -> refit -> confirm -> repeat.

Per step, every candidate of every problem is scored from the current fit (projected LM test,
:mod:`identify.discover.score`); p-values are Holm-adjusted over all testable candidates; a
candidate passes when its adjusted p-value is below ``alpha`` and it is predicted to explain at
least ``min_explained`` of the excess error above the noise floor (when the base error is above
the floor estimate at all). The best passing candidate
(smallest p) is refitted and kept only when the likelihood-ratio/F test (cluster-robust Wald
under cluster-robust noise), at the same Holm level, AND the held-out error (leave one pressure
level out; whole-sweep folds with fewer than three pressures) agree. Candidates that cannot be
told apart (|cos| > 0.95) are reported as an ambiguity group, never as one confident name.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy import stats

from identify.discover.conclude import conclusion, summaries
from identify.discover.library import Candidate, Library
from identify.discover.objective import Objective, with_fixed, with_free
from identify.discover.result import Accepted, CandidateRow, Discovery, Step, Trial
from identify.discover.result import excess_explained
from identify.discover.score import ambiguity_groups, canonical_cosines, holm, score_candidates
from identify.discover.working import Working, prepare, renoise, total_error_pct
from identify.fit.engine import covariance, pseudo_solve
from identify.fit.problem import FitProblem

__all__ = ["Settings", "discover"]


@dataclass(frozen=True)
class Settings:
    """Settings of a discovery run.

    Attributes
    ----------
    alpha : float            family-wise significance level (Holm) [-]
    max_steps : int          most effects added to one problem
    max_total : int          most steps in all
    min_explained : float    least predicted fraction of the excess error explained [-]
    n_starts : int           base-fit starts (> 1: multi-start global search)
    seed : int
    max_tries : int          candidates refitted per step before stopping
    """

    alpha: float = 0.05
    max_steps: int = 4
    max_total: int = 60
    min_explained: float = 0.10
    n_starts: int = 1
    seed: int = 0
    max_tries: int = 3

    def to_dict(self) -> dict:
        return dataclasses.asdict(self)


def _score(w: Working) -> tuple[dict, dict, list]:
    """Scores, cosines and ambiguity groups of one problem's candidates."""
    t0 = time.process_time()
    vals = w.problem.values(w.x)
    cols = {c.name: w.objective.columns(w.x, {k: vals[k] for k in c.coefficients})
            for c in w.candidates}
    kind = w.noise.kind if w.noise.kind == "cluster" else "independent"
    scores, projected = score_candidates(w.sol.r, w.sol.jac, cols, kind=kind,
                                         clusters=w.objective.index)
    testable = [n for n in scores if scores[n].testable]
    cos = canonical_cosines({n: projected[n] for n in testable})
    groups = ambiguity_groups(testable, cos)
    w.score_seconds = w.score_seconds or time.process_time() - t0
    return scores, cos, groups


def _fold_errors(w: Working, problem: FitProblem, x: np.ndarray) -> list[float]:
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


def _confirm(w: Working, cand: Candidate, step: tuple[float, ...], factor: int, alpha: float
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
        w.fold_errors = _fold_errors(w, w.problem, w.x)
    ext_folds = _fold_errors(w, ext, sol.x)
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


def _rows(works: list[Working], settings: Settings) -> tuple[list, dict]:
    """The candidate table of a step and, per row, what confirmation needs."""
    scored = []
    for w in works:
        scores, cos, groups = _score(w)
        for c in w.candidates:
            scored.append((w, c, scores[c.name], cos, groups))
    pvals = {(w.name, c.name): s.p_value for w, c, s, _, _ in scored if s.testable}
    adj = holm(pvals)
    order = sorted(pvals, key=lambda key: pvals[key])
    factor = {key: len(order) - i for i, key in enumerate(order)}
    rows, info = [], {}
    for w, c, s, cos, groups in scored:
        key = (w.name, c.name)
        e0 = w.error_pct()
        floor = w.floor_pct if np.isfinite(w.floor_pct) else 0.0
        e1 = e0 * np.sqrt(max(1.0 - s.drop / w.sol.rss, 0.0)) if s.testable else e0
        excess = e0 ** 2 - floor ** 2
        # no excess above the floor estimate: the floor (from residuals that still hold the
        # missing effect) is not trusted to block; significance and held-out error decide
        explained = (e0 ** 2 - e1 ** 2) / excess if excess > 0 else float("inf")
        group = next((g for g in groups if c.name in g), ())
        passes = bool(s.testable and adj.get(key, 1.0) <= settings.alpha
                      and explained >= settings.min_explained)
        others = {b: v for (a, b), v in cos.items() if a == c.name}
        rows.append(CandidateRow(c.name, w.name, tuple(c.coefficients), c.equation,
                                 c.description, s.testable, s.rel_norm, s.statistic, s.dof,
                                 s.p_value, adj.get(key, 1.0), e1, explained, others,
                                 tuple(g for g in group if g != c.name), passes))
        info[key] = (w, c, s, factor.get(key, 1))
    return rows, info


def discover(problems: Sequence[FitProblem], library: Library,
             settings: Settings = Settings(), *, base: dict | None = None) -> Discovery:
    """Find missing effects in ``problems`` (library coefficients held at neutral values).

    Parameters
    ----------
    problems : sequence of FitProblem
        The base models with their data; ``extra["name"]`` names a problem for the library's
        ``relations`` patterns (default ``relation/form``).
    library : Library
    settings : Settings
    base : dict, optional
        Description of the base model for the output ({kind, name, tir}).
    """
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1):  # small dense problems: threads only add overhead
        return _discover(problems, library, settings, base)


def _discover(problems, library, settings, base) -> Discovery:
    t0 = time.perf_counter()
    works = [prepare(p, library, n_starts=settings.n_starts, seed=settings.seed)
             for p in problems]
    steps, accepted = [], []
    for k in range(1, settings.max_total + 1):
        live = [w for w in works if len(w.history) < settings.max_steps]
        rows, info = _rows(live, settings)
        passing = sorted((r for r in rows if r.passes and r.name not in
                          info[(r.problem, r.name)][0].rejected),
                         key=lambda r: (info[(r.problem, r.name)][2].log_p, -info[
                             (r.problem, r.name)][2].drop))
        tried, chosen = [], None
        for row in passing[:settings.max_tries]:
            w, cand, s, factor = info[(row.problem, row.name)]
            trial, ext = _confirm(w, cand, s.step, factor, settings.alpha)
            tried.append(trial)
            if ext is None:
                w.rejected.add(cand.name)  # not retried until this problem's model changes
                continue
            problem, obj, sol, ext_folds = ext
            w.problem, w.objective, w.sol, w.fold_errors = problem, obj, sol, ext_folds
            w.candidates = [c for c in w.candidates if c.name != cand.name]
            w.history.append(cand.name)
            w.rejected.clear()
            renoise(w)
            accepted.append(Accepted(
                cand.name, w.name, cand.description, trial.coefficients, trial.stderr,
                trial.error_before_pct, trial.error_after_pct, trial.heldout_before_pct,
                trial.heldout_after_pct, trial.p_adjusted, row.ambiguity_group,
                w.floor_pct, excess_explained(trial.error_before_pct, trial.error_after_pct,
                                              w.floor_pct),
                _sign_note(cand, trial.coefficients)))
            chosen = cand.name
            break
        steps.append(Step(k, tuple(rows), tuple(tried), chosen))
        if chosen is None:
            break
    probs = summaries(works)
    accepted = _with_final_floors(accepted, probs)
    floor, explained = _headline(accepted, probs)
    return Discovery(base=base or {"kind": "given", "name": "", "tir": None},
                     problems=probs, steps=tuple(steps), accepted=tuple(accepted),
                     noise_floor_pct=floor, excess_explained=explained,
                     conclusion=conclusion(accepted, probs, steps),
                     settings=settings.to_dict(), seconds=time.perf_counter() - t0)


def _sign_note(cand: Candidate, values: dict) -> str:
    if not cand.expected_sign:
        return ""
    k = next(iter(cand.coefficients))
    dev = values[k] - cand.coefficients[k]
    if (cand.expected_sign == "+" and dev < 0) or (cand.expected_sign == "-" and dev > 0):
        return f"sign opposite to the physically expected one ({cand.expected_sign})"
    return ""


def _with_final_floors(accepted: list, probs) -> list:
    """The noise floor of an accepted effect is its problem's, from the final residuals."""
    by = {p.name: p for p in probs}
    out = []
    for a in accepted:
        f = by[a.problem].noise_floor_pct
        out.append(dataclasses.replace(a, noise_floor_pct=f, excess_explained=excess_explained(
            a.error_before_pct, a.error_after_pct, f)))
    return out


def _headline(accepted, probs) -> tuple[float, float]:
    if accepted:
        return accepted[0].noise_floor_pct, accepted[0].excess_explained
    if not probs:
        return float("nan"), float("nan")
    worst = max(probs, key=lambda p: p.final_error_pct ** 2 - p.noise_floor_pct ** 2
                if np.isfinite(p.noise_floor_pct) else -np.inf)
    return worst.noise_floor_pct, float("nan")
