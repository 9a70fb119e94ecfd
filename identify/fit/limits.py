"""Validity limits of a fitted .tir from the ranges the fits actually saw.

A Magic Formula file states where it is valid (FZMIN/FZMAX, PRESMIN/PRESMAX, KPUMIN/KPUMAX,
ALPMIN/ALPMAX, CAMMIN/CAMMAX); a vehicle model that honours them clips or warns outside. Generic
limits (10 kN, 10 bar, +-1.5 rad) claim a validity the data never showed, so mfid writes the
measured ranges of every data point a fit used (the rows of measured_vs_model.csv); a quantity
no fitted point varied keeps its default, and the caller marks it so.
"""
from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import pandas as pd

__all__ = ["LIMIT_COLUMNS", "TABLE_LIMIT_COLUMNS", "measured_limits", "table_limits",
           "union_limits"]

LIMIT_COLUMNS: dict[tuple[str, str], tuple[str, float]] = {
    ("FZMIN", "FZMAX"): ("Fz_N", 1.0),
    ("PRESMIN", "PRESMAX"): ("pi_bar", 1e5),
    ("KPUMIN", "KPUMAX"): ("kappa", 1.0),
    ("ALPMIN", "ALPMAX"): ("alpha_rad", 1.0),
    ("CAMMIN", "CAMMAX"): ("gamma_deg", math.pi / 180.0),
}
"""(.tir min key, max key) -> (points column, factor to SI)."""

TABLE_LIMIT_COLUMNS: dict[tuple[str, str], str] = {
    ("FZMIN", "FZMAX"): "Fz",
    ("KPUMIN", "KPUMAX"): "kappa",
    ("ALPMIN", "ALPMAX"): "alpha",
    ("CAMMIN", "CAMMAX"): "gamma",
}
"""(.tir min key, max key) -> column of a trailer table in SI (Fz [N], kappa [-], alpha [rad],
gamma [rad]): the axes of the MF validity grid (identify.fit.mf.constraints.validity_grid, which
takes the data's pressures themselves)."""


def _span(v: np.ndarray, load: bool) -> tuple[float, float] | None:
    """(min, max) of the finite values of ``v`` (of the positive ones for a ``load``), or None
    when they hold fewer than two distinct values."""
    v = v[np.isfinite(v)]
    if load:
        v = v[v > 0]
    if v.size < 2 or v.min() == v.max():
        return None
    return float(v.min()), float(v.max())


def measured_limits(points: pd.DataFrame) -> dict[str, float]:
    """The .tir validity limits [SI] spanned by ``points`` (columns as measured_vs_model.csv).

    Parameters
    ----------
    points : DataFrame
        One row per fitted data point, with some of the columns ``Fz_N`` [N], ``pi_bar`` [bar],
        ``kappa`` [-], ``alpha_rad`` [rad], ``gamma_deg`` [deg]; NaN where a column does not
        apply to a point.

    Returns
    -------
    dict
        Key -> value for every pair whose column holds a real range (two distinct finite
        values); a pair with one value (a single pressure) or none is left out.
    """
    out: dict[str, float] = {}
    for (lo_key, hi_key), (column, factor) in LIMIT_COLUMNS.items():
        if column not in points:
            continue
        span = _span(pd.to_numeric(points[column], errors="coerce").to_numpy(float),
                     load=column == "Fz_N")
        if span is not None:
            out[lo_key], out[hi_key] = span[0] * factor, span[1] * factor
    return out


def table_limits(table: pd.DataFrame) -> dict[str, float]:
    """The .tir validity limits [SI] spanned by a trailer table (columns of
    :data:`TABLE_LIMIT_COLUMNS`), by the rule of :func:`measured_limits`: a pair whose column
    is absent or holds fewer than two distinct finite values (loads: positive ones) is left
    out.

    The MF stages take them as the limits of their validity grid
    (identify.fit.mf.stages.fit_mf). The written .tir states the ranges of every fitted point
    (:func:`measured_limits`): where other relations' points reach further (the bundled
    sample's Flatplank characteristics: FZMIN 1000 N for the trailer's 3000 N, CAMMIN/CAMMAX
    +-15 deg for +-8 deg), ``mfid fit`` widens the grid to the :func:`union_limits` of both, so
    that the validity conditions hold wherever the file claims validity.
    """
    out: dict[str, float] = {}
    for (lo_key, hi_key), column in TABLE_LIMIT_COLUMNS.items():
        if column not in table:
            continue
        span = _span(pd.to_numeric(table[column], errors="coerce").to_numpy(float),
                     load=column == "Fz")
        if span is not None:
            out[lo_key], out[hi_key] = span
    return out


def union_limits(*spans: Mapping[str, float]) -> dict[str, float]:
    """The smallest limits [SI] that contain every one of ``spans`` (dicts as returned by
    :func:`table_limits` and :func:`measured_limits`): per (min, max) pair the least minimum
    and the largest maximum over the spans that hold the pair; a pair none holds is left out."""
    out: dict[str, float] = {}
    for lo_key, hi_key in LIMIT_COLUMNS:
        held = [s for s in spans if lo_key in s and hi_key in s]
        if held:
            out[lo_key] = min(float(s[lo_key]) for s in held)
            out[hi_key] = max(float(s[hi_key]) for s in held)
    return out
