"""One problem under discovery: base fit, convergence check, error model, diagnosis, folds.

:func:`prepare` turns a :class:`~identify.fit.solve.problem.FitProblem` (library coefficients
present and held at their neutral values) into a :class:`Working` problem:

1. fit the base model (weighted least squares with the thesis-metric group weights; optional
   multi-start through :func:`identify.fit.optimize.fit`) and check it is a stationary point;
2. with sweeps: the noise std of each noise group (run) and the AR(1) coefficient from the
   within-sweep variogram of the residuals, refit with weights 1/sigma, choose the error model
   (:func:`identify.discover.noise.choose_noise`) and refit prewhitened if AR(1);
3. thesis error per pressure and per condition cell, the noise floor, the held-out folds.
"""
from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

from identify.discover.design import folds, levels
from identify.discover.drift import DRIFT_KEY, with_drift
from identify.discover.floor import table_floor_sigma
from identify.discover.library import Candidate, Library
from identify.discover.noise import (
    MIN_SWEEP,
    PHI_MIN,
    NoiseModel,
    choose_noise,
    fit_ar1,
    group_variogram,
    sweep_index,
    variogram,
)
from identify.discover.objective import Objective, Solution, problem_name
from identify.discover.stage_problems import add_parameter
from identify.fit.optimize import fit
from identify.fit.solve.metric import thesis_error, thesis_error_by_group
from identify.fit.solve.problem import FitProblem

__all__ = ["Working", "prepare", "cells", "folds", "metric_groups", "total_error_pct",
           "final_floor", "renoise", "refresh", "noise_scale", "by_range", "group_scale",
           "errors_by_group", "MOMENTS"]

LONG_LAGS = 20
"""Variogram lags for the noise floor of correlated noise from the final residuals."""


@dataclass
class Working:
    """Mutable working state of one problem during the search (internal)."""

    name: str
    problem: FitProblem
    objective: Objective
    sol: Solution
    noise: NoiseModel
    candidates: list[Candidate]
    base_free: tuple[str, ...]
    base_error_pct: float
    base_by_pressure: dict
    base_predicted: np.ndarray
    converged: bool
    stationary: bool
    message: str
    floor_pct: float
    floor_source: str
    fit_seconds: float
    folds: list[np.ndarray]
    fold_scheme: str
    fold_errors: list[float] | None = None
    has_sweeps: bool = False
    base_noise: NoiseModel | None = None
    score_seconds: float = 0.0
    columns: dict = field(default_factory=dict)
    history: list[str] = field(default_factory=list)
    rejected: set = field(default_factory=set)

    @property
    def x(self) -> np.ndarray:
        return self.sol.x

    def error_pct(self, x: np.ndarray | None = None) -> float:
        p = self.problem
        return total_error_pct(p, p.predict(self.x if x is None else x))


def metric_groups(problem: FitProblem) -> np.ndarray:
    """Group id of each point for the thesis metric: the pressure, and within a pressure the
    characteristic (``extra["metric_group"]``, e.g. the sweep shape of MF stage data)."""
    pres = np.round(problem.pressure_bar, 6).astype(str)
    extra = problem.extra.get("metric_group")
    labels = pres if extra is None else np.char.add(np.char.add(pres, "|"),
                                                    np.asarray(extra).astype(str))
    return np.unique(labels, return_inverse=True)[1]


MOMENTS = ("Mx", "My", "Mz")
"""Quantities whose errors are relative to their range (:func:`by_range`)."""


def by_range(problem: FitProblem) -> bool:
    """Are the errors of ``problem`` relative to each group's range (moments) rather than to
    its RMS (the thesis metric)?

    A moment passes through zero within a sweep (Mz changes sign near the peak of Fy, Mx with
    camber): an error relative to the RMS of such values says little (a cell of near-zero Mz
    reached thousands of per cent, a noise floor 42 %). Relative to the range the measured
    values span in the group, the same error reads as a fraction of the curve's height.
    """
    return problem.extra.get("quantity") in MOMENTS


def group_scale(measured: np.ndarray, groups: np.ndarray, ranged: bool = False
                ) -> np.ndarray:
    """Per point, the scale S of its group with error = 100 sqrt(sum e^2) / S [%]:
    sqrt(sum A^2) (thesis metric) or, ``ranged``, (max A - min A) sqrt(n) (RMS error over the
    range). A group without a range falls back to its RMS scale (1 where that is 0 too)."""
    a = np.asarray(measured, dtype=float)
    _, inv = np.unique(np.asarray(groups), return_inverse=True)
    rms = np.sqrt(np.bincount(inv, a ** 2))
    scale = rms
    if ranged:
        lo = np.full(rms.size, np.inf)
        hi = np.full(rms.size, -np.inf)
        np.minimum.at(lo, inv, a)
        np.maximum.at(hi, inv, a)
        span = (hi - lo) * np.sqrt(np.bincount(inv))
        scale = np.where(span > 0, span, rms)
    return np.where(scale > 0, scale, 1.0)[inv]


def errors_by_group(problem: FitProblem, pred: np.ndarray, groups: np.ndarray,
                    mask: np.ndarray | None = None) -> dict[float, float]:
    """Error [%] per group of the points in ``mask`` (:func:`group_scale`, the problem's
    metric)."""
    meas, g = problem.measured, np.asarray(groups)
    if mask is not None:
        pred, meas, g = pred[mask], meas[mask], g[mask]
    if not by_range(problem):
        return thesis_error_by_group(pred, meas, g)
    scale = group_scale(meas, g, True)
    _, first, inv = np.unique(g, return_index=True, return_inverse=True)
    num = np.sqrt(np.bincount(inv, (np.asarray(pred, dtype=float) - meas) ** 2))
    return {float(k) if np.issubdtype(np.asarray(g).dtype, np.number) else k:
            float(100.0 * v / scale[i]) for k, v, i in zip(g[first], num, first)}


def total_error_pct(problem: FitProblem, pred: np.ndarray, mask: np.ndarray | None = None
                    ) -> float:
    """Total error [%]: mean over the metric groups of the points in ``mask`` (thesis metric;
    relative to the range for moments, :func:`by_range`)."""
    return float(np.mean(list(errors_by_group(problem, pred, metric_groups(problem),
                                              mask).values())))


def _applicable(problem: FitProblem, name: str, library: Library) -> tuple[FitProblem, list]:
    """Inject missing candidate coefficients where the model reads the whole .tir; return the
    problem and the candidates present at their neutral values."""
    out = []
    for cand in library.for_problem(name):
        if DRIFT_KEY in cand.coefficients:
            if problem.extra.get("session_pos") is None:
                continue  # no session order: a drift cannot be told from anything
            if DRIFT_KEY not in problem.parameters:
                problem = with_drift(problem)
        for k, neutral in cand.coefficients.items():
            if k not in problem.parameters and problem.extra.get("full_tir"):
                problem = add_parameter(problem, k, neutral)
        P = problem.parameters
        if all(k in P and not P[k].vary and abs(P[k].value - v) <= 1e-12
               for k, v in cand.coefficients.items()):
            out.append(cand)
    return problem, out


def noise_scale(e: np.ndarray, index: list[np.ndarray], groups: np.ndarray,
                long_lags: int = 0) -> tuple[float, np.ndarray]:
    """(phi, marginal noise std per point) from the within-sweep variogram of residuals ``e``.

    Each noise group is normalised by its lag-one semivariogram; phi comes from lags 1..3 of
    the pooled variogram (robust to a smooth misfit). With ``long_lags`` and phi >= PHI_MIN the
    marginal level is refined on lags 1..long_lags (for residuals that are pure noise: a long
    variogram pins the plateau of strongly correlated noise). A group without pairs (a sweep
    fragment of one sample) takes the level pooled over every pair: it has no noise of its own
    to read, and one such point must not void the floor of a whole session (it did: the floor
    of a TTC session became 0 and every candidate had to explain 10 % of the whole error).
    NaN stds only when no group has pairs.
    """
    gam1, _ = group_variogram(e, index, groups, 1)  # one pass over the points
    ok = np.isfinite(gam1) & (gam1 > 0)
    if not ok.all():
        pooled = variogram(e, index, 1)[0]  # NaN without pairs
        if not (np.isfinite(pooled) and pooled > 0):
            return 0.0, np.full(e.size, np.nan)
        gam1 = np.where(ok, gam1, pooled)
    en = e / np.sqrt(gam1)
    phi, s2 = fit_ar1(variogram(en, index))
    if phi < PHI_MIN:
        return phi, np.sqrt(gam1)
    if long_lags:
        long = variogram(en, index, long_lags)
        phi, s2 = fit_ar1(long)
        # the level the variogram reaches within the long lags, not extrapolated past them:
        # noise correlated over more samples (phi -> 1 on 100 Hz rig data) cannot be told
        # from a smooth misfit along the sweep, and its extrapolated plateau made floors
        # above the model's own error
        if np.any(np.isfinite(long)):
            s2 = min(s2, float(np.nanmax(long)))
    return phi, np.sqrt(gam1 * s2)


def noise_floor_pct(sigma: np.ndarray, meas: np.ndarray, groups: np.ndarray,
                    ranged: bool = False) -> float:
    """Error of the noise alone: mean over groups of 100 sqrt(sum s^2) / S [%] (S:
    :func:`group_scale`; the thesis metric's sqrt(sum A^2), or the range for moments)."""
    _, first, inv = np.unique(groups, return_index=True, return_inverse=True)
    num = np.bincount(inv, np.asarray(sigma, dtype=float) ** 2)
    den = group_scale(meas, groups, ranged)[first]
    return float(np.mean(100.0 * np.sqrt(num) / den))


def final_floor(w: Working) -> tuple[float, str]:
    """Noise floor [%] and its source at the end of the search: the within-sweep variogram of
    the final residuals (long lags for correlated noise); for a table the estimate made at the
    start (:mod:`identify.discover.floor`), else the final residual variance. Never above the
    final model's error (the best model found)."""
    p = w.problem
    pred = p.predict(w.x)
    e = pred - p.measured
    best = total_error_pct(p, pred)
    floor, source = float("nan"), ""
    if w.has_sweeps:
        groups = np.asarray(p.extra.get("noise_group", p.pressure_bar))
        _, sigma = noise_scale(e, w.objective.index, groups, long_lags=LONG_LAGS)
        if np.all(np.isfinite(sigma)):
            floor = noise_floor_pct(sigma, p.measured, metric_groups(p), by_range(p))
            source = "within-sweep variogram"
    elif np.isfinite(w.floor_pct):
        floor, source = w.floor_pct, w.floor_source
    if not np.isfinite(floor):
        r = e / np.asarray(p.sigma, dtype=float)
        s = np.sqrt(float(r @ r) / max(r.size - len(p.free), 1))
        floor = noise_floor_pct(s * np.asarray(p.sigma, dtype=float), p.measured,
                                metric_groups(p), by_range(p))
        source = "final residuals (no replicates, no candidate left)"
    if floor > best:
        return best, f"{source}; capped at the final error"
    return floor, source


def refresh(w: Working, problem: FitProblem) -> None:
    """Refit ``w`` on ``problem``: its own problem re-bound to new upstream values (same free
    parameters, weights and error model), from its current solution."""
    w.problem = problem
    w.objective = Objective(problem, w.objective.index, w.objective.phi)
    w.sol = w.objective.solve(w.x)
    w.fold_errors = None
    w.rejected.clear()


def renoise(w: Working) -> None:
    """Re-choose the error model from the current residuals; refit if phi changed."""
    if not w.has_sweeps:
        return
    w.noise = choose_noise(w.problem.residuals(w.x), w.objective.index)
    phi = w.noise.phi if w.noise.kind == "ar1" else 0.0
    if phi != w.objective.phi:
        w.objective = Objective(w.problem, w.objective.index, phi)
        w.sol = w.objective.solve(w.x)
        w.fold_errors = None


def load_levels(fz: np.ndarray, sweeps: np.ndarray | None = None) -> np.ndarray:
    """Each point's load level [N]: its sweep's mean load (the point's own load without
    sweeps), clustered (:func:`identify.discover.design.levels`) and replaced by the level's
    mean. A measured load wanders along a sweep: rounded point by point, a cell held a few
    points of one sweep and a moment's error there read thousands of per cent."""
    fz = np.asarray(fz, dtype=float)
    if sweeps is not None and np.size(sweeps) == fz.size:
        fz = pd.Series(fz).groupby(np.asarray(sweeps)).transform("mean").to_numpy()
    lv = levels(fz)
    out = pd.Series(fz).groupby(lv).transform("mean").to_numpy(dtype=float, copy=True)
    out[lv < 0] = np.nan
    return out


def cells(problem: FitProblem, pred: np.ndarray) -> tuple[dict, ...]:
    """Error per condition cell: pressure x load x camber class [%] (thesis metric; for
    moments relative to the cell's range, :func:`by_range`), and ``rms`` [unit of the
    quantity], the RMS error itself."""
    n = problem.measured.size
    fz = np.asarray(problem.extra.get("Fz_N", np.full(n, np.nan)), dtype=float)
    g = np.asarray(problem.extra.get("gamma_deg", np.zeros(n)), dtype=float)
    gcls = np.where(g < -0.5, "<0", np.where(g > 0.5, ">0", "0"))
    fzr = np.round(load_levels(fz, problem.sweeps), -1)
    out = []
    keys = sorted({(float(a), float(b), str(c)) for a, b, c in
                   zip(problem.pressure_bar, fzr, gcls)}, key=lambda t: (t[0], t[1], t[2]))
    for pb, f, gc in keys:
        sel = (problem.pressure_bar == pb) & ((fzr == f) | (np.isnan(fzr) & np.isnan(f))) \
            & (gcls == gc)
        out.append({"pi_bar": pb, "Fz_N": None if np.isnan(f) else f, "gamma": gc,
                    "n": int(sel.sum()),
                    "error_pct": _cell_error(problem, pred[sel], problem.measured[sel]),
                    "rms": float(np.sqrt(np.mean((pred[sel] - problem.measured[sel]) ** 2)))})
    return tuple(out)


def _cell_error(problem: FitProblem, pred: np.ndarray, meas: np.ndarray) -> float:
    if not by_range(problem):
        return thesis_error(pred, meas)
    span = float(np.ptp(meas)) if meas.size else 0.0
    rms = float(np.sqrt(np.mean((pred - meas) ** 2))) if meas.size else 0.0
    return 100.0 * rms / span if span > 0 else thesis_error(pred, meas)


def prepare(problem: FitProblem, library: Library, *, n_starts: int = 1,
            seed: int = 0, heldout: str = "auto") -> Working:
    """Fit the base model of ``problem`` and diagnose it (see the module docstring)."""
    name = problem_name(problem)
    p = dataclasses.replace(problem, objective="wls", constraints=(), sigma=None)
    p = dataclasses.replace(p, sigma=group_scale(p.measured, metric_groups(p), by_range(p)))
    p, cands = _applicable(p, name, library)
    index = sweep_index(p.sweeps, p.measured.size)
    t0 = time.process_time()
    x0 = p.x0()
    if n_starts > 1 and x0.size:
        x0 = np.array([fit(p, n_starts=n_starts, seed=seed).parameters[k] for k in p.free])
    sol = Objective(p, index).solve(x0, central=True)
    if not (sol.ok and sol.stationary):  # one more solve from where the budget ran out
        again = Objective(p, index).solve(sol.x, central=True)
        if again.rss <= sol.rss:
            sol = again
    fit_seconds = time.process_time() - t0
    converged, stationary, message = sol.ok, sol.stationary, sol.message
    noise = choose_noise(sol.r, [])
    floor, source, phi = float("nan"), "no sweeps", 0.0
    has_sweeps = bool(np.any(index.sizes >= MIN_SWEEP))
    if has_sweeps:
        e = p.predict(sol.x) - p.measured
        groups = np.asarray(p.extra.get("noise_group", p.pressure_bar))
        _, sigma = noise_scale(e, index, groups)
        if np.all(np.isfinite(sigma)) and np.all(sigma > 0):
            p = dataclasses.replace(p, sigma=sigma)
            sol = Objective(p, index).solve(sol.x)
            floor = noise_floor_pct(sigma, p.measured, metric_groups(p), by_range(p))
            source = "within-sweep variogram"
        noise = choose_noise(sol.r, index)
        phi = noise.phi if noise.kind == "ar1" else 0.0
        if phi:
            sol = Objective(p, index, phi).solve(sol.x)
    else:
        est = table_floor_sigma(p, sol.x, cands, index)
        if est is not None:
            floor = noise_floor_pct(est[0] * np.asarray(p.sigma, dtype=float), p.measured,
                                    metric_groups(p), by_range(p))
            source = est[1]
    obj = Objective(p, index, phi)
    pred = p.predict(sol.x)
    by_p = errors_by_group(p, pred, p.pressure_bar)
    base_error = total_error_pct(p, pred)
    masks, scheme = folds(p, index, scheme=heldout)
    return Working(name=name, problem=p, objective=obj, sol=sol, noise=noise,
                   candidates=cands, base_free=p.free,
                   base_error_pct=base_error, base_by_pressure=by_p,
                   base_predicted=pred, converged=converged, stationary=stationary,
                   message=message, floor_pct=floor, floor_source=source,
                   fit_seconds=fit_seconds, folds=masks, fold_scheme=scheme,
                   has_sweeps=has_sweeps, base_noise=noise)
