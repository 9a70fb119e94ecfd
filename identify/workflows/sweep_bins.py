"""The trailer points of the MF stages: quasi-steady sweeps of logged test programmes, binned.

``mf_table`` is what ``mfid fit`` hands the MF stages:

1. **Segmentation** (``FitSettings.segment``, on unless ``--no-segment``): a run logged
   continuously through a test programme, recognised by the warm-up that
   :func:`identify.segment.segment_trailer` finds in it (a TTC session's runs, as imported by
   ``mfid import``), is fitted on its quasi-steady sweeps at their condition levels only: warm-ups,
   transitions between set points, pauses, partial sweeps, cold-tread and slow samples are
   dropped and every channel is averaged over one wheel revolution (identify.segment.filters).
   Without this a TTC session's load ramps bridge its load steps, the data seem to hold one load
   level and the load and pressure terms are held (docs/procedures.md, "Logged sessions").
   Runs without a warm-up (the simulated folders, hand-made tables) are kept as they are.
2. **Binning** (``--bin-alpha``/``--bin-kappa``, ``--no-bin``), below.

Binning of dense trailer sweeps:

A trailer logging at 100 Hz records a slip sweep as thousands of samples whose neighbours carry
the same information. The averaging itself is the segmentation's ``binning`` filter
(:func:`identify.segment.filters.binning`: one point per bin of the swept variable and segment,
every channel the mean of its samples); here the segments it needs are labelled on a trailer
table that was not segmented: a segment is a sweep of :func:`identify.fit.mf.stage_data.sweep_ids`
(a new run, a time gap or a load step) at one inclination and pressure level, swept in slip
ratio when its kappa spans more than ``mf_data.SWEEP_KAPPA``, else in slip angle when its alpha
spans more than ``mf_data.SWEEP_ANGLE``.

Only **dense** sweeps are binned: those with at least :data:`MIN_PER_BIN` samples per occupied
bin on average (a 100 Hz TTC sweep has 10-40; the simulated folders' trailer sweeps, sampled
once per set point, have about 1 and are left as they are). Free rolling and other unswept
stretches keep their samples.

What it does to the fit (docs/procedures.md, "Sweep binning", has the measured numbers): the
MF stages see a tenth to a thirtieth of the points; each binned point is the mean of its
samples, so white noise per point shrinks by the square root of the count while the number of
points shrinks by the count, and the covariance s^2 (J'J)^-1 stays the same; correlated
(AR(1)) noise, which makes per-sample standard errors too small, is averaged within a bin, so
the binned errors are the more honest ones. The up- and down-going halves of a sweep are merged
(a relaxation lag or hysteresis is averaged out, not fitted: the MF is a steady-state model),
unless ``FitSettings.bin_passes`` asks for one point per bin and pass (where a rig's load
follows the slip direction, a merged bin averages two operating points;
identify.segment.filters, ``binning``).
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from identify.fit.mf import stage_data as mf_data
from identify.fit.mf.stage_data import SEGMENT_COLUMN
from identify.fit.run import FitSettings
from identify.segment import FilterCount, SegmentSettings, segment_trailer
from identify.segment.filters import binning

__all__ = ["GAMMA_RESOLUTION", "MIN_PER_BIN", "bin_sweeps", "mf_table"]

MIN_PER_BIN = 3.0
"""A sweep is dense (binned) with at least this many samples per occupied bin on average."""
GAMMA_RESOLUTION = np.deg2rad(0.25)
"""[rad] samples of one sweep whose inclination differs by more than this are not averaged
together (a camber step inside a load step)."""


def _segments(trailer: pd.DataFrame, fnomin: float) -> np.ndarray:
    """Segment number of every row: sweep, inclination level and pressure level."""
    key = pd.DataFrame({
        "sweep": mf_data.sweep_ids(trailer, fnomin),
        "gamma": np.round(trailer["gamma"].to_numpy(float) / GAMMA_RESOLUTION),
        "p": np.round(trailer["p"].to_numpy(float) / mf_data.PRESSURE_RESOLUTION)})
    return key.groupby(["sweep", "gamma", "p"], sort=False, dropna=False).ngroup().to_numpy()


def _kinds(trailer: pd.DataFrame, segment: np.ndarray, widths: dict) -> np.ndarray:
    """``kappa``, ``alpha`` or None (not binned) for every row."""
    frame = pd.DataFrame({"segment": segment, "alpha": trailer["alpha"].to_numpy(float),
                          "kappa": trailer["kappa"].to_numpy(float)})
    g = frame.groupby("segment")
    span = g[["alpha", "kappa"]].max() - g[["alpha", "kappa"]].min()
    count = g.size()
    kind = pd.Series(None, index=span.index, dtype=object)
    for var, threshold in (("alpha", mf_data.SWEEP_ANGLE), ("kappa", mf_data.SWEEP_KAPPA)):
        width = widths[var]
        if width is None:
            continue
        occupied = (frame.assign(b=np.floor(frame[var] / width))
                    .groupby("segment")["b"].nunique())
        dense = (span[var] > threshold) & (count / occupied.clip(lower=1) >= MIN_PER_BIN)
        kind[dense] = var  # kappa, set second, wins over alpha (a kappa sweep at a set angle)
    return kind.reindex(segment).to_numpy()


def bin_sweeps(trailer: pd.DataFrame, fnomin: float, *, alpha_deg: float | None,
               kappa: float | None, passes: bool = False) -> tuple[pd.DataFrame, FilterCount]:
    """The trailer table with every dense slip sweep averaged in bins of its swept variable.

    Parameters
    ----------
    trailer : DataFrame
        The tidy trailer table (identify.io.trailer.files); not modified.
    fnomin : float [N]
        Nominal load (the load steps that start a new sweep, mf_data.sweep_ids).
    alpha_deg : float or None [deg]
        Bin width of slip-angle sweeps (None: not binned).
    kappa : float or None [-]
        Bin width of slip-ratio sweeps (None: not binned).

    Returns
    -------
    table : DataFrame
        The same columns and the segment label ``segment_id`` (mf_data.SEGMENT_COLUMN: the
        sweeps of the covariance); unbinned rows as they were, then one row per bin, ordered
        by segment and time.
    count : FilterCount
        Samples removed and kept, and the widths (for the fit's progress and record).
    """
    widths = {"alpha": None if alpha_deg is None else np.deg2rad(alpha_deg), "kappa": kappa}
    if all(w is None for w in widths.values()) or trailer.empty:
        return trailer, FilterCount("binning", 0, len(trailer), False, "not requested")
    segment = _segments(trailer, fnomin)
    kinds = _kinds(trailer, segment, widths)
    if not pd.notna(kinds).any():  # no dense sweep: the table as it is, in its order
        return trailer, FilterCount("binning", 0, len(trailer), True, "no dense sweep")
    frame = trailer.drop(columns=SEGMENT_COLUMN, errors="ignore").assign(segment=segment,
                                                                         sweep=kinds)
    out, count = binning(frame, SegmentSettings(bin_alpha_deg=alpha_deg, bin_kappa=kappa,
                                                bin_passes=passes))
    return _labelled(out, trailer), count


def _labelled(table: pd.DataFrame, trailer: pd.DataFrame) -> pd.DataFrame:
    """``table`` (segmented or binned) with ``trailer``'s columns, and its ``segment`` as the
    sweep label (mf_data.SEGMENT_COLUMN) in place of any label it carried before."""
    columns = [c for c in trailer.columns if c != SEGMENT_COLUMN] + [SEGMENT_COLUMN]
    return table.drop(columns=SEGMENT_COLUMN, errors="ignore").rename(
        columns={"segment": SEGMENT_COLUMN})[columns]


def segment_settings(settings: FitSettings) -> SegmentSettings:
    """The segmentation thresholds of a fit: the defaults with ``settings``' bin widths and
    revolution average. Every segmentation of one fit (the session logs' in
    identify.workflows.trailer_prep and the other runs' in :func:`mf_table`) takes this one
    object, so that an option cannot reach one and miss the other."""
    return SegmentSettings(bin_alpha_deg=settings.bin_alpha_deg, bin_kappa=settings.bin_kappa,
                           bin_passes=settings.bin_passes,
                           revolution_average=settings.revolution_average)


def mf_table(trailer: pd.DataFrame, fnomin: float, *, segment: bool, settings: SegmentSettings
             ) -> tuple[pd.DataFrame, list[str]]:
    """The trailer points of the MF stages: logged runs segmented, dense sweeps binned.

    Parameters
    ----------
    trailer : DataFrame
        The tidy trailer table (identify.io.trailer.files); not modified.
    fnomin : float [N]
        Nominal load.
    segment : bool
        Fit the runs with a warm-up on their quasi-steady sweeps only (see module).
    settings : SegmentSettings
        The segmentation's thresholds and filters (:func:`segment_settings` for a fit), its
        bin widths ``bin_alpha_deg`` [deg] and ``bin_kappa`` [-] also the other runs' (None:
        not binned).

    Returns
    -------
    table : DataFrame
        The same columns and ``segment_id`` where a segmentation or binning labelled the
        sweeps: the segmented runs' selected (and binned) samples, then the other
        runs, dense sweeps binned.
    notes : list of str
        One line per step that changed the table (for the progress and the log).
    """
    notes: list[str] = []
    parts = []
    rest = trailer
    if segment and not trailer.empty:
        seg = segment_trailer(trailer, settings)
        runs = list(dict.fromkeys(s.run for s in seg.segmentation.segments
                                  if s.kind == "warmup"))
        if runs:
            mine = trailer["run"].isin(runs).to_numpy()
            picked = _labelled(seg.table[seg.table["run"].isin(runs)], trailer)
            sweeps = sum(1 for s in seg.segmentation.segments
                         if s.run in runs and s.kind == "sweep")
            filters = "; ".join(f"{f.name} {f.removed}" for f in seg.segmentation.filters
                                if f.applied)
            notes.append(f"segment: {', '.join(map(str, runs))} (runs with a warm-up): "
                         f"{int(mine.sum())} samples -> {len(picked)} points on {sweeps} "
                         f"quasi-steady sweeps (samples removed by filter, all runs: "
                         f"{filters})")
            parts.append(picked)
            rest = trailer[~mine]
    binned, count = bin_sweeps(rest, fnomin, alpha_deg=settings.bin_alpha_deg,
                               kappa=settings.bin_kappa, passes=settings.bin_passes)
    if count.applied and len(rest) and parts:
        notes.append(f"bin: the other runs' {len(rest)} samples -> {count.remaining} points "
                     f"({count.note}; dense sweeps only)")
    elif count.applied and count.removed:
        notes.append(f"bin: {len(rest)} trailer samples -> {count.remaining} points "
                     f"({count.note}; dense sweeps only)")
    if not parts:
        return binned, notes
    return pd.concat(parts + [binned], ignore_index=True), notes
