"""The status of a fit: one vocabulary for fit.json, the console, the report and batch summaries.

A fit's status weighs two things: whether its coefficients are determined by the data
(identifiability, identify.fit.identifiability) and whether its error is what the data allow.
The second needs the **noise floor**: the error no model of the quantity can go below on these
points, because the measurements themselves scatter that much (:func:`noise_floor`). Statuses,
worst first (:data:`STATUSES`):

``failed``
    The solver did not converge, or the model misses the data grossly: the error of the fit, or
    of one pressure's points, is at least :data:`GROSS_ERROR_PCT` (more than half of the
    measured signal's sum of squares left unexplained). Its coefficients describe no tyre.
``poor fit``
    The error is more than :data:`POOR_FIT_RATIO` times the noise floor (and above
    :data:`POOR_FIT_MIN_PCT`), or above :data:`MAX_OK_ERROR_PCT` whatever the floor: the model
    misses the data systematically; the reason names the error, the floor and the factor.
``poorly identified``
    The error is what the data allow, but some coefficient is not determined by the data
    (identify.fit.identifiability).
``ok``
    Neither.

Every caller that shows a status takes it from :func:`fit_status` (FitResult.status_text) and
compares it with these constants, never with a literal of its own.
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

__all__ = ["OK", "POORLY_IDENTIFIED", "POOR_FIT", "FAILED", "STATUSES", "GROSS_ERROR_PCT",
           "POOR_FIT_RATIO", "POOR_FIT_MIN_PCT", "MAX_OK_ERROR_PCT", "Floor", "noise_floor",
           "quality_problems", "fit_status", "worst"]

OK = "ok"
POORLY_IDENTIFIED = "poorly identified"
POOR_FIT = "poor fit"
FAILED = "failed"
STATUSES: tuple[str, ...] = (OK, POORLY_IDENTIFIED, POOR_FIT, FAILED)
"""Every status a fit can have, least to most severe."""

GROSS_ERROR_PCT = 70.0
"""[%] Thesis error at or above which a fit (or one pressure's points) is ``failed``: at
sqrt(0.5) = 70.7 % the residuals hold half of the measured signal's sum of squares, so the
model leaves more of the data unexplained than it explains."""
POOR_FIT_RATIO = 3.0
"""Error / noise floor above which a fit is a ``poor fit``: its systematic part,
sqrt(error^2 - floor^2), is then more than 2.8 times what the measurements scatter."""
POOR_FIT_MIN_PCT = 2.0
"""[%] Below this error a fit is not called a poor fit whatever its floor: within the
calibration accuracy of a trailer's force and moment transducers (about 1 % of full scale
each way), so a floor far below it (a low-noise or generated session) is no yardstick."""
MAX_OK_ERROR_PCT = 30.0
"""[%] Above this error a fit is at best a ``poor fit``, whatever its floor: a model that
misses by almost a third of the signal is not ``ok`` even on data that scatter that much."""


def worst(statuses) -> str:
    """The most severe of ``statuses`` (``ok`` for none)."""
    ranked = [STATUSES.index(s) for s in statuses if s in STATUSES]
    return STATUSES[max(ranked)] if ranked else OK


@dataclass(frozen=True)
class Floor:
    """The noise floor of one fit.

    Attributes
    ----------
    pct : float       thesis error [%] of the measurements' own scatter (mean over pressures,
                      as the fit's total error); NaN when the points hold no estimate
    source : str      where it comes from: ``repeated sweeps`` (the scatter of sweeps run
                      twice at the same conditions about their common curve, neighbouring
                      samples' noise included) or ``neighbouring samples`` (the noise from the
                      residuals' differences between neighbours along each sweep)
    """

    pct: float
    source: str


def _pairs_sigma2(r: np.ndarray, sweeps: np.ndarray, inv: np.ndarray, n_groups: int
                  ) -> np.ndarray:
    """Per group: the lag-one semivariogram of ``r`` within sweeps, 0.5 mean((r[t+1] -
    r[t])^2) over neighbours of one sweep and group (NaN without such pairs): the noise
    variance, robust to a smooth misfit."""
    same = (sweeps[1:] == sweeps[:-1]) & (inv[1:] == inv[:-1])
    d = (r[1:] - r[:-1])[same]
    g = inv[:-1][same]
    cnt = np.bincount(g, minlength=n_groups)
    ssq = np.bincount(g, d * d, minlength=n_groups)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(cnt > 0, 0.5 * ssq / np.maximum(cnt, 1), np.nan)


def _levels(v: np.ndarray, resolution: float) -> np.ndarray:
    """Level number of every value of ``v``: sorted values closer than ``resolution`` are
    one level (NaN: level -1)."""
    out = np.full(v.shape, -1, dtype=np.int64)
    ok = np.isfinite(v)
    if not ok.any():
        return out
    order = np.argsort(v[ok], kind="stable")
    s = v[ok][order]
    lev = np.r_[0, np.cumsum(np.diff(s) > resolution)]
    tmp = np.empty_like(lev)
    tmp[order] = lev
    out[ok] = tmp
    return out


def _repeat_ss(measured: np.ndarray, sweeps: np.ndarray, inv: np.ndarray, n_groups: int,
               conditions: Mapping[str, np.ndarray], fnomin: float, by_speed: bool
               ) -> tuple[np.ndarray, np.ndarray]:
    """Per pressure group: (sum of squared deviations of the repeated points from their
    common curve, sum of the squared measurements of those points). Zeros where no
    condition was repeated. The deviations are the least any model single-valued in the
    conditions and the slip can leave (no correction for the curve's degrees of freedom: that
    would count the repeats' difference, no noise, as if it were; the noise part is the
    neighbouring samples' estimate, which :func:`noise_floor` takes where it is larger).

    A sweep's condition is the mean of its load, camber, speed and held slip; its swept
    variable is the slip it spans more of (alpha [deg] against 100 kappa). Sweeps of one
    pressure group whose conditions fall on the same levels (load within 5 % of FNOMIN,
    camber 0.5 deg, held slip 0.5 deg or 0.01, and speed 1 m/s where the fitted model
    depends on the speed, ``by_speed``) are repeats; along the swept
    slip their points share bins (0.25 deg, 0.0025: the sweep binning's widths), and in
    every bin holding points of two or more repeats the common curve is a straight line
    (the mean when the bin's points sit at one slip, as binned sweeps do)."""
    ss = np.zeros(n_groups)
    yy = np.zeros(n_groups)
    alpha = np.rad2deg(conditions["alpha"])
    kappa = conditions["kappa"]
    sw_ids, sw_inv = np.unique(sweeps, return_inverse=True)
    n_sw = sw_ids.size

    order = np.argsort(sw_inv, kind="stable")
    starts = np.r_[0, np.cumsum(np.bincount(sw_inv, minlength=n_sw))[:-1]]

    def mean(v: np.ndarray) -> np.ndarray:
        ok = np.isfinite(v)
        cnt = np.bincount(sw_inv[ok], minlength=n_sw)
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.bincount(sw_inv[ok], v[ok], n_sw) / cnt

    def span(v: np.ndarray) -> np.ndarray:
        vs = v[order]
        return np.fmax.reduceat(vs, starts) - np.fmin.reduceat(vs, starts)

    by_alpha = np.nan_to_num(span(alpha)) >= np.nan_to_num(span(100.0 * kappa))
    held = np.where(by_alpha, mean(kappa) * 50.0, mean(alpha))  # kappa 0.01 -> 0.5
    group_of_sweep = np.zeros(n_sw, dtype=np.int64)
    group_of_sweep[sw_inv] = inv  # a sweep lies in one pressure group
    keys = np.stack([
        group_of_sweep, by_alpha.astype(np.int64),
        _levels(mean(conditions["Fz"]), 0.05 * fnomin),
        _levels(mean(np.rad2deg(conditions["gamma"])), 0.5),
        _levels(mean(conditions["Vx"]), 1.0) if by_speed else np.zeros(n_sw, np.int64),
        _levels(held, 0.5)], axis=1)
    _, cell_of_sweep = np.unique(keys, axis=0, return_inverse=True)
    cell = cell_of_sweep.ravel()[sw_inv]
    x = np.where(by_alpha[sw_inv], alpha / 0.25, kappa / 0.0025)
    ok = np.isfinite(x) & np.isfinite(measured)
    if not ok.any():
        return ss, yy
    bins = np.floor(np.where(ok, x, 0.0)).astype(np.int64)
    _, grp = np.unique(np.stack([cell, bins], axis=1)[ok], axis=0, return_inverse=True)
    grp = grp.ravel()
    G = int(grp.max()) + 1
    # sweeps per bin: a bin counts only with points of two or more repeats
    _, first = np.unique(np.stack([grp, sw_inv[ok]], axis=1), axis=0, return_index=True)
    n_rep = np.bincount(grp[first], minlength=G)
    y, xv = measured[ok], x[ok]
    n = np.bincount(grp, minlength=G).astype(float)
    sx, sy = np.bincount(grp, xv, G), np.bincount(grp, y, G)
    sxx, sxy, syy = (np.bincount(grp, xv * xv, G), np.bincount(grp, xv * y, G),
                     np.bincount(grp, y * y, G))
    with np.errstate(invalid="ignore", divide="ignore"):
        cxx = sxx - sx * sx / n
        cxy = sxy - sx * sy / n
        cyy = syy - sy * sy / n
        line = cxx > 1e-6 * n  # the points spread along the slip within the bin
        rss = np.where(line, cyy - cxy * cxy / np.where(line, cxx, 1.0), cyy)
        use = (n_rep >= 2) & (n > np.where(line, 2, 1))
        least = np.where(use, np.maximum(rss, 0.0), 0.0)
    g_of_bin = np.zeros(G, dtype=np.int64)
    g_of_bin[grp] = inv[ok]
    ss += np.bincount(g_of_bin, least, n_groups)
    yy += np.bincount(g_of_bin, np.where(use, syy, 0.0), n_groups)
    return ss, yy


def noise_floor(measured: np.ndarray, predicted: np.ndarray, pressure_bar: np.ndarray,
                sweeps: np.ndarray | None,
                conditions: Mapping[str, np.ndarray] | None = None,
                fnomin: float = math.nan, by_speed: bool = True) -> Floor:
    """The noise floor [%] of a fit's points (module docstring), as its thesis error: per
    pressure, 100 sqrt(n s^2 / sum A^2), the mean over pressures.

    Per pressure the larger of two estimates of s^2: the lag-one semivariogram of the
    residuals along each sweep (neighbouring samples: white noise, blind to drift and
    hysteresis), and, where sweeps were repeated at the same conditions (``conditions``:
    Fz [N], alpha [rad], kappa [-], gamma [rad], Vx [m/s] per point, with ``fnomin`` [N]), the
    scatter of the repeats about their common curve (what no single-valued model can remove:
    noise, drift, hysteresis and wear between the runs). Capped at the fit's own error: a
    floor above what a model achieved is an estimate the data contradict.

    Parameters
    ----------
    measured, predicted : ndarray (n,)   the fitted quantity and the model at the points
    pressure_bar : ndarray (n,)          pressure group of every point (the metric's groups)
    sweeps : ndarray (n,) or None        sweep number of every point (None: no floor)
    conditions : mapping, optional       see above
    fnomin : float                       nominal load [N] (load levels of the repeats)
    by_speed : bool                      the fitted model depends on the speed: sweeps at
                                         other speeds are no repeats (False: the MF force
                                         and moment stages but My, whose equations have no
                                         speed, so that what the speed changes in the data
                                         is as far beyond them as noise)
    """
    if sweeps is None or np.size(measured) < 3:
        return Floor(math.nan, "")
    measured = np.asarray(measured, dtype=float)
    r = np.asarray(predicted, dtype=float) - measured
    sweeps = np.asarray(sweeps)
    _, inv = np.unique(np.asarray(pressure_bar, dtype=float), return_inverse=True)
    G = int(inv.max()) + 1
    n = np.bincount(inv, minlength=G).astype(float)
    den = np.bincount(inv, measured * measured, G)
    s2 = _pairs_sigma2(r, sweeps, inv, G)
    neighbour = np.where(np.isfinite(s2) & (den > 0), n * s2 / np.where(den > 0, den, 1.0),
                         np.nan)
    repeat = np.full(G, np.nan)
    if conditions is not None and math.isfinite(fnomin) and fnomin > 0:
        ss, yy = _repeat_ss(measured, sweeps, inv, G, conditions, fnomin, by_speed)
        repeat = np.where(yy > 0, ss / np.where(yy > 0, yy, 1.0), np.nan)
    both = np.fmax(neighbour, repeat)
    if not np.all(np.isfinite(both)):
        return Floor(math.nan, "")
    floor = float(np.mean(100.0 * np.sqrt(both)))
    used = np.isfinite(repeat) & ~(neighbour > repeat)
    source = ("repeated sweeps" if used.all() else
              "neighbouring samples" if not used.any() else
              f"repeated sweeps at {int(used.sum())} of {G} pressures, neighbouring samples "
              "at the others")
    error = float(np.mean(100.0 * np.sqrt(np.bincount(inv, r * r, G) / np.where(den > 0, den,
                                                                                   1.0))))
    if floor > error:
        return Floor(error, f"{source}; capped at the fit's error")
    return Floor(floor, source)


def quality_problems(error_pct: float, by_pressure: Mapping[float, float], floor_pct: float,
                     floor_source: str = "") -> tuple[str, list[str]]:
    """(status, reasons) of a converged fit's error alone: :data:`FAILED` for a gross miss,
    :data:`POOR_FIT` far above its floor or above :data:`MAX_OK_ERROR_PCT`, else :data:`OK`
    (module docstring)."""
    worst_p = max(by_pressure.items(), key=lambda kv: kv[1], default=None)
    if math.isfinite(error_pct) and error_pct >= GROSS_ERROR_PCT:
        return FAILED, [f"the model misses the data: error {error_pct:.3g} % (at or above "
                        f"{GROSS_ERROR_PCT:g} %: more of the measured signal unexplained than "
                        "explained)"]
    if worst_p is not None and math.isfinite(worst_p[1]) and worst_p[1] >= GROSS_ERROR_PCT:
        return FAILED, [f"the model misses the data at {worst_p[0]:g} bar: error "
                        f"{worst_p[1]:.3g} % (at or above {GROSS_ERROR_PCT:g} %)"]
    if not math.isfinite(error_pct):
        return OK, []
    if (math.isfinite(floor_pct) and floor_pct > 0 and error_pct > POOR_FIT_MIN_PCT
            and error_pct > POOR_FIT_RATIO * floor_pct):
        return POOR_FIT, [f"error {error_pct:.3g} % is {error_pct / floor_pct:.3g} times the "
                          f"noise floor {floor_pct:.3g} % ({floor_source or 'noise'}; poor "
                          f"fit above {POOR_FIT_RATIO:g} times): the model misses the data "
                          "systematically"]
    if error_pct > MAX_OK_ERROR_PCT:
        floor = (f" (noise floor {floor_pct:.3g} %, {floor_source})"
                 if math.isfinite(floor_pct) else " (no noise floor: no sweeps)")
        return POOR_FIT, [f"error {error_pct:.3g} % is above {MAX_OK_ERROR_PCT:g} %{floor}"]
    return OK, []


def fit_status(converged: bool, identification: str, quality: str) -> str:
    """The status of a fit from its convergence, its identifiability status and the status of
    its error (:func:`quality_problems`)."""
    if not converged:
        return FAILED
    return worst((quality, POORLY_IDENTIFIED if identification != OK else OK))
