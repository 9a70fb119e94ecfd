"""Real-data quirks of trailer runs: found, cleaned and reported as warnings with counts.

Real trailer logs (a Tire Test Consortium session, a rig's own logger) are usable but not
clean. Each quirk below is handled, not refused, and reported as one :class:`DataWarning` per
run and kind (with the channels, the number of samples and what was done); only a time channel
that is not a time channel (more than :data:`MAX_BAD_TIME` of its samples out of order), or a
required channel without one finite value, is an error. The checks run on the tidy table, i.e.
after the unit conversion and the axis conversion, so that every threshold is in SI.

=================  =====================================================  ==================
kind               found as                                               action
=================  =====================================================  ==================
``time-order``     a time stamp not above every earlier one (repeated      sample dropped
                   or going back)
``time-gap``       a step longer than 1.5 median sample intervals          kept (reported)
``nan``            NaN/inf values (a logger's dropout stretch)             row dropped
``dropout``        a run of at most :data:`MAX_DROPOUT` samples reading    set NaN, row dropped
                   exactly 0 between neighbours far from 0
``spike``          at most :data:`MAX_SPIKE` samples further than           set NaN, row dropped
                   ``SPIKE_SIGMAS`` robust sigmas (and 5 % of the channel's
                   range) from a 7-sample running median (a Hampel filter)
``implausible``    a channel present but not physical: wheel speed         channel dropped
                   inconsistent with V (V/omega not a tyre radius), a
                   radius that is not a tyre's, a slip ratio pinned at
                   +-1, a temperature outside -70 .. 180 degC
=================  =====================================================  ==================

A dropped channel becomes NaN in the whole run, so that a stage needing it finds no points and
is skipped; :attr:`DataWarning.channels` names it and ``kind == "implausible"`` says why. Rows
are dropped only for a missing value in a required channel (the condition, force and moment
channels); optional channels (radii, temperatures, My) keep their NaN.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pandas as pd
from scipy.ndimage import median_filter

__all__ = [
    "MAX_BAD_TIME",
    "MAX_DROPOUT",
    "MAX_SPIKE",
    "RADIUS_RANGE",
    "REQUIRED_COLUMNS",
    "SPIKE_SIGMAS",
    "CleanResult",
    "DataWarning",
    "clean_run",
    "runs_of",
    "unused_slip_warning",
]

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

#: Columns whose missing value drops the row (when the channel is present and not dropped).
REQUIRED_COLUMNS = ("t", "Vx", "alpha", "kappa", "gamma", "p", "Fx", "Fy", "Fz", "Mx", "Mz")
_DATA = ("Vx", "omega", "alpha", "kappa", "gamma", "p", "Fx", "Fy", "Fz", "Mx", "My", "Mz")
_DROPOUT = ("Vx", "omega", "p", "Fx", "Fy", "Fz", "Mx", "My", "Mz")
_RADII = ("rl", "re")
_TEMPERATURES = ("T_tread_in", "T_tread_centre", "T_tread_out", "T_road", "T_ambient")


@dataclass(frozen=True)
class DataWarning:
    """One quirk of one run: usable data, cleaned, reported with a count.

    Attributes
    ----------
    file : str
        The data file.
    run : str
        The run id.
    kind : str
        ``time-order``, ``time-gap``, ``nan``, ``dropout``, ``spike`` or ``implausible``.
    channels : tuple of str
        The channels concerned, as the file names them.
    count : int
        Samples affected (for ``time-gap``: the number of gaps).
    total : int
        Samples in the run as read.
    detail : str
        What was found (per-channel counts, the implausible value).
    action : str
        What was done (``"samples dropped"``, ``"channel dropped"`` ...).
    line : int or None
        Line of the first occurrence in a text file.
    """

    file: str
    run: str
    kind: str
    channels: tuple[str, ...]
    count: int
    total: int
    detail: str
    action: str
    line: int | None = None

    def __str__(self) -> str:
        where = self.file if self.line is None else f"{self.file}:{self.line}"
        return (f"{where}: {', '.join(self.channels)}: {self.detail} ({self.count} of "
                f"{self.total} samples); {self.action}")

    def to_dict(self) -> dict[str, Any]:
        """A JSON-safe dict (``text`` is the printed line)."""
        return {"file": self.file, "run": self.run, "kind": self.kind,
                "channels": list(self.channels), "count": self.count, "total": self.total,
                "detail": self.detail, "action": self.action, "line": self.line,
                "text": str(self)}

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> DataWarning:
        """Inverse of :meth:`to_dict`."""
        return cls(d["file"], d["run"], d["kind"], tuple(d["channels"]), int(d["count"]),
                   int(d["total"]), d["detail"], d["action"], d.get("line"))


@dataclass(frozen=True, eq=False)
class CleanResult:
    """The cleaned table, the warnings, and the errors.

    ``errors`` holds ``(column, message, row)`` triples: the tidy column, what is wrong, and
    the row of the file's data concerned (None when it is not one row).
    """

    frame: pd.DataFrame | None
    warnings: tuple[DataWarning, ...]
    errors: tuple[tuple[str, str, int | None], ...]
    dropped_channels: tuple[str, ...] = ()


def runs_of(mask: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Start and stop (exclusive) positions of the runs of True in a boolean array."""
    edges = np.diff(np.concatenate(([0], np.asarray(mask, dtype=np.int8), [0])))
    return np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)


class _Report:
    """Collects the warnings of one run."""

    def __init__(self, file: str, run: str, total: int, names: Mapping[str, str],
                 first_line: int | None) -> None:
        self.file, self.run, self.total, self.names = file, run, total, names
        self.first_line = first_line
        self.rows: np.ndarray | None = None
        self.items: list[DataWarning] = []

    def add(self, kind: str, cols, count: int, detail: str, action: str,
            first: int | None = None) -> None:
        """Record one warning; ``first`` is the position of the first sample concerned."""
        if first is not None and self.rows is not None:
            first = int(self.rows[first]) if first < self.rows.size else None
        line = None if self.first_line is None or first is None else self.first_line + first
        self.items.append(DataWarning(self.file, self.run, kind,
                                      tuple(self.names.get(c, c) for c in cols), int(count),
                                      self.total, detail, action, line))


def _per_channel(report: _Report, counts: dict[str, int]) -> str:
    return ", ".join(f"{report.names.get(c, c)} {n}" for c, n in counts.items())


def _time(frame: pd.DataFrame, report: _Report, errors: list) -> pd.DataFrame:
    t = frame["t"].to_numpy(float)
    finite = np.isfinite(t)
    if not finite.all():
        report.add("nan", ["t"], int((~finite).sum()), "time stamp NaN/inf",
                   "samples dropped", int(np.flatnonzero(~finite)[0]))
        frame, t = frame[finite], t[finite]
    if t.size == 0:
        errors.append(("t", "no finite time stamp", None))
        return frame
    before = np.concatenate(([-np.inf], np.maximum.accumulate(t)[:-1]))
    bad = t <= before
    if bad.any():
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
    if t.size > 2:
        dt = np.diff(t)
        step = float(np.median(dt))
        # a step over a dropped time stamp is that sample's, not a gap in the logging
        gaps = (dt > 1.5 * step) & (np.diff(frame.index.to_numpy()) == 1)
        if gaps.any():
            missing = float(np.sum(dt[gaps]) - step * gaps.sum())
            report.add("time-gap", ["t"], int(gaps.sum()),
                       f"{int(gaps.sum())} gap(s) in time, {missing:.3g} s missing in all "
                       f"(sample interval {step:.3g} s)", "kept",
                       int(frame.index[np.flatnonzero(gaps)[0] + 1]))
    return frame


def _nan(frame: pd.DataFrame, cols: list[str], report: _Report, errors: list) -> None:
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
                   f"NaN/inf values in {starts.size} stretch(es): {_per_channel(report, counts)}",
                   "set NaN", first)


def _radius_why(values: np.ndarray, what: str) -> str | None:
    med = float(np.median(values)) if values.size else np.nan
    lo, hi = RADIUS_RANGE
    if values.size and not lo <= med <= hi:
        return f"{what}: median {med:.4g} m is not a tyre radius ({lo:g}-{hi:g} m)"
    return None


def _implausible(frame: pd.DataFrame, report: _Report) -> list[str]:
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
            with np.errstate(divide="ignore", invalid="ignore"):
                r = np.abs(vx[moving] / omega[moving])
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


def _dropouts(frame: pd.DataFrame, cols: list[str], report: _Report) -> None:
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
        frame.loc[mask, c] = np.nan
        counts[c] = int(mask.sum())
        events = max(events, int(starts.size))
        first = int(starts[0]) if first is None else min(first, int(starts[0]))
    if counts:
        report.add("dropout", list(counts), max(counts.values()),
                   f"{events} dropout(s) to exactly 0 between non-zero neighbours: "
                   f"{_per_channel(report, counts)} samples", "set NaN", first)


def _noise_scale(x: np.ndarray) -> float:
    """Robust sigma of the residual from a 7-sample running median (finite samples)."""
    v = x[np.isfinite(x)]
    if v.size < 8:
        return 0.0
    return 1.4826 * float(np.median(np.abs(v - median_filter(v, size=7, mode="nearest"))))


def _curvature_scale(v: np.ndarray) -> float:
    """Robust sigma of the second difference: noise in dense data, the curve's own bending in
    sparse smooth data (so that a sparsely sampled peak is not taken for a spike)."""
    d2 = v[1:-1] - 0.5 * (v[:-2] + v[2:])
    return 1.4826 * float(np.median(np.abs(d2))) if d2.size else 0.0


def _spikes(frame: pd.DataFrame, cols: list[str], report: _Report) -> None:
    counts, first = {}, None
    for c in cols:
        x = frame[c].to_numpy(float)
        idx = np.flatnonzero(np.isfinite(x))
        if idx.size < 20:
            continue
        v = x[idx]
        resid = v - median_filter(v, size=7, mode="nearest")
        sigma = max(1.4826 * float(np.median(np.abs(resid))), _curvature_scale(v))
        lo, hi = np.percentile(v, [0.5, 99.5])
        out = np.abs(resid) > max(SPIKE_SIGMAS * sigma, SPIKE_RANGE * (hi - lo))
        if not out.any():
            continue
        starts, stops = runs_of(out)
        short = stops - starts <= MAX_SPIKE
        mask = np.zeros(v.size, dtype=bool)
        for a, b in zip(starts[short], stops[short]):  # a handful of events
            mask[a:b] = True
        if mask.any():
            frame.loc[frame.index[idx[mask]], c] = np.nan
            counts[c] = int(mask.sum())
            i = int(idx[mask][0])
            first = i if first is None else min(first, i)
    if counts:
        report.add("spike", list(counts), sum(counts.values()),
                   f"isolated spike(s) (Hampel filter, 7 samples, {SPIKE_SIGMAS:g} sigma): "
                   f"{_per_channel(report, counts)} samples", "set NaN", first)


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


def clean_run(frame: pd.DataFrame, *, file: str, run: str,
              names: Mapping[str, str] | None = None,
              first_line: int | None = None) -> CleanResult:
    """Find, clean and report the quirks of one run's tidy table (SI, ISO-W).

    Parameters
    ----------
    frame : pandas.DataFrame
        The run's tidy table (``t`` [s], ``Vx`` [m/s], ``omega`` [rad/s], angles [rad],
        ``p`` [Pa], forces [N], moments [N m], optional ``rl``, ``re`` [m] and temperatures
        [K]); columns that are entirely NaN are channels the file does not have.
    file, run : str
        Named in the warnings.
    names : mapping, optional
        Tidy column -> channel name in the file (for the messages).
    first_line : int, optional
        Line of the first sample in a text file.

    Returns
    -------
    CleanResult
        The cleaned table (row index reset; None on an error), warnings, errors.
    """
    names = dict(names or {})
    report = _Report(file, run, len(frame), names, first_line)
    errors: list[tuple[str, str, int | None]] = []
    frame = frame.reset_index(drop=True)
    frame = _time(frame, report, errors)
    report.rows = frame.index.to_numpy()  # file row of each remaining sample
    frame = frame.reset_index(drop=True).copy()
    if errors:
        return CleanResult(None, tuple(report.items), tuple(errors))
    present = [c for c in frame.columns if c not in ("run", "t") and
               pd.api.types.is_numeric_dtype(frame[c]) and frame[c].notna().any()]
    _nan(frame, present, report, errors)
    if errors:
        return CleanResult(None, tuple(report.items), tuple(errors))
    dropped = _implausible(frame, report)
    for c in dropped:
        frame[c] = np.nan
    live = [c for c in present if c not in dropped]
    _dropouts(frame, [c for c in _DROPOUT if c in live], report)
    _spikes(frame, [c for c in _DATA + _RADII + _TEMPERATURES if c in live], report)
    keep_cols = [c for c in REQUIRED_COLUMNS if c in live]
    missing = ~np.isfinite(frame[keep_cols].to_numpy(float))
    bad = missing.any(axis=1)
    if bad.any():
        starts, _ = runs_of(bad)
        report.add("rows", [c for c, m in zip(keep_cols, missing.T) if m.any()],
                   int(bad.sum()), f"rows with a missing value in a required channel "
                   f"({starts.size} stretch(es))", "rows dropped", int(np.flatnonzero(bad)[0]))
        frame = frame[~bad].reset_index(drop=True)
    if frame.empty:
        errors.append(("t", "no usable sample left after cleaning", None))
        return CleanResult(None, tuple(report.items), tuple(errors))
    return CleanResult(frame, tuple(report.items), (), tuple(dropped))
