"""The pure parts of bench/realdata.py, the real-data judge: its error metric, its held-out
splits and its verdict, on hand-made numbers and on a small simulated TTC session."""
from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from tests.bench_modules import load_bench

R = load_bench("realdata")


def test_rms_and_thesis_metric_closed_form():
    measured = np.array([1.0, -1.0, 2.0, -2.0])
    model = np.array([1.1, -0.9, 2.0, -2.0])
    # pooled: sqrt((0.01 + 0.01) / 10)
    assert R.rms_pct(measured, model) == pytest.approx(100 * math.sqrt(0.02 / 10))
    groups = np.array([0, 0, 1, 1])
    e = R.channel_error(measured, model, groups)
    # per group: sqrt(0.02 / 2) = 10 % and 0 %; the thesis metric is their plain mean
    assert e.thesis_pct == pytest.approx(5.0)
    assert e.pooled_pct == pytest.approx(100 * math.sqrt(0.002))
    assert e.n == 4
    assert math.isnan(R.rms_pct(np.zeros(3), np.ones(3)))  # no measured signal: no ratio


def test_pressure_folds_partition_the_samples_by_nearest_level():
    p = np.array([55e3, 56e3, 70e3, 82e3, 84e3, np.nan])
    folds = R.pressure_folds(p, [55.5e3, 83e3])
    assert [f.name for f in folds] == ["p 56 kPa", "p 83 kPa"]
    held = np.vstack([f.rows for f in folds])
    # every finite sample held out exactly once, the transition sample at its nearest level
    assert held.sum(axis=0).tolist() == [1, 1, 1, 1, 1, 0]
    assert folds[1].rows.tolist() == [False, False, True, True, True, False]


def test_a_pressure_fold_is_judged_where_the_other_pressures_show_a_trend():
    # rows 0-3 at level 1 (held out): cornering at camber 0 and 4 deg, at 1 kN and 2 kN, and
    # a drive/brake row; rows 4-8 at levels 0 and 2: cornering at camber 0 and 1 kN at both,
    # at 2 kN at level 2 only, and drive/brake at level 0 only
    deg = np.radians
    table = pd.DataFrame({
        "gamma": deg([0.0, 4.0, 0.2, 0.0, 0.1, -0.2, 0.0, 0.0, 0.0]),
        "Fz": [1000.0, 1000.0, 2050.0, 1000.0, 1020.0, 990.0, 1980.0, 1010.0, 1000.0],
        "kappa": [0.0, 0.0, 0.0, 0.1, 0.0, 0.0, 0.0, -0.1, 0.0],
        "alpha": deg([5.0, 5.0, -6.0, 0.0, 4.0, 3.0, -5.0, 0.0, 0.0]),
    })
    level = np.array([1, 1, 1, 1, 0, 2, 2, 0, 0])
    held = level == 1
    ok = np.ones(9, bool)
    cells = R.condition_cells(table)
    assert cells[0] == cells[4] == cells[5] and cells[2] == cells[6] and cells[3] == cells[7]
    assert len({cells[0], cells[1], cells[2], cells[3]}) == 4
    # judged: camber 0 at 1 kN, which levels 0 and 2 both hold; not judged: the camber no
    # other level saw, the 2 kN cornering and the drive/brake run seen at one level only
    assert R.covered(cells, held, ok, level).tolist() == [True] + [False] * 8
    assert R.covered(cells, held, ok, level, min_levels=1).tolist() == \
        [True, False, True, True] + [False] * 5
    # a sample left out of the evaluation (ok False) does not cover a cell either
    ok[5] = False
    assert not R.covered(cells, held, ok, level).any()


def test_pressure_levels_split_at_a_slow_pressure_change():
    rng = np.random.default_rng(0)
    p = np.r_[55e3 + 300 * rng.standard_normal(500), 83e3 + 300 * rng.standard_normal(500),
              np.linspace(56e3, 82e3, 5)]  # a few samples of the pressure change
    levels = R.pressure_levels(p)
    assert len(levels) == 2
    assert levels[0] == pytest.approx(55e3, abs=100) and levels[1] == pytest.approx(83e3, abs=100)
    # a ramp between the levels with no step above the gap (the sorted values chain) still
    # leaves two levels; a level of fewer than 2 % of the samples is none
    ramp = np.r_[p[:1000], np.linspace(55.5e3, 82.5e3, 20)]
    assert np.max(np.diff(np.sort(ramp))) < R.PRESSURE_GAP
    assert len(R.pressure_levels(ramp)) == 2
    assert len(R.pressure_levels(np.r_[ramp, np.full(15, 110e3)])) == 2
    assert R.pressure_levels(np.full(10, 8e4)) == [8e4]


def test_sweep_folds_deal_every_sweep_once_and_are_seeded():
    sweep_of_row = np.repeat(np.arange(-1, 7), 3)  # rows of no sweep (-1), then sweeps 0..6
    folds = R.sweep_folds(sweep_of_row, 3, seed=4)
    assert len(folds) == 3
    held = np.vstack([f.rows for f in folds])
    assert held.sum(axis=0).tolist() == [0] * 3 + [1] * 21
    again = R.sweep_folds(sweep_of_row, 3, seed=4)
    assert [f.name for f in again] == [f.name for f in folds]
    assert [f.name for f in R.sweep_folds(sweep_of_row, 3, seed=5)] != [f.name for f in folds]
    assert R.sweep_folds(np.zeros(5, int), 3, seed=0) == []  # one sweep: nothing to hold out


def test_verdict_ties_within_five_percent():
    held = {"default": {"Fx": 10.0, "Fy": 5.2, "Mz": 20.0, "Mx": math.nan},
            "no-segment": {"Fx": 9.6, "Fy": 4.0, "Mz": 21.0, "Mx": 30.0}}
    v = R.verdict(held)
    assert v["Fx"]["ok"] and v["Fx"]["best"] == "no-segment"  # 10 / 9.6 = 1.04
    assert not v["Fy"]["ok"] and v["Fy"]["ratio"] == pytest.approx(1.3)
    assert v["Mz"]["ok"] and v["Mz"]["best"] == "default"
    assert "Mx" not in v  # no default error to judge


def test_a_fold_excites_a_channel_from_a_quarter_of_its_rms():
    """Fx of a set of one braking run (+-1000 N) and one cornering run (+-20 N): the braking
    fold holds 1.41 of the set's RMS, the cornering fold 0.028 of it, not excited; a
    channel without finite values or all zero has no share."""
    fx = np.r_[np.tile([1000.0, -1000.0], 50), np.tile([20.0, -20.0], 50)]
    every = np.ones(fx.size, bool)
    braking = np.arange(fx.size) < 100
    whole = math.sqrt((1000 ** 2 + 20 ** 2) / 2)
    assert R.excitation(fx, braking, every) == pytest.approx(1000 / whole, rel=1e-12)
    share = R.excitation(fx, ~braking, every)
    assert share == pytest.approx(20 / whole, rel=1e-12)
    assert R.excited(R.excitation(fx, braking, every)) and not R.excited(share)
    assert R.excited(0.25) and not R.excited(0.2499)
    assert math.isnan(R.excitation(np.zeros(4), every[:4], every[:4]))
    assert not R.excited(math.nan)


def test_a_channel_no_fold_excites_has_no_verdict():
    held = {"default": {"Fx": 175.7, "Fy": 8.77}, "no-segment": {"Fx": 92.1, "Fy": 9.27}}
    v = R.verdict(held, not_excited=["Fx"])
    assert v["Fx"] == {"not_excited": True} and v["Fy"]["ok"]
    assert not R.verdict(held)["Fx"]["ok"]  # judged, the ratio of two noise levels fails


def test_held_out_means_take_only_the_folds_that_excite_the_channel():
    """Two folds: Fx excited on the first only; its mean and pooled error are the first
    fold's, Fy's the mean of both."""
    n = 4
    inputs = pd.DataFrame({"Fx": [100.0, -100.0, 1.0, -1.0], "Fy": [50.0, -50.0, 50.0, -50.0]})
    a, b = np.array([1, 1, 0, 0], bool), np.array([0, 0, 1, 1], bool)
    pred = {"Fx": inputs["Fx"].to_numpy() * 1.1, "Fy": inputs["Fy"].to_numpy() * 1.2}
    folds = [{"fold": "A", "heldout": {"Fx": 10.0, "Fy": 20.0}, "insample": {"Fx": 9.0},
              "_pred": pred, "_rows": a},
             {"fold": "B", "heldout": {"Fx": 10.0 * 100, "Fy": 20.0}, "insample": {"Fx": 9.0},
              "_pred": pred, "_rows": b}]
    judged = {"A": {"Fx": True, "Fy": True}, "B": {"Fx": False, "Fy": True}}
    agg = R._aggregate(inputs.iloc[:n], folds, judged)
    assert agg["mean_pct"] == {"Fx": 10.0, "Fy": 20.0}
    assert agg["pooled_pct"]["Fx"] == pytest.approx(10.0, rel=1e-12)
    assert agg["pooled_pct"]["Fy"] == pytest.approx(20.0, rel=1e-12)


def test_left_out_counts_segments_by_kind_and_filters():
    seg = {"segments": [{"kind": "sweep", "start": 0, "stop": 10},
                        {"kind": "transition", "start": 10, "stop": 14},
                        {"kind": "warmup", "start": 14, "stop": 40},
                        {"kind": "transition", "start": 40, "stop": 41}],
           "filters": [{"name": "low speed", "removed": 3}, {"name": "cold tread", "removed": 0}]}
    assert R.left_out(seg) == [("warmup", 1, 26), ("transition", 2, 5),
                               ("filter: low speed", -1, 3)]
    assert R.left_out(None) == []


@pytest.fixture(scope="module")
def simulated(tmp_path_factory):
    """A simulated TTC cornering session, imported and loaded, with its segmentation."""
    from identify.io.folder import load_folder
    from identify.io.tir import read_tir
    from identify.segment import segment_trailer
    from identify.simulate import default_tir_path
    from identify.simulate.ttc import simulate_ttc
    from identify.workflows.import_session import import_session

    root = tmp_path_factory.mktemp("ttc")
    simulate_ttc(read_tir(default_tir_path()).params(), root / "raw", seed=1,
                 cornering_only=True)
    import_session(sorted((root / "raw").glob("*.mat")), root / "set")
    table = load_folder(root / "set").trailer.reset_index(drop=True)
    return table, segment_trailer(table).segmentation


def test_sweep_rows_map_the_segments_onto_the_loaded_table(simulated):
    table, seg = simulated
    segments = [s.to_dict() for s in seg.segments]
    rows = R.sweep_rows(table, segments)
    sweeps = [s for s in seg.segments if s.kind == "sweep"]
    assert rows.max() == len(sweeps) - 1
    for k, s in enumerate(sweeps):
        at = rows == k
        assert at.sum() == s.stop - s.start
        # the rows labelled are the segment's: their medians are the ones it recorded
        for c in ("Fz", "p"):
            assert np.median(table.loc[at, c]) == pytest.approx(s.medians[c], rel=1e-9)


def test_the_simulated_session_splits_into_one_fold_per_pressure(simulated):
    table, seg = simulated
    levels = seg.level_values("p")
    assert len(levels) >= 2
    folds = R.pressure_folds(table["p"].to_numpy(float), levels)
    assert len(folds) == len(levels)
    held = np.vstack([f.rows for f in folds]).sum(axis=0)
    assert np.all(held == 1)
    for f, level in zip(folds, levels):
        assert np.median(table.loc[f.rows, "p"]) == pytest.approx(level, rel=0.02)


def test_mx_is_split_into_the_freely_rolling_runs_and_the_others():
    # run "c" sweeps alpha and rolls freely; run "d" sweeps kappa (a drive/brake run)
    n = 10
    table = pd.DataFrame({
        "run": ["c"] * n + ["d"] * n,
        "alpha": np.r_[np.linspace(-0.1, 0.1, n), np.zeros(n)],
        "kappa": np.r_[np.zeros(n), np.linspace(-0.2, 0.2, n)],
        "gamma": np.zeros(2 * n),
        "Mx": np.r_[np.full(n, 10.0), np.full(n, 2.0)]})
    model = {"Mx": np.r_[np.full(n, 11.0), np.full(n, 0.0)]}  # 10 % and 100 % off
    ok = np.ones(2 * n, bool)
    out = R.mx_by_run_kind(table, {"default": model}, np.zeros(2 * n), ok)["default"]
    assert out["rolling"]["pooled_pct"] == pytest.approx(10.0)
    assert out["other"]["pooled_pct"] == pytest.approx(100.0)
    # squared errors 1 per rolling sample, 4 per drive/brake sample: 40 of 50
    assert out["other_sse_share_pct"] == pytest.approx(80.0)
    # one kind of run only: nothing to split
    assert R.mx_by_run_kind(table[:n], {"default": {"Mx": model["Mx"][:n]}}, np.zeros(n),
                            ok[:n]) == {}
