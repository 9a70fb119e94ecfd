"""Levels of a measured condition: values that lie closer together than a gap are one level."""
from __future__ import annotations

from collections.abc import Callable

import numpy as np

__all__ = ["gap_levels"]


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
