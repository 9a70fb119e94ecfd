"""The named filters applied to the samples of the sweep segments, each counting what it removes.

In the order applied:

``revolution average``
    Every channel is averaged over one wheel revolution (a centred moving average of
    2 pi / (omega dt) samples, omega the median wheel speed, or V / R without a wheel speed
    channel, R the effective or loaded radius; within each segment), which
    removes the once-per-revolution ripple of an eccentric wheel or a non-uniform tyre from
    load and forces alike (so each point stays a consistent operating point). Along a sweep it
    is a low-pass over about 1/7 s: in a curved part of the characteristic the average is off
    by the window's second moment times the curvature (window^2/24 f''), well below the noise
    at TTC sweep rates. The half-windows at both ends of a segment are removed.
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
    n = round(2 * np.pi / (omega * dt)) if omega > 0 else 0
    if n < 3:
        return frame, FilterCount(name, 0, len(frame), False,
                                  "no wheel speed or radius to size the window")
    n += 1 - n % 2
    h = n // 2
    cols = _numeric(frame)
    parts = []
    for _, seg in frame.groupby("segment", sort=False):  # one array operation per segment
        if len(seg) <= n:
            continue
        x = seg[cols].to_numpy(float)
        c = np.cumsum(np.vstack((np.zeros((1, x.shape[1])), x)), axis=0)
        avg = (c[n:] - c[:-n]) / n
        out = seg.iloc[h:len(seg) - h].copy()
        out[cols] = avg
        parts.append(out)
    result = pd.concat(parts) if parts else frame.iloc[:0]
    return result, FilterCount(name, len(frame) - len(result), len(result), True,
                               f"{n} samples per revolution ({how})")


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
