"""Condition levels: robust 1-D clustering of the sweep segments' medians.

A trailer programme holds each condition (load, pressure, inclination, speed; the set slip
angle of slip-ratio sweeps) at a few set points while it sweeps, and the measured value drifts
about its set point (the pressure rises as the tyre warms, the load control wanders). Each
sweep segment is summarised by the median of each condition channel over the segment, which
removes the noise and the once-per-revolution ripple; the medians of one set point then lie
within the drift of each other, and the set points are further apart than that.

The medians of one channel are sorted and split wherever two neighbours are further apart
than the resolution (a fraction of the value for load and pressure, an absolute step for
angles and speed): single-linkage clustering in one dimension, the 1-D case of DBSCAN with
``min_samples = 1``. It needs no number of levels and no starting guess, and one outlying
segment cannot pull two levels together (it only ever adds its own). A cluster of fewer than
``min_segments`` segments is not a level (a warm-up that looked like a sweep, a stray set-up
move) unless its one sweep held the channel: it starts and ends at the same value, within the
resolution (a set point the programme visits once, such as one sweep at a pressure of its
own; a sweep during which a set point was changed starts at one and ends at the other).
Otherwise its segments are dropped. A level's value is the sample-weighted median of its
segments' medians; ``low`` and ``high`` give the drift.
"""
from __future__ import annotations

from itertools import pairwise

import numpy as np

from identify.segment.result import Level
from identify.segment.settings import SegmentSettings

__all__ = ["MIN_SEGMENTS", "cluster", "resolution"]

#: Fewest sweep segments that make a level.
MIN_SEGMENTS = 2


def resolution(channel: str, value: float, s: SegmentSettings) -> float:
    """Largest gap between neighbouring segment medians inside one level [SI]."""
    if channel == "Fz":
        return s.resolution_Fz * abs(value)
    if channel == "p":
        return s.resolution_p * abs(value)
    if channel == "gamma":
        return np.deg2rad(s.resolution_gamma_deg)
    if channel == "alpha":
        return np.deg2rad(s.resolution_alpha_deg)
    return s.resolution_Vx


def _weighted_median(values: np.ndarray, weights: np.ndarray) -> float:
    order = np.argsort(values)
    v, w = values[order], weights[order]
    cum = np.cumsum(w)
    return float(v[np.searchsorted(cum, 0.5 * cum[-1])])


def cluster(channel: str, medians: np.ndarray, weights: np.ndarray, s: SegmentSettings,
            min_segments: int = MIN_SEGMENTS, held: np.ndarray | None = None
            ) -> tuple[tuple[Level, ...], np.ndarray]:
    """Levels of one channel from its segment medians.

    Parameters
    ----------
    channel : str
        Condition channel (``Fz``, ``p``, ``gamma``, ``Vx``, ``alpha``).
    medians : ndarray
        One median per segment [SI].
    weights : ndarray
        Samples per segment.
    s : SegmentSettings
    min_segments : int
        Fewest segments of a level.
    held : ndarray of bool, optional
        Segments that held the channel from start to end: one alone makes a level.

    Returns
    -------
    (tuple of Level, ndarray of int)
        The levels (increasing) and each segment's level index (-1: in no level).
    """
    medians = np.asarray(medians, dtype=float)
    weights = np.asarray(weights, dtype=float)
    index = np.full(medians.size, -1, dtype=int)
    if medians.size == 0:
        return (), index
    order = np.argsort(medians)
    v = medians[order]
    gaps = np.diff(v)
    limit = np.array([resolution(channel, 0.5 * (a + b), s) for a, b in pairwise(v)])
    group = np.concatenate(([0], np.cumsum(gaps > limit)))
    levels = []
    for g in np.unique(group):  # a handful of clusters
        members = order[group == g]
        if members.size < min_segments and (held is None or not held[members].all()):
            continue
        levels.append((members, _weighted_median(medians[members], weights[members])))
    out = []
    for i, (members, value) in enumerate(levels):
        index[members] = i
        out.append(Level(channel, i, value, float(medians[members].min()),
                         float(medians[members].max()), int(members.size),
                         int(weights[members].sum())))
    return tuple(out), index
