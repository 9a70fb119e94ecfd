"""``segment_trailer``: the sweeps of a trailer table at their condition levels, filtered.

Steps (pure computation on the tidy table of :mod:`identify.io.trailer.files`):

1. per run, the quasi-steady plateaus and what each holds (:mod:`~identify.segment.plateaus`);
   between plateaus lie transitions;
2. the condition levels, by 1-D clustering of the sweep plateaus' medians over all runs
   together (:mod:`~identify.segment.levels`): load, pressure, inclination, speed, and the set
   slip angle of slip-ratio sweeps; a sweep whose median falls in no level (a cluster of one
   that did not hold the channel from its start to its end) becomes ``isolated`` and is
   dropped;
3. the named filters on the sweeps' samples (:mod:`~identify.segment.filters`).

Warm-ups, transitions, steady stretches (a pause, the tyre lifted for a pressure change) and
partial sweeps are dropped; every segment is listed with its kind in the result, and every
filter with the samples it removed, so that a report can show where the data went.

Sweeps of the inclination angle (a camber sweep at fixed slip) break the quasi-steady test and
are not found; the TTC programme steps the camber instead.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pandas as pd

from identify.segment import filters as F
from identify.segment.levels import cluster, resolution
from identify.segment.plateaus import (
    classify,
    describe,
    find_plateaus,
    steady_mask,
)
from identify.segment.result import Segment, Segmentation
from identify.segment.settings import CONDITIONS, SegmentSettings

__all__ = ["LEVEL_COLUMNS", "SegmentedTable", "segment_trailer"]

#: Columns added to the selected table: the level value [SI] of each condition.
LEVEL_COLUMNS = {c: f"{c}_level" for c in (*CONDITIONS, "alpha")}


@dataclass(frozen=True, eq=False)
class SegmentedTable:
    """The segmentation and the selected samples.

    ``table`` holds the kept rows of the input (after the filters; one row per bin when
    binned) with three more kinds of column: ``segment`` (index into
    ``segmentation.segments``), ``sweep`` (``alpha`` or ``kappa``) and the level values
    :data:`LEVEL_COLUMNS` (``Fz_level`` [N], ``p_level`` [Pa], ``gamma_level`` [rad],
    ``Vx_level`` [m/s], ``alpha_level`` [rad] for slip-ratio sweeps, NaN otherwise).
    """

    segmentation: Segmentation
    table: pd.DataFrame


def _set_alpha(alpha: np.ndarray, kappa: np.ndarray) -> float:
    """The set slip angle of a slip-ratio sweep: the median where the tyre slips."""
    k = kappa - np.median(kappa)
    slipping = np.abs(k) > 0.25 * np.max(np.abs(k)) if k.size else k.astype(bool)
    return float(np.median(alpha[slipping] if slipping.sum() > 10 else alpha))


def _runs(table: pd.DataFrame, s: SegmentSettings):
    """Per run: positions, plateaus, kinds; yields one record per segment (plateaus and the
    transitions between them)."""
    offset = 0
    for run, sub in table.groupby("run", sort=False):
        t = sub["t"].to_numpy(float)
        cols = {c: sub[c].to_numpy(float) for c in (*CONDITIONS, "alpha", "kappa")}
        ok = steady_mask(cols, t, s)
        starts, stops = find_plateaus(ok, t, s)
        plats = describe(cols, t, starts, stops)
        kinds = classify(plats, s)
        edge = 0
        for p, (kind, var) in zip(plats, kinds):
            if p.start > edge:
                yield run, "transition", "", offset + edge, offset + p.start, {}, t, offset
            med = dict(p.medians)
            med.update({f"{c}_ends": v for c, v in p.ends.items()})
            if var == "kappa":
                med["alpha"] = _set_alpha(cols["alpha"][p.start:p.stop],
                                          cols["kappa"][p.start:p.stop])
            yield run, kind, var, offset + p.start, offset + p.stop, med, t, offset
            edge = p.stop
        if edge < t.size:
            yield run, "transition", "", offset + edge, offset + t.size, {}, t, offset
        offset += t.size


def _levels(records: list, sweeps: list[int], s: SegmentSettings):
    """Levels of every condition over the sweeps, and each sweep's level index per channel
    (-1: in no level; -2 for ``alpha`` of a slip-angle sweep, which has no set slip angle)."""
    weights = np.array([records[i][4] - records[i][3] for i in sweeps], dtype=float)
    levels, index = {}, {}
    for c in CONDITIONS:
        med = np.array([records[i][5][c] for i in sweeps])
        ends = np.array([records[i][5][f"{c}_ends"] for i in sweeps])
        held = ends <= np.array([resolution(c, m, s) for m in med])
        levels[c], index[c] = cluster(c, med, weights, s, held=held)
    kappa_sweeps = [j for j, i in enumerate(sweeps) if records[i][2] == "kappa"]
    med = np.array([records[sweeps[j]][5]["alpha"] for j in kappa_sweeps])
    levels["alpha"], found = cluster("alpha", med, weights[kappa_sweeps], s)
    index["alpha"] = np.full(len(sweeps), -2, dtype=int)
    index["alpha"][kappa_sweeps] = found
    return levels, index


def segment_trailer(table: pd.DataFrame,
                    settings: SegmentSettings | None = None) -> SegmentedTable:
    """Find the sweeps and condition levels of a trailer table and filter its samples.

    Parameters
    ----------
    table : pandas.DataFrame
        The tidy trailer table (columns ``run, t, Vx, alpha, kappa, gamma, p, Fz`` ... in SI,
        ISO-W; optional ``re``, ``rl``, ``T_tread_centre``), rows of a run in time order.
    settings : SegmentSettings, optional

    Returns
    -------
    SegmentedTable
    """
    s = settings or SegmentSettings()
    table = table.reset_index(drop=True)
    records = list(_runs(table, s))
    sweeps = [i for i, r in enumerate(records) if r[1] == "sweep"]
    while True:  # a sweep in no level is dropped, and the levels are found again without it
        levels, index = _levels(records, sweeps, s)
        isolated = np.any([index[c] == -1 for c in index], axis=0) if sweeps else []
        if not np.any(isolated):
            break
        for j in np.flatnonzero(isolated):
            records[sweeps[j]] = (records[sweeps[j]][0], "isolated", *records[sweeps[j]][2:])
        sweeps = [i for j, i in enumerate(sweeps) if not isolated[j]]
    segments: list[Segment] = []
    seg_of_row = np.full(len(table), -1, dtype=int)
    level_cols = {c: np.full(len(table), np.nan) for c in LEVEL_COLUMNS}
    position = {i: j for j, i in enumerate(sweeps)}
    for i, (run, kind, var, a, b, med, t, off) in enumerate(records):
        lv = {}
        if kind == "sweep":
            j = position[i]
            lv = {c: int(index[c][j]) for c in index if index[c][j] != -2}
            seg_of_row[a:b] = len(segments)
            for c, k in lv.items():
                level_cols[c][a:b] = levels[c][k].value
        medians = {k: v for k, v in med.items() if not k.endswith("_ends")}
        segments.append(Segment(str(run), kind, var, a - off, b - off, float(t[a - off]),
                                float(t[b - off - 1]), lv, medians))
    chosen = seg_of_row >= 0
    frame = table[chosen].assign(
        segment=seg_of_row[chosen],
        sweep=np.array([segments[k].sweep for k in seg_of_row[chosen]], dtype=object),
        **{name: level_cols[c][chosen] for c, name in LEVEL_COLUMNS.items()})
    in_sweeps = len(frame)
    counts = []
    for step in (lambda f: F.revolution_average(f, s), lambda f: F.set_slip_angle(f, s),
                 lambda f: F.cold_tread(f, s), lambda f: F.low_speed(f, s),
                 lambda f: F.binning(f, s)):
        frame, count = step(frame)
        counts.append(count)
    frame = frame.reset_index(drop=True)
    kept = np.bincount(frame["segment"].to_numpy(int), minlength=len(segments)) \
        if len(frame) else np.zeros(len(segments), dtype=int)
    segments = [Segment(g.run, g.kind, g.sweep, g.start, g.stop, g.t_start, g.t_end, g.levels,
                        g.medians, int(kept[k])) for k, g in enumerate(segments)]
    result = Segmentation(levels, tuple(segments), tuple(counts), len(table), in_sweeps,
                          len(frame), s.to_dict())
    return SegmentedTable(result, frame)
