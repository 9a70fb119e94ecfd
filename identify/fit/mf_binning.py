"""Optional binning of dense trailer sweeps before the MF stages (issue 17).

A trailer logging at 100 Hz records a slip sweep as thousands of samples whose neighbours carry
the same information; averaging each sweep in bins of its swept variable (the slip angle of a
cornering sweep, the slip ratio of a drive/brake sweep) keeps the curve and divides the points,
and with them the cost of every model evaluation, by the samples per bin. Each bin's point is
the mean of its samples (every numeric column, so operating conditions and channels stay
consistent); sweeps without a slip sweep (free rolling) are left as they are.

This is the operation of ``identify.segment.filters.binning`` on the TTC import branch, for a
table that has not been segmented (mf_data.sweep_ids stands in for its segments); once that
branch is merged the workflow should bin there, before the table reaches the MF stages, and
this function can go. The effect on the coefficients is measured by bench/mf_binning.py.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from identify.fit import mf_data

__all__ = ["ALPHA_BIN_DEG", "KAPPA_BIN", "bin_sweeps"]

ALPHA_BIN_DEG = 0.25
"""[deg] default bin width of a slip-angle sweep."""
KAPPA_BIN = 0.0025
"""[-] default bin width of a slip-ratio sweep."""
GAMMA_RESOLUTION = np.deg2rad(0.1)
"""[rad] samples whose camber differs by more than this are not averaged together."""


def bin_sweeps(trailer: pd.DataFrame, fnomin: float, *, alpha_deg: float = ALPHA_BIN_DEG,
               kappa: float = KAPPA_BIN) -> pd.DataFrame:
    """The trailer table with every slip sweep averaged in bins of its swept variable.

    Parameters
    ----------
    trailer : DataFrame
        The tidy trailer table (identify.fit.mf_data); not modified.
    fnomin : float [N]
        Nominal load (the load steps that start a new sweep, mf_data.sweep_ids).
    alpha_deg : float [deg]
        Bin width of slip-angle sweeps.
    kappa : float [-]
        Bin width of slip-ratio sweeps.

    Returns
    -------
    DataFrame
        The same columns; one row per (sweep, camber level, pressure level, bin), in the order
        of the bins' first samples. A sweep is a kappa sweep when its kappa spans more than
        mf_data.SWEEP_KAPPA, else an alpha sweep when its alpha spans more than
        mf_data.SWEEP_ANGLE; other sweeps keep their samples.
    """
    sweep = mf_data.sweep_ids(trailer, fnomin)
    a = trailer["alpha"].to_numpy(float)
    k = trailer["kappa"].to_numpy(float)
    frame = pd.DataFrame({"sweep": sweep, "a": a, "k": k})
    span = frame.groupby("sweep")[["a", "k"]].agg(lambda x: float(np.nanmax(x) - np.nanmin(x)))
    is_kappa = (span["k"] > mf_data.SWEEP_KAPPA).reindex(sweep).to_numpy()
    is_alpha = ~is_kappa & (span["a"] > mf_data.SWEEP_ANGLE).reindex(sweep).to_numpy()
    with np.errstate(invalid="ignore"):
        bins = np.where(is_kappa, np.floor(k / kappa),
                        np.where(is_alpha, np.floor(a / np.deg2rad(alpha_deg)), np.nan))
    key = pd.DataFrame({
        "sweep": sweep,
        "gamma": np.round(trailer["gamma"].to_numpy(float) / GAMMA_RESOLUTION),
        "p": np.round(trailer["p"].to_numpy(float) / mf_data.PRESSURE_RESOLUTION),
        "bin": bins})
    # unbinned rows keep a key of their own (their position), so they are never merged
    solo = np.isnan(bins)
    key.loc[solo, "bin"] = -np.arange(1, int(solo.sum()) + 1, dtype=float) - 1e12
    group = key.groupby(["sweep", "gamma", "p", "bin"], sort=False).ngroup().to_numpy()
    numeric = [c for c in trailer.columns if pd.api.types.is_numeric_dtype(trailer[c])]
    others = [c for c in trailer.columns if c not in numeric]
    grouped = trailer.groupby(group, sort=False)
    out = grouped[numeric].mean()
    for c in others:
        out[c] = grouped[c].first()
    return out[list(trailer.columns)].reset_index(drop=True)
