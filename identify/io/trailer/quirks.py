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
``few-samples``    fewer than :data:`MIN_RUN_SAMPLES` usable samples       kept (reported)
``implausible``    a channel present but not physical: wheel speed         channel dropped
                   inconsistent with V (V/omega not a tyre radius), a
                   radius that is not a tyre's, a slip ratio pinned at
                   +-1, a temperature outside -70 .. 180 degC
=================  =====================================================  ==================

The record (:class:`DataWarning`) lives in identify.io.data_warning, the checks in
identify.io.trailer.quirk_checks; :func:`clean_run` runs them in order. A dropped channel becomes
NaN in the whole run, so that a stage needing it finds no points and is skipped;
:attr:`DataWarning.channels` names it and ``kind == "implausible"`` says why. Rows are dropped
only for a missing value in a required channel (the condition, force and moment channels);
optional channels (radii, temperatures, My) keep their NaN.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np
import pandas as pd

from identify.io.csv_rows import RowLines
from identify.io.data_warning import DataWarning, WarningReport, runs_of
from identify.io.trailer.quirk_checks import (
    MAX_BAD_TIME,
    MAX_DROPOUT,
    MAX_SPIKE,
    MIN_RUN_SAMPLES,
    RADIUS_RANGE,
    SPIKE_SIGMAS,
    dropouts,
    implausible,
    nan_values,
    spikes,
    time_order,
    unused_slip_warning,
)

__all__ = ["MAX_BAD_TIME", "MAX_DROPOUT", "MAX_SPIKE", "RADIUS_RANGE", "REQUIRED_COLUMNS",
           "SPIKE_SIGMAS", "CleanResult", "DataWarning", "clean_run", "runs_of",
           "unused_slip_warning"]

#: Columns whose missing value drops the row (when the channel is present and not dropped).
REQUIRED_COLUMNS = ("t", "Vx", "alpha", "kappa", "gamma", "p", "Fx", "Fy", "Fz", "Mx", "Mz")
_DATA = ("Vx", "omega", "alpha", "kappa", "gamma", "p", "Fx", "Fy", "Fz", "Mx", "My", "Mz")
_DROPOUT = ("Vx", "omega", "p", "Fx", "Fy", "Fz", "Mx", "My", "Mz")
_RADII = ("rl", "re")
_TEMPERATURES = ("T_tread_in", "T_tread_centre", "T_tread_out", "T_road", "T_ambient")


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


def clean_run(frame: pd.DataFrame, *, file: str, run: str,
              names: Mapping[str, str] | None = None,
              first_line: int | RowLines | None = None) -> CleanResult:
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
    first_line : int or RowLines, optional
        Line of the first sample in a text file (``first_line + i``: the line of sample
        ``i``, a :class:`~identify.io.csv_rows.RowLines` when the file has blank lines).

    Returns
    -------
    CleanResult
        The cleaned table (row index reset; None on an error), warnings, errors.
    """
    names = dict(names or {})
    report = WarningReport(file, run, len(frame), names, first_line)
    errors: list[tuple[str, str, int | None]] = []
    frame = frame.reset_index(drop=True)
    frame = time_order(frame, report, errors)
    report.rows = frame.index.to_numpy()  # file row of each remaining sample
    # no copy of the run (0.5 GB at 5e6 samples): a check that sets samples NaN replaces that
    # channel with a new array, so the caller's arrays are never written
    frame = frame.reset_index(drop=True)
    if errors:
        return CleanResult(None, tuple(report.items), tuple(errors))
    present = [c for c in frame.columns if c not in ("run", "t") and
               pd.api.types.is_numeric_dtype(frame[c]) and frame[c].notna().any()]
    nan_values(frame, present, report, errors)
    if errors:
        return CleanResult(None, tuple(report.items), tuple(errors))
    dropped = implausible(frame, report)
    for c in dropped:
        frame[c] = np.nan
    live = [c for c in present if c not in dropped]
    dropouts(frame, [c for c in _DROPOUT if c in live], report)
    spikes(frame, [c for c in _DATA + _RADII + _TEMPERATURES if c in live], report)
    keep_cols = [c for c in REQUIRED_COLUMNS if c in live]
    bad, missing = np.zeros(len(frame), dtype=bool), []
    for c in keep_cols:  # column by column: no n x channels mask
        gone = ~np.isfinite(frame[c].to_numpy(float))
        if gone.any():
            bad |= gone
            missing.append(c)
    if bad.any():
        starts, _ = runs_of(bad)
        report.add("rows", missing,
                   int(bad.sum()), f"rows with a missing value in a required channel "
                   f"({starts.size} stretch(es))", "rows dropped", int(np.flatnonzero(bad)[0]))
        frame = frame[~bad].reset_index(drop=True)
    if frame.empty:
        errors.append(("t", "no usable sample left after cleaning", None))
        return CleanResult(None, tuple(report.items), tuple(errors))
    if len(frame) < MIN_RUN_SAMPLES:  # usable, but no stage will have the points it needs
        report.add("few-samples", ["t"], len(frame), f"only {len(frame)} usable sample(s): "
                   f"too few for a sweep (a Magic Formula stage needs 50 points)", "kept", None)
    return CleanResult(frame, tuple(report.items), (), tuple(dropped))
