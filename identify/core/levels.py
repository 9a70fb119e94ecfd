"""Levels of a measured condition: the values it was held at, and each sample's level."""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["dense_levels", "gap_levels", "nearest_level"]


def gap_levels(values: np.ndarray, gap: float,
               centre: Callable[[np.ndarray], float] = np.mean) -> np.ndarray:
    """Each value's level: the sorted values split wherever two neighbours are more than
    ``gap`` apart, each level's value the ``centre`` (mean by default, or np.median) of its
    members; NaN stays NaN.

    Parameters
    ----------
    values : ndarray
        The condition per sample (any unit; ``gap`` in the same).
    gap : float
        Neighbours further apart than this start a new level.
    centre : callable
        The level's value from its members.
    """
    values = np.asarray(values, dtype=float)
    out = np.full(values.shape, np.nan)
    ok = np.isfinite(values)
    if not ok.any():
        return out
    order = np.argsort(values[ok])
    v = values[ok][order]
    starts = np.r_[0, np.flatnonzero(np.diff(v) > gap) + 1]
    level = np.empty_like(v)
    for a, b in zip(starts, np.r_[starts[1:], v.size]):
        level[a:b] = centre(v[a:b])
    tmp = np.empty_like(v)
    tmp[order] = level
    out[ok] = tmp
    return out


def dense_levels(values: np.ndarray, gap: float, share: float = 0.02,
                 dense: float = 0.005) -> list[float]:
    """The levels a logged condition was held at: in a histogram of bins ``gap``/2 wide, each
    run of bins holding at least ``dense`` of the samples is a level (its median) when it holds
    at least ``share`` of them. A condition changed slowly between two levels (a pressure ramp,
    a tyre warming) leaves sparse bins between them, which split the levels, where a split at
    gaps between the sorted values (:func:`gap_levels`) would chain them into one.

    Parameters
    ----------
    values : ndarray
        The condition per sample (NaN ignored; ``gap`` in its unit).
    gap : float
        Twice the histogram's bin width.
    share, dense : float
        Fractions of the finite samples (see above).

    Returns
    -------
    list of float
        The levels, increasing (empty without a finite value).
    """
    x = np.sort(np.asarray(values, float)[np.isfinite(values)])
    if x.size == 0:
        return []
    width = gap / 2
    edges = x[0] + width * np.arange(int((x[-1] - x[0]) // width) + 2)
    counts, _ = np.histogram(x, bins=edges)
    full = np.r_[False, counts >= dense * x.size, False]
    starts = np.flatnonzero(~full[:-1] & full[1:])  # first dense bin of each run
    stops = np.flatnonzero(full[:-1] & ~full[1:])  # one past its last
    levels = []
    for a, b in zip(starts, stops):
        sel = x[(x >= edges[a]) & (x <= edges[b])]
        if sel.size >= share * x.size:
            levels.append(float(np.median(sel)))
    return levels


def nearest_level(values: np.ndarray, levels) -> np.ndarray:
    """Index of the level nearest to each value (-1 where the value is not finite or there is
    no level)."""
    v = np.asarray(values, float)
    lv = np.asarray(levels, float)
    out = np.full(v.shape, -1, dtype=int)
    ok = np.isfinite(v)
    if lv.size:
        out[ok] = np.argmin(np.abs(v[ok, None] - lv[None, :]), axis=1)
    return out
