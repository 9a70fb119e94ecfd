"""sigma_y from lateral relaxation runs: the 1-deg run minus its 0-deg reference.

Subtracting the 0-deg reference (same pressure, load and start position) removes ply-steer,
conicity and non-uniformity. The difference builds up as Fy = Fss (1 - exp(-x/sigma)) with the
rolled distance x; sigma_y is the exponential fit (variable projection: for each sigma the best
Fss is linear, so the search is one-dimensional). The distance rolled to 63 % of Fss is kept as
a cross-check. A run shorter than :attr:`Thresholds.short_run` relaxation lengths has not
reached steady state: Fss is then extrapolated by the fit and the run is flagged.
"""
from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
from scipy.optimize import minimize_scalar

from identify.extract.diagnostics import Flag, Part, RunDiagnostic
from identify.extract.flags import Thresholds, cell_means, condition_flags
from identify.extract.linear import smooth
from identify.extract.runs import RunData

__all__ = ["fit_build_up", "distance_63", "pair_with_reference", "difference",
           "extract_relaxation"]


def _sse(x, y, sigma):
    b = -np.expm1(-x[:, None] / np.atleast_1d(sigma)[None, :])
    by, bb = y @ b, (b * b).sum(axis=0)
    return float(y @ y) - by ** 2 / bb, by / bb


def fit_build_up(x: np.ndarray, y: np.ndarray) -> dict:
    """Least-squares fit y = Fss (1 - exp(-x/sigma)).

    Parameters
    ----------
    x : numpy.ndarray
        Rolled distance from the start of rolling, >= 0 [m].
    y : numpy.ndarray
        Force or moment difference [N or N m].

    Returns
    -------
    dict
        ``sigma`` [m], ``fss`` [unit of y], their standard errors ``sigma_se``, ``fss_se``,
        ``r2``, ``rmse`` and ``n``; ``sigma`` is NaN when the curve shows no bend (the best
        fit lies at the end of the search range).
    """
    x, y = np.asarray(x, float), np.asarray(y, float)
    span = float(x.max()) if x.size else 0.0
    out = {"sigma": math.nan, "fss": math.nan, "sigma_se": math.nan, "fss_se": math.nan,
           "r2": math.nan, "rmse": math.nan, "n": int(x.size)}
    if x.size < 5 or span <= 0:
        return out
    grid = np.geomspace(span / 300.0, span * 30.0, 181)
    sse, _ = _sse(x, y, grid)
    k = int(np.argmin(sse))
    if k in (0, grid.size - 1):
        return out
    best = minimize_scalar(lambda s: _sse(x, y, np.exp(s))[0][0], method="bounded",
                           bounds=(math.log(grid[k - 1]), math.log(grid[k + 1])),
                           options={"xatol": 1e-10})
    sigma = float(np.exp(best.x))
    fss = float(_sse(x, y, sigma)[1][0])
    # Brent on the sum of squares stops where it is flat to round-off (sigma to ~1e-7
    # relative); Gauss-Newton steps on the residuals themselves reach the round-off of sigma
    def sse_at(f: float, s: float) -> float:
        return float(np.sum((y - f * (1.0 - np.exp(-x / s))) ** 2))

    for _ in range(4):
        e = np.exp(-x / sigma)
        jac = np.stack([1.0 - e, -fss * x / sigma ** 2 * e], axis=1)
        step = np.linalg.lstsq(jac, y - fss * (1.0 - e), rcond=None)[0]
        f1, s1 = fss + float(step[0]), sigma + float(step[1])
        if not (np.isfinite(f1) and s1 > 0 and sse_at(f1, s1) <= sse_at(fss, sigma)):
            break
        fss, sigma = f1, s1
    e = np.exp(-x / sigma)
    jac = np.stack([1.0 - e, -fss * x / sigma ** 2 * e], axis=1)
    sse_best = float(np.sum((y - fss * (1.0 - e)) ** 2))
    s2 = sse_best / max(x.size - 2, 1)
    try:
        cov = s2 * np.linalg.inv(jac.T @ jac)
        fss_se, sigma_se = float(np.sqrt(cov[0, 0])), float(np.sqrt(cov[1, 1]))
    except np.linalg.LinAlgError:
        fss_se = sigma_se = math.nan
    sst = float(((y - y.mean()) ** 2).sum())
    out.update(sigma=sigma, fss=fss, sigma_se=sigma_se, fss_se=fss_se,
               r2=1.0 - sse_best / sst if sst > 0 else 1.0,
               rmse=float(np.sqrt(sse_best / x.size)))
    return out


def distance_63(x: np.ndarray, y: np.ndarray, fss: float) -> float:
    """Rolled distance [m] at which the (lightly smoothed) build-up first reaches 63.2 % of
    ``fss``; NaN when it never does."""
    level = (1.0 - math.exp(-1.0)) * abs(fss)
    ys = smooth(np.asarray(y, float) * (1.0 if fss >= 0 else -1.0), 0.03)
    above = np.flatnonzero(ys >= level)
    if not math.isfinite(level) or above.size == 0 or above[0] == 0:
        return math.nan
    i = int(above[0])
    return float(np.interp(level, [ys[i - 1], ys[i]], [x[i - 1], x[i]]))


def pair_with_reference(runs: list[RunData], is_reference: Callable[[RunData], bool]
                        ) -> list[tuple[RunData, list[RunData]]]:
    """Each non-reference run with its reference(s): the one of the same start position, else
    every reference of the same pressure x load cell (averaged by :func:`difference`)."""
    refs: dict[tuple, list[RunData]] = {}
    for run in runs:
        if is_reference(run):
            refs.setdefault(run.cell, []).append(run)
    out = []
    for run in runs:
        if is_reference(run):
            continue
        cell = refs.get(run.cell, [])
        same = [r for r in cell if r.start == run.start]
        out.append((run, same or cell))
    return out


def difference(run: RunData, refs: list[RunData], channel: str) -> tuple[np.ndarray, np.ndarray]:
    """Rolled distance [m] of ``run`` and its ``channel`` minus the mean reference,
    interpolated onto the run's distance."""
    x = run.ch["plank_x"] - run.ch["plank_x"][0]
    ref = np.mean([np.interp(x, r.ch["plank_x"] - r.ch["plank_x"][0], r.ch[channel])
                   for r in refs], axis=0)
    return x, run.ch[channel] - ref


def extract_relaxation(runs: list[RunData], th: Thresholds) -> Part:
    """sigma_y per pressure x load cell: the mean of the per-start exponential fits.

    Parameters
    ----------
    runs : list of RunData
        Relaxation runs: slipped runs and their 0-deg references.
    th : Thresholds
        Flag thresholds.
    """
    diags, flags = [], []
    cells: dict[tuple[float, float], list[tuple[float, float]]] = {}
    for run in runs:
        flags += condition_flags(run, th)
    for run, refs in pair_with_reference(runs, lambda r: abs(r.alpha_deg) < 0.05):
        mine = []
        if not refs:
            diags.append(RunDiagnostic(run.run, run.test, "sigma_y", run.p_bar, run.load_N,
                                       run.start, math.nan, extra={"error": "no 0-deg reference"}))
            continue
        x, y = difference(run, refs, "Fy")
        fit = fit_build_up(x, y)
        lengths = float(x.max()) / fit["sigma"] if fit["sigma"] > 0 else math.nan
        if not lengths >= th.short_run:
            mine.append(Flag(run.run, run.test, "short_run",
                             f"rolled {lengths:.1f} relaxation lengths (< {th.short_run:g}): "
                             "no steady state, Fss extrapolated by the exponential fit"))
        flags += mine
        if math.isfinite(fit["sigma"]):
            cells.setdefault(run.cell, []).append((fit["sigma"], fit["sigma_se"]))
        diags.append(RunDiagnostic(
            run.run, run.test, "sigma_y", run.p_bar, run.load_N, run.start, fit["sigma"],
            (0.0, float(x.max())), "m", fit["n"], fit["r2"], fit["rmse"],
            tuple(f.flag for f in mine),
            {"reference": [r.run for r in refs], "Fss_N": fit["fss"], "sigma_se": fit["sigma_se"],
             "distance_63_m": distance_63(x, y, fit["fss"]), "relaxation_lengths": lengths,
             "extrapolated": bool(mine)}))
    rows, spread = cell_means("relaxation", "sigma_y", cells, th)
    return Part(tuple(rows), tuple(diags), tuple(flags + spread))
