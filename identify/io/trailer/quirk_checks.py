"""The checks of identify.io.trailer.quirks, one function per kind of quirk (thresholds in SI)."""
from __future__ import annotations

import numpy as np
import pandas as pd
from scipy.ndimage import median_filter

from identify.io.data_warning import DataWarning, WarningReport, per_channel, runs_of

__all__ = ["MIN_RUN_SAMPLES", "MAX_BAD_TIME", "MAX_DROPOUT", "MAX_SPIKE", "MOVING_SPEED",
           "RADIUS_RANGE",
           "SPIKE_RANGE", "SPIKE_SIGMAS", "TEMPERATURE_RANGE", "dropouts", "implausible",
           "nan_values", "spikes", "time_order", "unused_slip_warning"]

#: Fraction of out-of-order time stamps above which the time channel is an error.
MAX_BAD_TIME = 0.01
#: Longest run of exact zeros [samples] counted as a dropout (longer: a real zero or a pause).
MAX_DROPOUT = 50
#: Longest run of outliers [samples] counted as an isolated spike.
MAX_SPIKE = 3
#: Outlier threshold of the spike filter [robust sigmas of the residual].
SPIKE_SIGMAS = 10.0
#: Outlier threshold of the spike filter as a fraction of the channel's 0.5-99.5 % range.
SPIKE_RANGE = 0.05
#: A plausible tyre radius [m] (loaded, effective, or V/omega).
RADIUS_RANGE = (0.1, 1.5)
#: A plausible tyre or road temperature [K].
TEMPERATURE_RANGE = (203.15, 453.15)
#: V [m/s] above which V/omega is compared with a tyre radius.
MOVING_SPEED = 3.0

#: Fewest usable samples of a run not reported as too few [samples]: below it a run holds
#: no sweep worth the name (a stage pools the runs, and needs 50 points in all:
#: identify.fit.coverage.MIN_POINTS), so that a fit finding nothing is not a surprise.
MIN_RUN_SAMPLES = 10

#: Columns whose missing value drops the row (when the channel is present and not dropped).
_TEMPERATURES = ("T_tread_in", "T_tread_centre", "T_tread_out", "T_road", "T_ambient")


def time_order(frame: pd.DataFrame, report: WarningReport, errors: list) -> pd.DataFrame:
    t = frame["t"].to_numpy(float)
    finite = np.isfinite(t)
    if not finite.all():
        report.add("nan", ["t"], int((~finite).sum()), "time stamp NaN/inf",
                   "samples dropped", int(np.flatnonzero(~finite)[0]))
        frame, t = frame[finite], t[finite]
    if t.size == 0:
        errors.append(("t", "no finite time stamp", None))
        return frame
    top = np.maximum.accumulate(t)  # the latest time stamp so far; before[i] = top[i - 1]
    bad = np.zeros(t.size, dtype=bool)
    np.less_equal(t[1:], top[:-1], out=bad[1:])
    if bad.any():
        before = np.concatenate(([-np.inf], top[:-1]))
        i = int(np.flatnonzero(bad)[0])
        n = int(bad.sum())
        if n > MAX_BAD_TIME * t.size:
            row = int(frame.index[i])
            at = "" if report.first_line is not None else f" at sample {row}"
            errors.append(("t", (f"time is not increasing{at}: {float(t[i])!r} after "
                                f"{float(before[i])!r} ({n} such sample(s))"), row))
            return frame
        repeated = int((t[bad] == before[bad]).sum())
        report.add("time-order", ["t"], n, f"{repeated} repeated and {n - repeated} earlier "
                   f"time stamp(s), first at sample {int(frame.index[i])}: {float(t[i])!r} "
                   f"after {float(before[i])!r}", "samples dropped", int(frame.index[i]))
        frame, t = frame[~bad], t[~bad]
    del top
    if t.size > 2:
        # the median partitions a diff of its own (freed before the one in order is made)
        step = float(np.median(np.diff(t), overwrite_input=True))
        dt = np.diff(t)
        gaps = dt > 1.5 * step
        index = frame.index
        if not (isinstance(index, pd.RangeIndex) and index.step == 1):
            # a step over a dropped time stamp is that sample's, not a gap in the logging
            gaps &= np.diff(index.to_numpy()) == 1
        if gaps.any():
            missing = float(np.sum(dt[gaps]) - step * gaps.sum())
            report.add("time-gap", ["t"], int(gaps.sum()),
                       f"{int(gaps.sum())} gap(s) in time, {missing:.3g} s missing in all "
                       f"(sample interval {step:.3g} s)", "kept",
                       int(frame.index[np.flatnonzero(gaps)[0] + 1]))
    return frame


def nan_values(frame: pd.DataFrame, cols: list[str], report: WarningReport, errors: list) -> None:
    counts, first, rows = {}, None, np.zeros(len(frame), dtype=bool)
    for c in cols:
        bad = ~np.isfinite(frame[c].to_numpy(float))
        if bad.all() and len(frame):
            errors.append((c, f"no finite value (all {bad.size} samples are NaN/inf)", None))
        elif bad.any():
            counts[c] = int(bad.sum())
            i = int(np.flatnonzero(bad)[0])
            first = i if first is None else min(first, i)
            rows |= bad
    if counts:
        starts, _ = runs_of(rows)
        report.add("nan", list(counts), int(rows.sum()),
                   f"NaN/inf values in {starts.size} stretch(es): {per_channel(report, counts)}",
                   "set NaN", first)


def _radius_why(values: np.ndarray, what: str) -> str | None:
    med = float(np.median(values)) if values.size else np.nan
    lo, hi = RADIUS_RANGE
    if values.size and not lo <= med <= hi:
        return f"{what}: median {med:.4g} m is not a tyre radius ({lo:g}-{hi:g} m)"
    return None


def implausible(frame: pd.DataFrame, report: WarningReport) -> list[str]:
    """Channels present but not physical; reported and returned (the caller drops them)."""
    dropped = []
    n = len(frame)

    def drop(col: str, why: str, count: int) -> None:
        report.add("implausible", [col], count, why, "channel dropped")
        dropped.append(col)

    if "omega" in frame and frame["omega"].notna().any():
        vx, omega = frame["Vx"].to_numpy(float), frame["omega"].to_numpy(float)
        moving = np.isfinite(vx) & np.isfinite(omega) & (vx > MOVING_SPEED)
        if moving.sum() >= 10:
            with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
                r = np.abs(vx[moving] / omega[moving])  # inf: not a radius, said below
            why = _radius_why(r, "wheel speed inconsistent with the road speed, V/omega")
            if why:
                drop("omega", why, int(moving.sum()))
    for col, what in (("rl", "loaded radius"), ("re", "effective rolling radius")):
        if col in frame:
            v = frame[col].to_numpy(float)
            v = v[np.isfinite(v)]
            why = _radius_why(v, what)
            if why:
                drop(col, why, v.size)
    if "kappa" in frame:
        k = frame["kappa"].to_numpy(float)
        pinned = np.abs(k) >= 0.999
        if pinned.sum() > 0.5 * n:
            drop("kappa", f"slip ratio pinned at {np.median(k[pinned]):+.3g}", int(pinned.sum()))
    lo, hi = TEMPERATURE_RANGE
    for col in _TEMPERATURES:
        if col in frame:
            v = frame[col].to_numpy(float)
            v = v[np.isfinite(v)]
            if v.size and not lo <= np.median(v) <= hi:
                drop(col, f"temperature median {np.median(v) - 273.15:.4g} degC is not "
                          "plausible", v.size)
    return dropped


def dropouts(frame: pd.DataFrame, cols: list[str], report: WarningReport) -> None:
    counts, events, first = {}, 0, None
    for c in cols:
        x = frame[c].to_numpy(float)
        starts, stops = runs_of(x == 0.0)
        ok = (starts > 0) & (stops < x.size) & (stops - starts <= MAX_DROPOUT)
        starts, stops = starts[ok], stops[ok]
        if starts.size == 0:
            continue
        finite = np.abs(x[np.isfinite(x)])
        scale = max(10.0 * _noise_scale(x), 0.05 * float(np.percentile(finite, 99.5)))
        # both neighbours far from 0 on the same side (a zero crossing is not a dropout)
        far = (np.abs(x[starts - 1]) > scale) & (np.abs(x[stops]) > scale) & (
            np.sign(x[starts - 1]) == np.sign(x[stops]))
        starts, stops = starts[far], stops[far]
        if starts.size == 0:
            continue
        mask = np.zeros(x.size, dtype=bool)
        for a, b in zip(starts, stops):  # a handful of events, not a loop over samples
            mask[a:b] = True
        frame[c] = np.where(mask, np.nan, x)  # a new array: the caller's is not written
        counts[c] = int(mask.sum())
        events = max(events, int(starts.size))
        first = int(starts[0]) if first is None else min(first, int(starts[0]))
    if counts:
        report.add("dropout", list(counts), max(counts.values()),
                   f"{events} dropout(s) to exactly 0 between non-zero neighbours: "
                   f"{per_channel(report, counts)} samples", "set NaN", first)


def _noise_scale(x: np.ndarray) -> float:
    """Robust sigma of the residual from a 7-sample running median (finite samples)."""
    v = x[np.isfinite(x)]
    if v.size < 8:
        return 0.0
    return 1.4826 * float(np.median(np.abs(v - median_filter(v, size=7, mode="nearest"))))


def _curvature_scale(v: np.ndarray) -> float:
    """Robust sigma of the second difference: noise in dense data, the curve's own bending in
    sparse smooth data (so that a sparsely sampled peak is not taken for a spike)."""
    if v.size < 3:
        return 0.0
    d2 = np.add(v[:-2], v[2:])  # v[1:-1] - 0.5 (v[:-2] + v[2:]), in one array
    d2 *= 0.5
    np.abs(np.subtract(v[1:-1], d2, out=d2), out=d2)
    return 1.4826 * float(np.median(d2, overwrite_input=True))  # d2 is ours: no copy


def _outliers(v: np.ndarray) -> np.ndarray | None:
    """Samples of ``v`` (finite) further from the 7-sample running median than
    max(:data:`SPIKE_SIGMAS` robust sigmas, :data:`SPIKE_RANGE` of the 0.5-99.5 % range), or
    None when there are none.

    The threshold is a maximum, so each term is computed only while the largest residual
    still exceeds what is known of it (the same result; a clean 5e6-sample channel needs one
    median filter and one median instead of three medians and two percentiles).
    """
    if v.min() == v.max():
        return None  # constant: its running median is itself
    resid = median_filter(v, size=7, mode="nearest")
    np.abs(np.subtract(v, resid, out=resid), out=resid)  # in place: one array of transient
    largest = float(resid.max())
    sigma = 1.4826 * float(np.median(resid))
    if largest <= SPIKE_SIGMAS * sigma:
        return None
    sigma = max(sigma, _curvature_scale(v))
    if largest <= SPIKE_SIGMAS * sigma:
        return None
    lo, hi = np.percentile(v, [0.5, 99.5])
    out = resid > max(SPIKE_SIGMAS * sigma, SPIKE_RANGE * (hi - lo))
    return out if out.any() else None


def spikes(frame: pd.DataFrame, cols: list[str], report: WarningReport) -> None:
    counts, first = {}, None
    for c in cols:
        x = frame[c].to_numpy(float)
        finite = np.isfinite(x)
        whole = bool(finite.all())
        if (x.size if whole else np.count_nonzero(finite)) < 20:
            continue
        out = _outliers(x if whole else x[finite])
        if out is None:
            continue
        idx = np.arange(x.size) if whole else np.flatnonzero(finite)
        starts, stops = runs_of(out)
        short = stops - starts <= MAX_SPIKE
        mask = np.zeros(out.size, dtype=bool)
        for a, b in zip(starts[short], stops[short]):  # a handful of events
            mask[a:b] = True
        if mask.any():
            x = x.copy()  # a new array: the caller's is not written
            x[idx[mask]] = np.nan
            frame[c] = x
            counts[c] = int(mask.sum())
            i = int(idx[mask][0])
            first = i if first is None else min(first, i)
    if counts:
        report.add("spike", list(counts), sum(counts.values()),
                   f"isolated spike(s) (Hampel filter, 7 samples, {SPIKE_SIGMAS:g} sigma): "
                   f"{per_channel(report, counts)} samples", "set NaN", first)


def unused_slip_warning(values: np.ndarray, *, file: str, run: str, channel: str,
                        first_line: int | None = None) -> DataWarning | None:
    """A warning when a slip-ratio channel the loader does not use (a TTC file's SR, based on
    the loaded radius) is pinned at +-1 in more than half of its samples, else None."""
    x = np.asarray(values, dtype=float)
    pinned = np.abs(x) >= 0.999
    if pinned.sum() <= 0.5 * x.size:
        return None
    return DataWarning(file, run, "implausible", (channel,), int(pinned.sum()), x.size,
                       f"slip ratio pinned at {np.median(x[pinned]):+.3g} (not used: kappa "
                       "comes from SL)", "channel dropped")
