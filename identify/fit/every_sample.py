"""The written model against every measured trailer sample (fit.json ``every_sample``).

The stages are judged on the points they fit: the sweeps a segmentation kept, averaged into
bins. A user runs the .tir on the whole session, so the fit also says how the model meets
every loaded sample with a positive load and finite inputs, the ones the fit left out
included: per force and moment the pooled error 100 RMS(model - measured) / RMS(measured),
the thesis metric (the same per pressure level, then the mean over the levels) and the mean of
model - measured, for

- every sample;
- each kind of run: ``free rolling`` (a run without a slip-ratio sweep and without a held slip
  ratio, identify.fit.mf.stage_data.run_sweeps: the runs the pure side-slip and Mx stages fit),
  ``drive/brake`` (the other runs' samples at a slip angle under PURE_ANGLE) and ``combined``
  (the rest);
- what the segmentation did with the sample: in a sweep it kept, or left out as a transition,
  a warm-up, a steady stretch or a partial sweep (``not segmented`` for runs used as loaded);
- each pressure level.

An offset note names a group whose mean error is at least OFFSET_SHARE of its RMS error and
whose pooled error exceeds OFFSET_PCT: the model sits on one side of those samples, as where a
rig's moment zero differs from one file to the next, or where a term the Magic Formula lacks
(Mx has no slip-ratio term) matters; the page says where, not why.

The model is evaluated as the fits evaluate it (identify.model.evaluate, useMode FIT_MODE), with
a freely rolling run's slip-ratio channel taken as 0 (identify.fit.mf.stage_data.rolling_kappa).
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from identify.core.levels import dense_levels, nearest_level
from identify.core.serial import Serial, from_data
from identify.fit.mf.stage_data import rolling_kappa, run_sweeps
from identify.fit.solve.metric import thesis_error, thesis_error_by_group
from identify.model.evaluate import evaluate
from identify.model.modes import FIT_MODE

__all__ = ["CHANNELS", "ChannelError", "EverySample", "SampleGroup", "every_sample",
           "pressure_levels", "run_kinds", "segment_kinds"]

CHANNELS = ("Fx", "Fy", "Mz", "Mx")
"""The forces and moments judged."""
INPUTS = ("Fz", "Vx", "alpha", "kappa", "gamma", "p")
"""The model's inputs: a sample needs them finite (and a positive load) to be judged."""
UNITS = {"Fx": "N", "Fy": "N", "Mz": "N m", "Mx": "N m"}
PURE_ANGLE = np.deg2rad(1.0)
"""[rad] a sample of a run that is not freely rolling is pure longitudinal slip below this
|alpha|."""
PRESSURE_GAP = 5000.0
"""[Pa] twice the histogram bin the pressure levels are found in (dense_levels)."""
OFFSET_SHARE = 0.5
"""A group's mean error at least this share of its RMS error is an offset (see the notes)."""
OFFSET_PCT = 20.0
"""[%] ... where the group's pooled error is above this."""
SEGMENT_NAMES = {"sweep": "kept: sweeps", "transition": "left out: transitions",
                 "warmup": "left out: warm-ups", "steady": "left out: steady stretches",
                 "partial": "left out: partial sweeps",
                 "between segments": "left out: between segments",
                 "not segmented": "runs used as loaded"}
"""What the segmentation made of a sample (identify.segment.result.Segment.kind, and the two
labels of :func:`segment_kinds`) -> the group's name."""
MIN_SAMPLES = 50
"""Groups with fewer samples are not reported."""


@dataclass(frozen=True)
class ChannelError(Serial):
    """The model's error on one force or moment over one group of samples.

    Attributes
    ----------
    samples : int
    pooled_pct : float        100 RMS(model - measured) / RMS(measured) [%]
    thesis_pct : float        the same per pressure level, then the mean over the levels [%]
    mean_error : float        mean of model - measured [N or N m]
    rms_measured : float      RMS of the measured channel [N or N m]
    """

    samples: int
    pooled_pct: float
    thesis_pct: float
    mean_error: float
    rms_measured: float


@dataclass(frozen=True)
class SampleGroup(Serial):
    """One group of samples (see the module notes).

    Attributes
    ----------
    by : str                  ``all``, ``run``, ``segmentation`` or ``pressure``
    name : str                the group (``drive/brake``, ``transition``, ``0.83 bar`` ...)
    samples : int
    channels : mapping        channel -> ChannelError (the channels measured there)
    """

    by: str
    name: str
    samples: int
    channels: Mapping[str, ChannelError] = field(default_factory=dict)


@dataclass(frozen=True)
class EverySample(Serial):
    """The written model against every loaded trailer sample (fit.json ``every_sample``).

    Attributes
    ----------
    samples : int             samples judged (positive load, finite inputs)
    loaded : int              samples loaded
    groups : tuple of SampleGroup   ``all`` first, then by run, segmentation and pressure
    notes : tuple of str      the offsets found (see the module notes)
    """

    samples: int
    loaded: int
    groups: tuple[SampleGroup, ...]
    notes: tuple[str, ...] = ()

    @classmethod
    def from_dict(cls, d: Mapping[str, Any] | None) -> EverySample | None:
        """Inverse of :meth:`to_dict`; None for fit.json's empty entry (not computed)."""
        return from_data(cls, d) if d else None

    def group(self, by: str, name: str) -> SampleGroup | None:
        """The group ``name`` of ``by`` (None when it has too few samples or none)."""
        return next((g for g in self.groups if g.by == by and g.name == name), None)

    def summary_line(self) -> str:
        """One line: the pooled error of each channel over every sample."""
        g = self.group("all", "every sample")
        if g is None:
            return ""
        parts = ", ".join(f"{c} {e.pooled_pct:.1f} %" for c, e in g.channels.items())
        return (f"the .tir on every loaded trailer sample ({g.samples} of {self.loaded}): "
                f"{parts} (pooled RMS error; per kind of run on the report's page)")


def run_kinds(table: pd.DataFrame) -> np.ndarray:
    """The kind of run of every row (``free rolling``, ``drive/brake``, ``combined``; see the
    module notes)."""
    rolling = run_sweeps(table)[2]
    pure = np.abs(table["alpha"].to_numpy(float)) < PURE_ANGLE
    return np.where(rolling, "free rolling", np.where(pure, "drive/brake", "combined"))


def pressure_levels(p: np.ndarray) -> np.ndarray:
    """Per sample its pressure level [Pa] (NaN where p is not finite or no level is found): the
    nearest of the levels the session held (identify.core.levels.dense_levels, which a slow
    pressure ramp between two levels does not join into one)."""
    levels = np.asarray(dense_levels(p, PRESSURE_GAP), float)
    idx = nearest_level(p, levels)
    return np.where(idx >= 0, levels[np.maximum(idx, 0)] if levels.size else np.nan, np.nan)


def _error(measured: np.ndarray, model: np.ndarray, level: np.ndarray) -> ChannelError | None:
    ok = np.isfinite(measured) & np.isfinite(model)
    if ok.sum() < MIN_SAMPLES:
        return None
    m, mod = measured[ok], model[ok]
    rms_m = math.sqrt(float(np.mean(m ** 2)))
    if rms_m == 0.0:
        return None
    groups = np.nan_to_num(level[ok], nan=-1.0)  # no level found: one group
    per = [v for v in thesis_error_by_group(mod, m, groups).values() if math.isfinite(v)]
    return ChannelError(int(ok.sum()), thesis_error(mod, m),
                        float(np.mean(per)) if per else math.nan, float(np.mean(mod - m)), rms_m)


def every_sample(params: Mapping[str, float], trailer: pd.DataFrame,
                 segment_kind: np.ndarray | None = None) -> EverySample:
    """The model ``params`` against every row of the loaded trailer table (see the module
    notes).

    Parameters
    ----------
    params : mapping
        The written .tir's numeric values.
    trailer : DataFrame
        The loaded trailer table (tidy columns, ISO-W, SI; identify.io.trailer.files).
    segment_kind : ndarray of str, optional
        Per row what the segmentation made of it (``sweep``, ``transition``, ``warmup``,
        ``steady``, ``partial``, ``not segmented``); None: no segmentation group.
    """
    if any(c not in trailer.columns for c in ("run", *INPUTS)):
        return EverySample(0, len(trailer), ())
    table = rolling_kappa(trailer.reset_index(drop=True))
    fz = table["Fz"].to_numpy(float)
    ok = fz > 0
    for c in INPUTS:
        ok &= np.isfinite(table[c].to_numpy(float))
    t = table[ok]
    if t.empty:
        return EverySample(0, len(trailer), ())
    out = evaluate(params, t["Fz"].to_numpy(float), t["kappa"].to_numpy(float),
                   t["alpha"].to_numpy(float), t["gamma"].to_numpy(float),
                   t["Vx"].to_numpy(float), t["p"].to_numpy(float), mode=FIT_MODE)
    model = {c: np.asarray(out[c], float) for c in CHANNELS}
    measured = {c: t[c].to_numpy(float) for c in CHANNELS if c in t.columns}
    level = pressure_levels(t["p"].to_numpy(float))
    parts: list[tuple[str, str, np.ndarray]] = [("all", "every sample", np.ones(len(t), bool))]
    kinds = run_kinds(t)
    parts += [("run", k, kinds == k) for k in ("free rolling", "drive/brake", "combined")]
    if segment_kind is not None:
        seg = np.asarray(segment_kind, dtype=object)[ok]
        parts += [("segmentation", shown, seg == k) for k, shown in SEGMENT_NAMES.items()]
    parts += [("pressure", f"{v / 1e5:.2f} bar", level == v)
              for v in np.unique(level[np.isfinite(level)])]
    groups, notes = [], []
    for by, name, rows in parts:
        if rows.sum() < MIN_SAMPLES:
            continue
        chans = {c: e for c in measured
                 if (e := _error(measured[c][rows], model[c][rows], level[rows])) is not None}
        groups.append(SampleGroup(by, name, int(rows.sum()), chans))
        if by != "run":
            continue
        for c, e in chans.items():
            rms_e = e.pooled_pct * e.rms_measured / 100.0
            if e.pooled_pct > OFFSET_PCT and abs(e.mean_error) >= OFFSET_SHARE * rms_e:
                notes.append(f"{c} on the {name} samples: the model is "
                             f"{abs(e.mean_error):.3g} {UNITS[c]} "
                             f"{'below' if e.mean_error < 0 else 'above'} the measurement on "
                             f"average (RMS error {rms_e:.3g} {UNITS[c]}, "
                             f"{e.pooled_pct:.0f} %)")
    return EverySample(int(ok.sum()), len(trailer), tuple(groups), tuple(notes))


def segment_kinds(trailer: pd.DataFrame, segments: Sequence[Any] | None,
                  segmented_runs: Sequence[str]) -> np.ndarray:
    """Per row of the loaded trailer table what the segmentation made of it: the kind of the
    segment it lies in (a Segment's ``start``/``stop`` are row positions within its run), ``left
    between segments`` for a segmented run's rows in none, ``not segmented`` for the other
    runs."""
    run = trailer["run"].astype(str).to_numpy()
    out = np.full(len(trailer), "not segmented", dtype=object)
    done = np.isin(run, list(segmented_runs))
    out[done] = "between segments"
    pos = trailer.groupby("run", sort=False).cumcount().to_numpy()
    for s in segments or ():
        rows = (run == str(s.run)) & (pos >= s.start) & (pos < s.stop)
        out[rows] = s.kind
    return out
