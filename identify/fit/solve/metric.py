"""The thesis error metric (docs/relations.md) and its pooled variant.

For one characteristic A and one inflation pressure, over its N points::

    eps_A = 100 * sqrt( sum_i (A_model,i - A_meas,i)^2 / sum_i A_meas,i^2 )   [%]

The total is the plain mean of the per-pressure errors.
"""
from __future__ import annotations

import numpy as np


def thesis_error(model: np.ndarray, measured: np.ndarray) -> float:
    """Thesis error [%] of one group of points (pooled variant when given all points)."""
    model = np.asarray(model, dtype=float)
    measured = np.asarray(measured, dtype=float)
    den = np.sum(measured ** 2)
    if den == 0:
        return float("inf") if np.any(model != measured) else 0.0
    return float(100.0 * np.sqrt(np.sum((model - measured) ** 2) / den))


def thesis_error_by_group(model: np.ndarray, measured: np.ndarray,
                          groups: np.ndarray) -> dict[float, float]:
    """Thesis error [%] per group (per inflation pressure, keyed by the group value)."""
    groups = np.asarray(groups)
    return {float(g): thesis_error(np.asarray(model)[groups == g],
                                   np.asarray(measured)[groups == g])
            for g in np.unique(groups)}


def thesis_total(model: np.ndarray, measured: np.ndarray, groups: np.ndarray) -> float:
    """Total thesis error [%]: the plain mean of the per-pressure errors."""
    by_group = thesis_error_by_group(model, measured, groups)
    return float(np.mean(list(by_group.values())))


def group_weights(measured: np.ndarray, groups: np.ndarray) -> np.ndarray:
    """Per-point weights w_i = 1/sqrt(sum_group A_meas^2), so that the sum of squared weighted
    residuals is the sum over pressures of the squared per-pressure errors (/100^2): the
    least-squares companion of the thesis metric."""
    measured = np.asarray(measured, dtype=float)
    groups = np.asarray(groups)
    w = np.empty_like(measured)
    for g in np.unique(groups):
        sel = groups == g
        w[sel] = 1.0 / np.sqrt(np.sum(measured[sel] ** 2))
    return w
