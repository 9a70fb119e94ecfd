"""The trailer table the MF stages see: segmented where it is a continuous log, with the channels
that cannot be used named, and the data-quality record that goes into fit.json and the report.

Continuous session logs (the runs read from TTC ``.mat``/``.dat`` files: sweeps, warm-ups and
transitions in one stream) other than drive/brake and combined-slip runs
(:data:`SLIP_RATIO_TESTS`, left to identify.workflows.sweep_bins.mf_table) are segmented
first (identify.segment.segment_trailer with its default settings): only the sweep segments
at their condition levels are kept, after the named filters (revolution average, set slip
angle, cold tread, low speed). Runs in the other formats
are test-by-test files whose every sample is a measurement, and are used as loaded.

A channel is unavailable to the fit when it is absent from every run or was dropped as
implausible while loading (identify.io.trailer.quirks); :func:`prepare_trailer` says why, per tidy
column, so that the stages needing it are skipped with that reason
(identify.fit.coverage.mf_coverage) instead of being fitted to placeholder data.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from identify.core.serial import Serial, meta
from identify.fit.mf.stage_data import SEGMENT_COLUMN
from identify.segment import LEVEL_COLUMNS, Segmentation, SegmentSettings, segment_trailer
from identify.segment.turnaround import turnaround_mask

__all__ = ["SEGMENTED_SUFFIXES", "TrailerData", "prepare_trailer", "unavailable_channels"]

SLIP_RATIO_TESTS = ("braking_driving", "combined")
"""Tests of the runs not segmented here with the cornering programme: a drive/brake or
combined-slip run is handed on as logged, and identify.workflows.sweep_bins.mf_table segments
it on its own when it holds a warm-up (its condition levels its own, not found together with
the slip-angle programme's, which kept only part of its slip-ratio sweeps) and bins its dense
sweeps. The fitted model is judged on every sample of a session; the slip-ratio sweeps' are
then fitted rather than left out."""
SEGMENTED_SUFFIXES = (".mat", ".dat")
"""Run files whose runs are continuous logs and are segmented before fitting (TTC)."""

#: implausible-warning detail (identify.io.trailer.quirk_checks) -> the tidy column it dropped
_IMPLAUSIBLE = (("wheel speed", "omega"), ("slip ratio pinned", "kappa"),
                ("effective rolling radius", "re"), ("loaded radius", "rl"))
_USED = ("omega", "kappa", "rl", "Fx", "Fy", "Mz", "Mx", "My")


@dataclass(frozen=True, eq=False)
class TrailerData(Serial):
    """The trailer table to fit and what happened to it.

    Attributes
    ----------
    table : DataFrame            the rows the MF stages may use
    segmentation : Segmentation or None   the segmentation of the continuous runs (None when
                                 there were none)
    segmented_runs : tuple of str   the runs that were segmented
    unavailable : mapping        tidy column -> why it cannot be used
    mz_turnaround : int          samples whose Mz was taken out (NaN) at a slip-angle
                                 turn-around (identify.segment.turnaround), before any
                                 segmentation
    """

    table: pd.DataFrame = field(metadata=meta(skip=True))
    segmentation: Segmentation | None
    segmented_runs: tuple[str, ...] = ()
    unavailable: Mapping[str, str] = field(default_factory=dict)
    mz_turnaround: int = field(default=0, metadata=meta(key="mz_turnaround_samples"))

    #: ``to_dict`` is the trailer part of fit.json's ``data_quality``: the fields but the
    #: table, and the number of its rows
    serial_derived = {"rows_fitted": lambda self: len(self.table)}
    serial_order = ("segmented_runs", "segmentation", "unavailable", "rows_fitted")


def unavailable_channels(trailer: pd.DataFrame, warnings) -> dict[str, str]:
    """Tidy column -> why the fit cannot use it: dropped as implausible in every run that has
    it, or absent (all NaN). Only the columns a stage fits or selects by are listed."""
    dropped: dict[str, str] = {}
    for w in warnings:
        if w.kind != "implausible":
            continue
        col = next((c for text, c in _IMPLAUSIBLE if w.detail.startswith(text)), None)
        if col is not None and "not used" not in w.detail:
            dropped.setdefault(col, f"{', '.join(w.channels)} in {w.run}: {w.detail}")
    out = {}
    for col in _USED:
        if col in trailer.columns and trailer[col].notna().any():
            continue
        if col in dropped:
            out[col] = f"dropped as implausible ({dropped[col]})"
        else:
            out[col] = "absent"
    return out


def prepare_trailer(mset, settings: SegmentSettings = SegmentSettings(), *,
                    segment: bool = True) -> TrailerData:
    """The trailer table of a MeasurementSet ready for the MF stages (see the module notes);
    ``settings`` go to the segmentation (bin widths: FitSettings), ``segment=False`` keeps
    every run as loaded (``mfid fit --no-segment``). Either way the Mz of the samples at a
    slip-angle turn-around is taken out (NaN; identify.segment.turnaround): the rig's steering
    transient, not the tyre's steady state."""
    trailer, turned = _without_turnaround_mz(mset.trailer)
    continuous = {r.id for r in mset.manifest.runs if r.kind == "trailer"
                  and Path(r.file).suffix.lower() in SEGMENTED_SUFFIXES
                  and r.test not in SLIP_RATIO_TESTS}
    unavailable = unavailable_channels(trailer, mset.warnings)
    if not segment or not continuous or trailer is None or trailer.empty:
        return TrailerData(trailer, None, (), unavailable, turned)
    is_cont = trailer["run"].astype(str).isin(continuous)
    seg = segment_trailer(trailer[is_cont], settings)
    # the segment of each sample stays as the sweep label (the clusters of the covariance)
    kept = seg.table.drop(columns=["sweep", *LEVEL_COLUMNS.values()], errors="ignore") \
        .rename(columns={"segment": SEGMENT_COLUMN})
    table = pd.concat([kept, trailer[~is_cont]], ignore_index=True)
    runs = tuple(sorted(set(trailer.loc[is_cont, "run"].astype(str))))
    return TrailerData(table, seg.segmentation, runs, unavailable, turned)


def _without_turnaround_mz(trailer: pd.DataFrame | None) -> tuple[pd.DataFrame | None, int]:
    """``trailer`` with Mz NaN at the slip-angle turn-arounds (a copy when any), and how many
    samples that took out."""
    if trailer is None or trailer.empty or "Mz" not in trailer.columns:
        return trailer, 0
    turn = turnaround_mask(trailer) & trailer["Mz"].notna().to_numpy()
    if not turn.any():
        return trailer, 0
    return trailer.assign(Mz=trailer["Mz"].where(~turn)), int(turn.sum())
