"""The named filters applied to the samples of the sweep segments, each counting what it removes.

In the order applied:

``revolution average``
    Every channel is averaged over one wheel revolution, twiced: with M the centred moving
    average over n = 2 pi / (omega dt) samples (omega the median wheel speed, or V / R without
    a wheel speed channel, R the effective or loaded radius; within each segment; n need not be
    whole), the filter is 2 M - M M. Both M and M M have zeros at the wheel frequency and its
    harmonics, so the once-per-revolution ripple of an eccentric wheel or a non-uniform tyre
    goes from load and forces alike (each point stays a consistent operating point). M alone
    also bends the characteristic: along a sweep it is off by the window's second moment times
    the curvature, T^2/24 f'' (T one revolution), which on a drive/brake sweep of 0.125/s at
    40 km/h (0.02 of slip ratio a revolution) put the slip stiffness PKX1 1.85 % low in every
    seed of bench/ttc_truth.py. The twiced filter has no second moment (2 T^2/12 - 2 T^2/12),
    so it reproduces every cubic exactly and leaves a curved characteristic in place. The
    samples at both ends of a segment where the double window does not fit (about one
    revolution each) are removed.
``set slip angle``
    Samples of a slip-ratio sweep further than ``set_alpha_deg`` from the segment's set slip
    angle (the ramps between set slip angles inside a quasi-steady stretch) are removed.
``cold tread``
    Samples whose tread centre temperature is below ``cold_below_K`` are removed (a cold tread
    has a different friction and stiffness than the warm one the model describes).
``low speed``
    Samples slower than ``min_speed`` are removed.
``binning`` (optional)
    Each sweep is cut into bins of its swept variable (``bin_alpha_deg``, ``bin_kappa``) and
    every channel averaged per bin: one point per bin and sweep. What it does to the fit: far
    fewer points (faster), each the mean of many samples (the noise per point shrinks by the
    square root of the count, so residual-based errors keep their meaning only if the fit
    weights points by their counts); the up- and down-going halves of a sweep are merged (any
    hysteresis or relaxation lag is averaged out rather than fitted); and every part of the
    curve gets the same weight per unit of slip instead of per second of dwell.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from identify.segment.result import FilterCount
from identify.segment.settings import SegmentSettings

__all__ = ["binning", "cold_tread", "low_speed", "revolution_average", "set_slip_angle"]


def _numeric(frame: pd.DataFrame) -> list[str]:
    """The measured channels (not the labels: run, sweep, segment, the level values)."""
    return [c for c in frame.columns if c not in ("run", "sweep", "segment")
            and not c.endswith("_level") and pd.api.types.is_float_dtype(frame[c])]


def revolution_average(frame: pd.DataFrame, s: SegmentSettings,
                       dt: float) -> tuple[pd.DataFrame, FilterCount]:
    """Moving average over one wheel revolution within each segment (see module)."""
    name = "revolution average"
    if not s.revolution_average:
        return frame, FilterCount(name, 0, len(frame), False, "switched off")
    omega = float(frame["omega"].median()) if frame["omega"].notna().any() else np.nan
    how = f"wheel speed {omega:.4g} rad/s"
    if not omega > 0:  # no wheel speed: the speed over a radius
        radius = next((float(frame[c].median()) for c in ("re", "rl")
                       if c in frame and frame[c].notna().any()), np.nan)
        omega = float(frame["Vx"].median()) / radius if len(frame) else np.nan
        how = f"V / R, R {radius:.3f} m"
    n = 2 * np.pi / (omega * dt) if omega > 0 else 0.0  # samples a revolution
    if not n >= 3:
        return frame, FilterCount(name, 0, len(frame), False,
                                  "no wheel speed or radius to size the window")
    h = _half_width(n)
    cols = _numeric(frame)
    parts = []
    for _, seg in frame.groupby("segment", sort=False):  # one array operation per segment
        if len(seg) <= 4 * h:
            continue
        once = _revolution_mean(seg[cols].to_numpy(float), n)  # centred on h .. len - h - 1
        twice = _revolution_mean(once, n)  # on 2h .. len - 2h - 1
        out = seg.iloc[2 * h:len(seg) - 2 * h].copy()
        out[cols] = 2 * once[h:len(once) - h] - twice
        parts.append(out)
    result = pd.concat(parts) if parts else frame.iloc[:0]
    return result, FilterCount(name, len(frame) - len(result), len(result), True,
                               f"{n:.1f} samples per revolution, twiced ({how})")


def _half_width(n: float) -> int:
    """Samples either side of the centre that a window of ``n`` samples touches."""
    return int((n - 1) // 2) + 1


def _revolution_mean(x: np.ndarray, n: float) -> np.ndarray:
    """The centred mean of ``x`` (rows: samples) over a window of ``n`` samples, ``n`` not
    necessarily whole: the 2m + 1 samples about the centre weigh 1, the next one on each side
    the rest, (n - 2m - 1) / 2 (18 samples: 17 full and two halves, the centred 2 x 18 average,
    which has its zeros at a period of 18 samples and its harmonics; rounding the window to 19
    samples would leave 5 % of such a ripple). Rows ``h .. len - h - 1`` (h =
    :func:`_half_width`), where the window fits."""
    m = int((n - 1) // 2)
    h = m + 1
    rest = (n - 2 * m - 1) / 2
    c = np.cumsum(np.vstack((np.zeros((1, x.shape[1])), x)), axis=0)
    i = np.arange(h, len(x) - h)
    return (c[i + m + 1] - c[i - m] + rest * (x[i - h] + x[i + h])) / n


def set_slip_angle(frame: pd.DataFrame, s: SegmentSettings) -> tuple[pd.DataFrame,
                                                                      FilterCount]:
    """Drop samples of slip-ratio sweeps away from their set slip angle."""
    off = (frame["sweep"] == "kappa") & (
        (frame["alpha"] - frame["alpha_level"]).abs() > np.deg2rad(s.set_alpha_deg))
    out = frame[~off]
    return out, FilterCount("set slip angle", int(off.sum()), len(out), True,
                            f"slip-ratio sweeps within {s.set_alpha_deg:g} deg of the set "
                            "slip angle")


def cold_tread(frame: pd.DataFrame, s: SegmentSettings) -> tuple[pd.DataFrame, FilterCount]:
    """Drop samples whose tread centre temperature is below ``cold_below_K``."""
    name = "cold tread"
    if "T_tread_centre" not in frame or frame["T_tread_centre"].isna().all():
        return frame, FilterCount(name, 0, len(frame), False, "no tread temperature channel")
    cold = frame["T_tread_centre"] < s.cold_below_K  # NaN (unknown) is kept
    out = frame[~cold]
    return out, FilterCount(name, int(cold.sum()), len(out), True,
                            f"tread centre below {s.cold_below_K - 273.15:g} degC")


def low_speed(frame: pd.DataFrame, s: SegmentSettings) -> tuple[pd.DataFrame, FilterCount]:
    """Drop samples slower than ``min_speed``."""
    slow = frame["Vx"] < s.min_speed
    out = frame[~slow]
    return out, FilterCount("low speed", int(slow.sum()), len(out), True,
                            f"below {s.min_speed:g} m/s")


def binning(frame: pd.DataFrame, s: SegmentSettings) -> tuple[pd.DataFrame, FilterCount]:
    """Average each sweep per bin of its swept variable (optional; see module)."""
    name = "binning"
    widths = {"alpha": None if s.bin_alpha_deg is None else np.deg2rad(s.bin_alpha_deg),
              "kappa": s.bin_kappa}
    if all(w is None for w in widths.values()):
        return frame, FilterCount(name, 0, len(frame), False, "not requested")
    bins = np.full(len(frame), np.nan)
    for var, width in widths.items():
        if width is not None:
            rows = (frame["sweep"] == var).to_numpy()
            bins[rows] = np.floor(frame[var].to_numpy(float)[rows] / width)
    frame = frame.assign(_bin=bins)
    unbinned = frame[frame["_bin"].isna()].drop(columns="_bin")
    binned = frame[frame["_bin"].notna()]
    cols = _numeric(unbinned)
    first = [c for c in unbinned.columns if c not in cols and c != "segment"]
    grouped = binned.groupby(["segment", "_bin"], sort=True)
    means = grouped[cols].mean()
    means[first] = grouped[first].first()
    means = means.reset_index().drop(columns="_bin")
    out = pd.concat([unbinned, means[unbinned.columns]], ignore_index=True)
    out = out.sort_values(["segment", "t"], kind="stable", ignore_index=True)
    note = ", ".join(f"{v} {w:g}" for v, w in (("alpha [deg]", s.bin_alpha_deg),
                                                 ("kappa", s.bin_kappa)) if w is not None)
    return out, FilterCount(name, len(frame) - len(out), len(out), True, f"bins of {note}")
