"""The named filters applied to the samples of the sweep segments, each counting what it removes.

In the order applied:

``revolution average``
    Every channel is averaged over one revolution of the wheel, twiced: with M the mean over
    the wheel angle theta +- pi about each sample (the angle is the integral of the measured
    wheel speed over time, or of V / R without it, R the effective or loaded radius), the
    filter is 2 M - M M. The ripple of an eccentric wheel or a non-uniform tyre is periodic in
    the wheel's angle, not in time: M removes it from load and forces alike (each point stays
    a consistent operating point) at any wheel speed, including on a slip-ratio sweep, where
    the wheel speed moves with the slip ratio (+-15 % at kappa +-0.15), and across speed
    steps. M alone also bends the characteristic: along a sweep it is off by the window's
    second moment times the curvature, T^2/24 f'' (T one revolution), which on a drive/brake
    sweep of 0.125/s at 40 km/h (0.02 of slip ratio a revolution) put the slip stiffness PKX1
    1.85 % low in every seed of bench/ttc_truth.py. The twiced filter has no second moment
    (2 T^2/12 - 2 T^2/12), so it reproduces every cubic exactly and leaves a curved
    characteristic in place. The samples at both ends of a segment where the double window
    does not fit (one revolution each) are removed, and so are those on both sides of a gap in
    the log longer than half a revolution (rows the loader dropped: a time gap, a NaN
    stretch): each side of it is trimmed as a segment's end is.
``set slip angle``
    Samples of a slip-ratio sweep further than ``set_alpha_deg`` from the segment's set slip
    angle (the ramps between set slip angles inside a quasi-steady stretch) are removed.
``cold tread``
    Samples of a tread colder than the run itself works it at are removed (a cold tread has a
    different friction and stiffness than the warm one the model describes). The run's own
    temperatures decide, not a fixed degree: a tread centre sample is cold where it is both

    - well below the run's working range: under the lower fence Q1 - ``cold_fence`` (Q3 - Q1)
      of the tread centre temperatures of the run's sweep samples (Q1, Q3 their quartiles).
      A sweep heats its own tread: the temperature climbs from the sweep's start at zero slip
      to its end at full slip by tens of kelvin, and the first sweeps after a
      pressure change start a few kelvin cooler than the rest. That is the range the run's
      forces are measured over and the model describes; a sample inside it, or a little
      below, is no colder than the tread the fit is made for (cutting the cool starts of the
      sweeps would remove the small slip angles of the hard sweeps, where the cornering
      stiffness and the pneumatic trail are measured);
    - and less than halfway from the ambient temperature (median of ``T_ambient``) to the
      run's working temperature (the median of the same samples): the tread has not taken
      half of the rise the programme gives it, as on the first sweep after a long pause
      (the tread cooled towards ambient while the pressure was changed) that starts without a
      warm-up. Without an ambient channel the fence alone decides.

    A run whose sweeps all work the tread in one range therefore loses nothing; one that
    starts a sweep on a tread that has cooled to near ambient while the others run warm
    loses that stretch.
``low speed``
    Samples slower than ``min_speed`` are removed.
``binning`` (optional)
    Each sweep is cut into bins of its swept variable (``bin_alpha_deg``, ``bin_kappa``) and
    every channel averaged per bin: one point per bin and sweep, the up- and down-going passes
    of a sweep merged (any hysteresis or relaxation lag is averaged out rather than fitted).
    With ``bin_passes`` one point per bin each time the sweep crosses it: a pass ends where the
    swept variable turns back by ``PASS_TURN`` bins from its extreme (:func:`sweep_passes`).
    Merging passes assumes that the other inputs are the same on both: where a rig's load
    follows the slip direction within a sweep (a "1500 N" slip-angle sweep swinging between
    1240 and 2090 N), a merged bin's mean inputs are an operating point no sample had, and the
    model at the mean inputs differs from the mean of the model over the samples where the
    curve bends (a bias of a few percent of the channel on such a rig, well under a tenth of a
    percent per pass). What binning does to the fit: far fewer points (faster), each the mean
    of many samples (the noise per point shrinks by the square root of the count, so
    residual-based errors keep their meaning only if the fit weights points by their counts);
    and every part of the curve gets the same weight per unit of slip instead of per second of
    dwell.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from identify.segment.result import FilterCount
from identify.segment.settings import SegmentSettings

__all__ = ["PASS_TURN", "binning", "cold_mark", "cold_tread", "low_speed", "revolution_average",
           "set_slip_angle", "sweep_passes"]


def _numeric(frame: pd.DataFrame) -> list[str]:
    """The measured channels (not the labels: run, sweep, segment, the level values)."""
    return [c for c in frame.columns if c not in ("run", "sweep", "segment")
            and not c.endswith("_level") and pd.api.types.is_float_dtype(frame[c])]


def revolution_average(frame: pd.DataFrame,
                       s: SegmentSettings) -> tuple[pd.DataFrame, FilterCount]:
    """Average over one revolution of the wheel within each segment, twiced (see module)."""
    name = "revolution average"
    if not s.revolution_average:
        return frame, FilterCount(name, 0, len(frame), False, "switched off")
    speed, how = _wheel_speed(frame)
    if speed is None:
        return frame, FilterCount(name, 0, len(frame), False,
                                  "no wheel speed or radius to find the wheel's angle")
    cols = _numeric(frame)
    t = frame["t"].to_numpy(float)
    values = frame[cols].to_numpy(float)
    taken, averaged = [], []  # row positions kept and their averaged values, per stretch
    for rows in frame.groupby("segment", sort=False).indices.values():
        theta = _wheel_angle(t[rows], speed[rows])
        if theta is None:
            continue
        ahead = np.concatenate(([True], theta[1:] > np.maximum.accumulate(theta)[:-1]))
        rows, theta = rows[ahead], theta[ahead]  # a repeated time stamp: the sample is dropped
        # a gap in the log (rows the loader dropped: a step over 1.5 of the median sample
        # interval, as identify.io.trailer.quirk_checks.time_order counts one) of over half a
        # revolution: each side is averaged on its own, as a segment (a straight line across
        # it is no measurement; a log of under two samples a revolution has no gap)
        dt = np.diff(t[rows])
        gap = (np.diff(theta) > np.pi) & (dt > 1.5 * np.median(dt))
        cuts = np.flatnonzero(gap) + 1
        for stretch, angle in zip(np.split(rows, cuts), np.split(theta, cuts)):
            if angle[-1] - angle[0] < 4 * np.pi:
                continue
            once, i = _revolution_mean(angle, values[stretch])  # at stretch[i]
            twice, j = _revolution_mean(angle[i], once)  # at stretch[i[j]]
            taken.append(stretch[i[j]])
            averaged.append(2 * once[j] - twice)
    # one copy of the kept rows and one assignment, not one of each per stretch (pandas has
    # an overhead per call; bench/fit_cost.py --ttc 0 times the whole table)
    result = frame.iloc[np.concatenate(taken) if taken else []].copy()
    if taken:
        result[cols] = np.concatenate(averaged)
    return result, FilterCount(name, len(frame) - len(result), len(result), True,
                               f"one revolution of the wheel's angle, twiced ({how})")


def _wheel_speed(frame: pd.DataFrame) -> tuple[np.ndarray | None, str]:
    """The wheel speed of every sample [rad/s]: the measured one where it is finite and
    positive, else the speed over the effective (or loaded) radius; None without either."""
    omega = frame["omega"].to_numpy(float) if "omega" in frame else np.full(len(frame), np.nan)
    radius = next((float(frame[c].median()) for c in ("re", "rl")
                   if c in frame and frame[c].notna().any()), np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        fallback = frame["Vx"].to_numpy(float) / radius
    measured = np.isfinite(omega) & (omega > 0)
    speed = np.where(measured, omega, fallback)
    if not (np.isfinite(speed) & (speed > 0)).any():
        return None, ""
    share = measured.mean() if len(measured) else 0.0
    other = (f"V / R ({radius:.3f} m)" if np.isfinite(radius)
             else "interpolated in time")  # no radius: _wheel_angle fills the gaps
    how = ("wheel speed" if share == 1 else f"wheel speed, {other} for "
           f"{100 * (1 - share):.0f} % of the samples")
    return speed, how


def _wheel_angle(t: np.ndarray, speed: np.ndarray) -> np.ndarray | None:
    """The wheel's angle [rad] at the samples of one segment (trapezoidal integral of its
    speed over time; samples without a usable speed take the one interpolated in time); None
    when the segment turns less than two revolutions."""
    ok = np.isfinite(speed) & (speed > 0)
    if ok.sum() < 2 or np.ptp(t) <= 0:
        return None
    w = speed if ok.all() else np.interp(t, t[ok], speed[ok])
    theta = np.concatenate(([0.0], np.cumsum(0.5 * (w[1:] + w[:-1]) * np.diff(t))))
    if theta[-1] < 4 * np.pi:
        return None
    return theta


def _revolution_mean(theta: np.ndarray, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The mean of ``x`` (rows: samples at the increasing wheel angles ``theta`` [rad]) over
    the revolution centred on each sample, theta +- pi, with ``x`` linear between samples
    (the integral of each piece exact). Returns the means and the rows they belong to: those
    whose revolution lies within the samples. A ripple that is periodic in the wheel's angle
    averages to zero whatever the wheel speed does, so slip-ratio sweeps (the wheel speed
    moves with the slip ratio) and speed steps need no window of their own.

    A NaN sample (a spike or dropout set NaN by identify.io.trailer.quirks) within half a revolution
    of measured samples on both sides is first filled linearly in the angle (see
    :func:`_fill_short_gaps`). A longer dropout takes the pieces next to it out of that
    column's integral, and the mean is over the rest of the revolution; with less than half a
    revolution left it is NaN. (A plain running sum would carry the NaN to every later sample
    of the segment.)"""
    x = _fill_short_gaps(theta, x)
    d = np.diff(theta)[:, None]
    finite = np.isfinite(x)
    piece = finite[1:] & finite[:-1]  # pieces with both ends measured
    x0 = np.where(finite, x, 0.0)
    slope = np.where(piece, np.diff(x0, axis=0) / d, 0.0)
    zero = np.zeros((1, x.shape[1]))
    area = np.concatenate((zero, np.cumsum(np.where(piece, 0.5 * (x0[1:] + x0[:-1]) * d, 0.0),
                                           axis=0)))
    span = np.concatenate((zero, np.cumsum(np.where(piece, d, 0.0), axis=0)))
    rows = np.flatnonzero((theta - np.pi >= theta[0]) & (theta + np.pi <= theta[-1]))

    def integrals(q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # from theta[0] to q
        k = np.clip(np.searchsorted(theta, q, side="right") - 1, 0, len(d) - 1)
        u = (q - theta[k])[:, None] * piece[k]
        return area[k] + u * x0[k] + 0.5 * u ** 2 * slope[k], span[k] + u

    q = theta[rows]
    (a_hi, s_hi), (a_lo, s_lo) = integrals(q + np.pi), integrals(q - np.pi)
    length = s_hi - s_lo
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(length >= np.pi, (a_hi - a_lo) / length, np.nan), rows


def _fill_short_gaps(theta: np.ndarray, x: np.ndarray) -> np.ndarray:
    """``x`` (rows: samples at the increasing wheel angles ``theta`` [rad]) with every run of
    NaN that has measured samples on both sides at most half a revolution (pi) apart filled
    linearly in the angle. Left out of the revolution's integral instead, a single NaN moves
    the centre of what is averaged by up to half a sample: on the steep part of a fast
    drive/brake sweep (90 N a sample) that put the twiced mean up to 140 N off the curve."""
    finite = np.isfinite(x)
    if finite.all():
        return x
    gappy = ~finite.all(axis=0)
    if not gappy.all():  # only the columns with a NaN (the others are returned as they are)
        out = x.copy()
        out[:, gappy] = _fill_short_gaps(theta, x[:, gappy])
        return out
    n = len(theta)
    index = np.arange(n)[:, None]
    before = np.maximum.accumulate(np.where(finite, index, -1), axis=0)
    after = np.minimum.accumulate(np.where(finite, index, n)[::-1], axis=0)[::-1]
    gap = ~finite & (before >= 0) & (after < n)
    lo, hi = np.where(gap, before, 0), np.where(gap, after, 0)
    span = theta[hi] - theta[lo]
    fill = gap & (span <= np.pi)
    x_lo, x_hi = np.take_along_axis(x, lo, axis=0), np.take_along_axis(x, hi, axis=0)
    w = (theta[:, None] - theta[lo]) / np.where(fill, span, 1.0)
    return np.where(fill, x_lo + w * (x_hi - x_lo), x)


def set_slip_angle(frame: pd.DataFrame, s: SegmentSettings) -> tuple[pd.DataFrame,
                                                                      FilterCount]:
    """Drop samples of slip-ratio sweeps away from their set slip angle."""
    off = (frame["sweep"] == "kappa") & (
        (frame["alpha"] - frame["alpha_level"]).abs() > np.deg2rad(s.set_alpha_deg))
    out = frame[~off]
    return out, FilterCount("set slip angle", int(off.sum()), len(out), True,
                            f"slip-ratio sweeps within {s.set_alpha_deg:g} deg of the set "
                            "slip angle")


def cold_mark(frame: pd.DataFrame, s: SegmentSettings) -> pd.Series:
    """The tread centre temperature below which a sample is cold [K], per run (see module):
    the lower of the fence Q1 - ``cold_fence`` (Q3 - Q1) of the run's ``T_tread_centre``
    and, with ``T_ambient``, halfway from the run's ambient (its median) to its working
    temperature (the median of ``T_tread_centre``); NaN for a run without a tread
    temperature."""
    tread = frame.groupby("run", sort=False)["T_tread_centre"]
    q1, q3 = tread.quantile(0.25), tread.quantile(0.75)
    fence = q1 - s.cold_fence * (q3 - q1)
    if "T_ambient" not in frame:
        return fence
    ambient = frame.groupby("run", sort=False)["T_ambient"].median()
    halfway = ambient + 0.5 * (tread.median() - ambient)
    return np.fmin(fence, halfway)  # the fence alone where the ambient is unknown


def cold_tread(frame: pd.DataFrame, s: SegmentSettings) -> tuple[pd.DataFrame, FilterCount]:
    """Drop samples of a tread colder than its run works it at (see module)."""
    name = "cold tread"
    if "T_tread_centre" not in frame or frame["T_tread_centre"].isna().all():
        return frame, FilterCount(name, 0, len(frame), False, "no tread temperature channel")
    mark = cold_mark(frame, s)
    cold = frame["T_tread_centre"] < frame["run"].map(mark).to_numpy(float)  # NaN is kept
    out = frame[~cold]
    marks = "/".join(f"{v - 273.15:.0f}" for v in mark.dropna())
    return out, FilterCount(name, int(cold.sum()), len(out), True,
                            f"tread centre below {marks or '-'} degC per run (below the run's "
                            f"working range, Q1 - {s.cold_fence:g} IQR of its sweeps, and "
                            "less than halfway from ambient to its median)")


def low_speed(frame: pd.DataFrame, s: SegmentSettings) -> tuple[pd.DataFrame, FilterCount]:
    """Drop samples slower than ``min_speed``."""
    slow = frame["Vx"] < s.min_speed
    out = frame[~slow]
    return out, FilterCount("low speed", int(slow.sum()), len(out), True,
                            f"below {s.min_speed:g} m/s")


PASS_TURN = 2
"""[bins] A sweep's pass ends where its swept variable has come back this many bins from the
pass's extreme (one bin of jitter at a bin edge does not start a pass)."""


def sweep_passes(bins: np.ndarray, turn: int = PASS_TURN) -> np.ndarray:
    """Pass number (0, 1, ...) of every sample of one sweep, from its bin indices in time order.

    A pass runs in one direction; it ends at its extreme bin once a later sample lies ``turn``
    bins or more back from it, and the samples after the extreme start the next pass (in the
    other direction). A sweep that only jitters within ``turn`` bins is one pass.

    Parameters
    ----------
    bins : ndarray of int-valued float
        Bin index of every sample, in time order (finite).
    turn : int [bins]
    """
    bins = np.asarray(bins, float)
    if bins.size == 0:
        return np.zeros(0, int)
    change = np.r_[True, bins[1:] != bins[:-1]]
    runs = bins[change]  # the bin of every run of equal indices
    pid = np.zeros(runs.size, int)
    p, ext, ext_j, d = 0, runs[0], 0, 0  # pass, its extreme and where, direction (0: open)
    for j in range(1, runs.size):
        x = runs[j]
        if (d >= 0 and x > ext) or (d <= 0 and x < ext):  # further on: a new extreme
            if d == 0:
                d = 1 if x > ext else -1
            ext, ext_j = x, j
        elif d != 0 and abs(x - ext) >= turn:  # turned back: a new pass after the extreme
            p += 1
            d = -d
            pid[ext_j + 1:j] = p
            ext, ext_j = x, j
        pid[j] = p
    return pid[np.cumsum(change) - 1]


def binning(frame: pd.DataFrame, s: SegmentSettings) -> tuple[pd.DataFrame, FilterCount]:
    """Average each sweep per bin of its swept variable, and per pass with ``bin_passes``
    (optional; see module)."""
    name = "binning"
    widths = {"alpha": None if s.bin_alpha_deg is None else np.deg2rad(s.bin_alpha_deg),
              "kappa": s.bin_kappa}
    if all(w is None for w in widths.values()):
        return frame, FilterCount(name, 0, len(frame), False, "not requested")
    if s.bin_passes:  # passes in time order
        frame = frame.sort_values(["segment", "t"], kind="stable")
    bins = np.full(len(frame), np.nan)
    for var, width in widths.items():
        if width is not None:
            rows = (frame["sweep"] == var).to_numpy()
            bins[rows] = np.floor(frame[var].to_numpy(float)[rows] / width)
    passes = np.zeros(len(frame))
    for idx in (frame.groupby("segment", sort=False).indices.values() if s.bin_passes else ()):
        idx = idx[np.isfinite(bins[idx])]
        if idx.size:
            passes[idx] = sweep_passes(bins[idx])
    frame = frame.assign(_bin=bins, _pass=passes)
    unbinned = frame[frame["_bin"].isna()].drop(columns=["_bin", "_pass"])
    binned = frame[frame["_bin"].notna()]
    cols = _numeric(unbinned)
    first = [c for c in unbinned.columns if c not in cols and c != "segment"]
    grouped = binned.groupby(["segment", "_pass", "_bin"], sort=True)
    means = grouped[cols].mean()
    means[first] = grouped[first].first()
    means = means.reset_index().drop(columns=["_bin", "_pass"])
    out = pd.concat([unbinned, means[unbinned.columns]], ignore_index=True)
    out = out.sort_values(["segment", "t"], kind="stable", ignore_index=True)
    note = ", ".join(f"{v} {w:g}" for v, w in (("alpha [deg]", s.bin_alpha_deg),
                                                 ("kappa", s.bin_kappa)) if w is not None)
    return out, FilterCount(name, len(frame) - len(out), len(out), True,
                            f"bins of {note}" + (" per pass" if s.bin_passes else ""))
