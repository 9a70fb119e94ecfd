"""Flag thresholds and the checks shared by the test types.

Flags (:data:`~identify.extract.diagnostics.FLAG_NAMES`): stick-slip in a stiffness or parking
run; a rolling run too short for steady state; camber asymmetry between +gamma and -gamma; a
spread between start positions; a run whose load, camber, slip angle or pressure differs from
its declared condition.
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2
from scipy.stats import f as f_dist

from identify.core.serial import Serial
from identify.extract.diagnostics import Flag, row
from identify.extract.runs import RunData, cell_label

__all__ = ["Thresholds", "stick_slip_score", "condition_flags", "spread_flag", "cell_means"]


@dataclass(frozen=True)
class Thresholds(Serial):
    """Settings of the extraction and its flags.

    Attributes
    ----------
    asymmetry : float
        Relative difference of |Fy_gamma| between -gamma and +gamma that is flagged [-]. A
        symmetric tyre shows ~3 % from ply-steer and conicity, so the default sits above it.
    spread : float
        Relative range of a characteristic over the start positions that is flagged [-] (only
        when the per-run standard errors cannot explain it, :func:`spread_flag`).
    load : float
        Relative distance between the measured and the declared load that is flagged [-].
    angle_deg : float
        Distance between the measured and the declared camber or slip angle flagged [deg].
    short_run : float
        Rolled distance in relaxation lengths below which a rolling run has not reached
        steady state [-] (3 lengths = 95 % of the steady force).
    stick_slip_log10p : float
        Significance of the stick-slip oscillation (log10 of the white-noise p-value of the
        strongest periodogram peak, :func:`stick_slip_score`) below which it is flagged [-].
    stick_slip_amplitude : float
        Smallest oscillation amplitude flagged, as a fraction of the saturation force [-].
    band : tuple of float
        Force band, as fractions of the saturation force, in which the linear window of a
        locked-hub run is searched (skips the start-up, stops before saturation) [-].
    parking_band : float
        Torque band around the zero crossing, as a fraction of the saturated half-height, in
        which the linear window of a parking branch is searched [-].
    """

    asymmetry: float = 0.05
    spread: float = 0.05
    load: float = 0.05
    angle_deg: float = 0.25
    short_run: float = 3.0
    stick_slip_log10p: float = -5.0
    stick_slip_amplitude: float = 0.007
    band: tuple[float, float] = (0.10, 0.70)
    parking_band: float = 0.75



def stick_slip_score(x: np.ndarray, y: np.ndarray, scale: float) -> tuple[float, float]:
    """Evidence of a periodic stick-slip oscillation on a saturated stretch of a run.

    The stretch is detrended with a degree-7 Chebyshev series in ``x`` (which follows the
    approach to saturation but not an oscillation of several cycles). In the periodogram of the
    residual (periods of 2 to m/5 samples), the strongest pair of neighbouring ordinates (a
    period between two Fourier frequencies splits its power over both) is compared with the
    mean of the others: under white noise their ratio is F(4, 2(K-2)) distributed, and the
    p-value is Bonferroni-corrected for the K pairs searched.

    Parameters
    ----------
    x, y : numpy.ndarray
        Abscissa (travel) and saturated force or torque.
    scale : float
        Saturation level used to express the amplitude [unit of y].

    Returns
    -------
    (float, float)
        log10 of the p-value [-] (0 when the stretch is too short) and the amplitude of the
        strongest periodic component as a fraction of ``scale`` [-].
    """
    m = y.size
    if m < 24 or scale <= 0 or np.ptp(x) <= 0:
        return 0.0, 0.0
    t = 2.0 * (x - x.min()) / np.ptp(x) - 1.0
    cheb = np.polynomial.chebyshev
    resid = y - cheb.chebval(t, cheb.chebfit(t, y, 7))
    power = (np.abs(np.fft.rfft(resid)) ** 2)[5:m // 2]
    if power.size < 6:
        return 0.0, 0.0
    pair = power[:-1] + power[1:]
    j = int(np.argmax(pair))
    rest = (power.sum() - pair[j]) / (power.size - 2)
    if rest <= 0:
        return 0.0, 0.0
    log_sf = f_dist.logsf(0.5 * pair[j] / rest, 4, 2 * (power.size - 2))
    log10p = min(0.0, (math.log(pair.size) + float(log_sf)) / math.log(10))
    return float(log10p), float(2.0 * np.sqrt(pair[j]) / m / scale)


def condition_flags(run: RunData, th: Thresholds, *, measured_load: float | None = None
                    ) -> list[Flag]:
    """Flags for a run whose load, camber, slip angle or pressure differs from its declaration.

    ``measured_load`` [N] overrides the median contact Fz (the vertical test is declared by its
    turn-back load).
    """
    flags = []
    declared = run.declared
    if "load_N" in declared and float(declared["load_N"]) > 0:
        want = float(declared["load_N"])
        got = float(np.median(run.ch["Fz"])) if measured_load is None else measured_load
        if abs(got - want) > th.load * want:
            flags.append(Flag(run.run, run.test, "condition",
                              f"measured load {got:.0f} N differs from the declared {want:.0f} N "
                              f"by {100 * (got / want - 1):+.1f} %"))
    for key, channel, what in (("gamma_deg", "gamma", "camber"),
                               ("slip_angle_deg", "alpha", "slip angle")):
        if key in declared and run.test != "parking":
            got = float(np.rad2deg(np.median(run.ch[channel])))
            if abs(got - float(declared[key])) > th.angle_deg:
                flags.append(Flag(run.run, run.test, "condition",
                                  f"measured {what} {got:.2f} deg differs from the declared "
                                  f"{float(declared[key]):.2f} deg"))
    if run.pressure_source == "name":
        flags.append(Flag(run.run, run.test, "condition",
                          f"no declared pressure: {run.p_bar:g} bar taken from the run name"))
    return flags


def spread_flag(label: str, test: str, quantity: str, values: Sequence[float],
                errors: Sequence[float], th: Thresholds) -> Flag | None:
    """A flag when the per-start values of a cell differ by more than ``th.spread`` (range
    relative to the mean) and by more than their standard errors explain: the chi-square of
    the values about their weighted mean beyond its 1 - 1e-6 point (hundreds of cells are
    checked per folder; skipped when no error is known)."""
    v = np.asarray(values, float)
    e = np.asarray(errors, float)
    ok = np.isfinite(v)
    if ok.sum() < 2:
        return None
    v, e = v[ok], e[ok]
    mean = abs(float(v.mean()))
    spread = float(v.max() - v.min())
    if not (mean > 0 and spread > th.spread * mean):
        return None
    if np.all(np.isfinite(e) & (e > 0)):
        w = 1.0 / e ** 2
        centre = float((w * v).sum() / w.sum())
        if float((w * (v - centre) ** 2).sum()) <= chi2.isf(1e-6, v.size - 1):
            return None
    return Flag(label, test, "spread",
                f"{quantity} differs by {100 * spread / mean:.1f} % between start positions "
                f"(threshold {100 * th.spread:.0f} %)")


def cell_means(test: str, quantity: str,
               cells: Mapping[tuple[float, float], Sequence[tuple[float, float]]],
               th: Thresholds) -> tuple[list[dict], list[Flag]]:
    """One characteristic row per pressure x load cell, the mean of its runs' values, and the
    :func:`spread_flag` of every cell whose runs disagree.

    ``cells`` maps (pressure [bar], load [N]) to the (value, standard error) of each run.
    """
    rows, flags = [], []
    for (p, fz), values in sorted(cells.items()):
        vals, errors = zip(*values)
        rows.append(row(quantity, p, fz, float(np.mean(vals))))
        found = spread_flag(cell_label(test, p, fz), test, quantity, vals, errors, th)
        flags += [found] if found else []
    return rows, flags
