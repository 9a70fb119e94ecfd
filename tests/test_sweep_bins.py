"""Sweep binning before the MF stages (identify.workflows.sweep_bins, ``mfid fit --bin-*``)."""
from __future__ import annotations

import numpy as np
import pandas as pd

from identify.workflows.sweep_bins import bin_sweeps


def _table(n: int = 2000) -> tuple[pd.DataFrame, pd.DataFrame]:
    alpha = np.deg2rad(np.linspace(-10, 10, n, endpoint=False))
    sweep = pd.DataFrame({"run": "lat", "t": np.arange(n) * 0.01, "Vx": 11.0, "alpha": alpha,
                          "kappa": 0.0, "gamma": 0.0, "p": 2.5e5, "Fz": 4000.0,
                          "Fy": 1e4 * alpha})
    free = pd.DataFrame({"run": "rr", "t": np.arange(5) * 0.01, "Vx": [5.0, 10, 15, 20, 25],
                         "alpha": 0.0, "kappa": 0.0, "gamma": 0.0, "p": 2.5e5, "Fz": 4000.0,
                         "Fy": 0.0})
    return sweep, free


def test_each_bin_is_the_mean_of_its_samples_and_free_rolling_is_kept():
    sweep, free = _table()
    table = pd.concat([sweep, free], ignore_index=True)
    out, count = bin_sweeps(table, 4000.0, alpha_deg=0.25, kappa=0.0025)
    lat = out[out["run"] == "lat"]
    assert len(lat) == 80 and list(out.columns) == list(table.columns)
    assert count.applied and count.remaining == len(out) == 85
    # 25 samples 0.01 deg apart per bin; a sample on a bin edge may fall on either side
    np.testing.assert_allclose(np.diff(np.rad2deg(lat["alpha"].to_numpy())), 0.25, atol=0.006)
    np.testing.assert_allclose(lat["Fy"].to_numpy(), 1e4 * lat["alpha"].to_numpy())
    pd.testing.assert_frame_equal(out[out["run"] == "rr"].reset_index(drop=True), free)


def test_sparse_sweeps_and_switched_off_binning_keep_every_sample():
    sweep, _ = _table(40)  # 0.5 deg apart: one sample per 0.25 deg bin
    out, count = bin_sweeps(sweep, 4000.0, alpha_deg=0.25, kappa=0.0025)
    pd.testing.assert_frame_equal(out.reset_index(drop=True), sweep)
    dense, _ = _table()
    out, count = bin_sweeps(dense, 4000.0, alpha_deg=None, kappa=None)
    assert out is dense and not count.applied


def test_camber_and_pressure_levels_are_not_averaged_together():
    sweep, _ = _table()
    other = sweep.assign(gamma=np.deg2rad(2.0), t=sweep["t"] + 20.0)
    higher = sweep.assign(p=2.9e5, t=sweep["t"] + 40.0)
    out, _ = bin_sweeps(pd.concat([sweep, other, higher], ignore_index=True), 4000.0,
                        alpha_deg=0.25, kappa=0.0025)
    assert len(out) == 240
    assert sorted(np.unique(np.round(np.rad2deg(out["gamma"]), 9))) == [0.0, 2.0]
    assert sorted(out["p"].unique()) == [2.5e5, 2.9e5]
