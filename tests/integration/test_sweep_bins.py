"""Sweep binning before the MF stages (identify.workflows.sweep_bins, ``mfid fit --bin-*``)."""
from __future__ import annotations

import numpy as np
import pandas as pd

from identify.fit.mf import stage_data as mf_data
from identify.io.folder import load_folder
from identify.io.trailer.files import read_trailer
from identify.segment import SegmentSettings
from identify.workflows.sweep_bins import bin_sweeps, mf_table
from tests.measurement_cases import sample_trailer_folder
from tests.ttc_cases import session

RAW = SegmentSettings()  # the segmentation's defaults: not binned
BINNED = SegmentSettings(bin_alpha_deg=0.25, bin_kappa=0.0025)


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
    assert len(lat) == 80 and list(out.columns) == [*table.columns, "segment_id"]
    # the binned rows are not in time order; their sweep is the segment label
    assert lat["segment_id"].nunique() == 1
    assert np.unique(mf_data.sweep_ids(out, 4000.0)[out["run"] == "lat"]).size == 1
    assert count.applied and count.remaining == len(out) == 85
    # 25 samples 0.01 deg apart per bin; a sample on a bin edge may fall on either side
    np.testing.assert_allclose(np.diff(np.rad2deg(lat["alpha"].to_numpy())), 0.25, atol=0.006)
    np.testing.assert_allclose(lat["Fy"].to_numpy(), 1e4 * lat["alpha"].to_numpy())
    pd.testing.assert_frame_equal(out[out["run"] == "rr"].drop(columns="segment_id")
                                  .reset_index(drop=True), free)


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


def test_logged_runs_are_fitted_on_their_quasi_steady_sweeps(tmp_path):
    s = session(tmp_path / "s", seed=5, cornering_only=True)
    table = pd.concat([read_trailer(f) for f in s.files if f.suffix == ".mat"],
                      ignore_index=True)
    fnomin = float(s.truth["tir"]["FNOMIN"])
    out, notes = mf_table(table, fnomin, segment=True, settings=RAW)
    assert len(notes) == 1 and notes[0].startswith("segment: ")
    assert list(out.columns) == [*table.columns, "segment_id"]
    assert 0.5 * len(table) < len(out) < len(table)
    # one sweep per slip-angle sweep of the programme, 3 pressures x 3 cambers x 5 loads (the
    # clusters of the covariance; their binned rows are not in time order)
    assert np.unique(mf_data.sweep_ids(out, fnomin)).size == 45
    for run in s.truth["runs"]:
        starts = np.array([g["t_start"] for g in run["segments"]])
        kinds = np.array([g["kind"] for g in run["segments"]])
        kept = out[out["run"] == run["stem"]]["t"].to_numpy()
        where = kinds[np.searchsorted(starts, kept, side="right") - 1]
        assert not np.isin(where, ["warmup", "start", "pressure_change"]).any()
    # why: the load ramps between steps bridge the load levels of the raw samples
    loads = len(s.truth["plan"]["loads_N"])
    resolution = mf_data.LOAD_RESOLUTION * fnomin
    assert mf_data.levels(table["Fz"].to_numpy(), resolution) == 1
    assert mf_data.levels(out["Fz"].to_numpy(), resolution) == loads
    binned, notes = mf_table(table, fnomin, segment=True, settings=BINNED)
    assert len(binned) < len(out) / 5 and len(notes) == 1
    # without the revolution average (mfid fit --no-revolution-average) the same sweeps are
    # kept as measured samples (more of them: the average trims a revolution at each end of
    # a stretch)
    assert "revolution average" in notes[0]
    raw, notes = mf_table(table, fnomin, segment=True,
                          settings=SegmentSettings(revolution_average=False))
    assert "revolution average" not in notes[0]
    assert np.unique(mf_data.sweep_ids(raw, fnomin)).size == 45 and len(raw) > len(out)
    assert np.isin(raw["Fz"], table["Fz"]).all()  # measured samples, not averages
    assert not np.isin(out["Fz"], table["Fz"]).any()


def test_runs_without_a_warmup_are_kept_as_they_are(tmp_path):
    mset = load_folder(sample_trailer_folder(tmp_path / "sample"))  # the sample's trailer runs
    out, notes = mf_table(mset.trailer, mset.manifest.tyre.nominal_load_N, segment=True,
                          settings=BINNED)
    assert notes == []
    pd.testing.assert_frame_equal(out.reset_index(drop=True),
                                  mset.trailer.reset_index(drop=True))


def test_bins_per_pass_keep_the_passes_operating_points_apart():
    # out and back through +-10 deg; the load follows the slip direction (+-80 N: within one
    # load level, mf_data.LOAD_RESOLUTION), as on a rig
    # whose load swings within a sweep: a merged bin averages the two passes' loads into one
    # no sample had, a bin per pass keeps each pass's
    n = 2000
    up = np.deg2rad(np.linspace(-10, 10, n, endpoint=False))
    sweep = pd.DataFrame({"run": "lat", "t": np.arange(2 * n) * 0.01, "Vx": 11.0,
                          "alpha": np.r_[up, up[::-1]], "kappa": 0.0, "gamma": 0.0, "p": 2.5e5,
                          "Fz": np.r_[np.full(n, 4080.0), np.full(n, 3920.0)], "Fy": 0.0})
    merged, _ = bin_sweeps(sweep, 4000.0, alpha_deg=0.25, kappa=0.0025)
    assert len(merged) == 80
    np.testing.assert_allclose(merged["Fz"], 4000.0, atol=1e-9)
    split, count = bin_sweeps(sweep, 4000.0, alpha_deg=0.25, kappa=0.0025, passes=True)
    # the bin the sweep turns in is the end of the first pass, its samples from both ways
    assert len(split) == 159 and count.note.endswith("per pass")
    turn = np.isclose(split["alpha"], split["alpha"].max())
    assert turn.sum() == 1 and 3920.0 < float(split.loc[turn, "Fz"].iloc[0]) < 4080.0
    # every other point is one pass's: the up-going pass at 4080 N, 79 bins each way
    assert (split["Fz"] == 4080.0).sum() == (split["Fz"] == 3920.0).sum() == 79
    np.testing.assert_allclose(np.diff(np.rad2deg(split.loc[split["Fz"] == 4080.0, "alpha"])),
                               0.25, atol=0.006)


def test_a_fit_asks_for_bins_per_pass_through_its_settings():
    from identify.fit.run import FitSettings
    from identify.workflows.sweep_bins import segment_settings
    assert segment_settings(FitSettings()).bin_passes is False  # the passes merged
    assert segment_settings(FitSettings(bin_passes=True)).bin_passes is True
