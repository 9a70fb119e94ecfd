"""Segmentation of trailer data (identify.segment) on simulated TTC sessions.

The acceptance (tests/segment_cases.py): the load, pressure, camber, speed and set-slip-angle
levels found equal the set points, all of them and none extra; every programmed sweep is found
once at its levels; no warm-up and no cold-tread sample is kept. Two seeds here, twenty in
tests/trials/test_segment_trials.py.
"""
from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest

from identify.segment import Segmentation, SegmentSettings, segment_trailer
from identify.segment.filters import revolution_average, sweep_passes
from tests.segment_cases import check, segmented
from tests.ttc_cases import session


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    return {seed: session(tmp_path_factory.mktemp("seg") / f"s{seed}", seed=seed)
            for seed in (11, 12)}


@pytest.fixture(scope="module")
def segmentations(sessions):
    """seed -> (segmented table, loaded table) with the default settings, once per module
    (segment_trailer leaves its input table as it was: the tests below segment it again with
    other settings)."""
    return {seed: segmented(s) for seed, s in sessions.items()}


@pytest.mark.parametrize("seed", [11, 12])
def test_levels_are_the_set_points_and_warmups_are_dropped(sessions, segmentations, seed):
    result = check(sessions[seed], segmentations[seed][0])
    seg = result.segmentation
    counts = seg.counts()
    assert counts["sweep"] == 45 + 90 and counts["warmup"] >= 4
    names = [f.name for f in seg.filters]
    assert names == ["revolution average", "set slip angle", "cold tread", "low speed",
                     "binning"]
    assert seg.kept == len(result.table) == seg.in_sweeps - sum(f.removed for f in seg.filters)
    assert seg.kept == sum(s.kept for s in seg.segments)


def test_segmentation_round_trips_through_json(segmentations):
    result, _ = segmentations[11]
    seg = result.segmentation
    back = Segmentation.from_dict(json.loads(json.dumps(seg.to_dict())))
    assert back.to_dict() == seg.to_dict()
    assert back.levels["Fz"][0] == seg.levels["Fz"][0]


def test_revolution_average_removes_the_eccentricity_ripple(tmp_path):
    s = session(tmp_path / "clean", seed=3, noise=0.0, cornering_only=True)
    on, table = segmented(s)
    off = segment_trailer(table, SegmentSettings(revolution_average=False))

    def ripple(result):  # sample-to-sample change of Fz / its level: the 7 Hz ripple's
        t = result.table  # (the slow drift and the sweep hardly change in 0.01 s)
        step = t.groupby("segment")["Fz"].diff() / t["Fz_level"]
        return float(np.std(step.dropna()))

    assert ripple(off) > 0.0015  # 0.8 % once per revolution: 0.8 % * 2 pi / 18 / sqrt(2)
    assert ripple(on) < 0.1 * ripple(off)
    removed = {f.name: f for f in on.segmentation.filters}["revolution average"]
    # one revolution (18-20 samples at 40 km/h) at both ends of each of the 45 sweeps, and on
    # both sides of each gap in the log within a sweep (the generator's time gap and two NaN
    # stretches, rows the loader drops: at most 3)
    assert removed.applied and 2 * 18 * 45 <= removed.removed <= 2 * 20 * (45 + 3)


def _ripple_sweep(speed_factor):
    """A drive/brake sweep of 0.125/s at 100 Hz through the peak of
    Fx = 3000 sin(1.6 atan(15 kappa)) N, a 24 N ripple once per wheel revolution (18.7
    samples at kappa = 0), the wheel speed ``speed_factor(kappa)`` times its free-rolling one."""
    t = np.arange(0.0, 3.2, 0.01)
    kappa = -0.2 + 0.125 * t
    omega = 2 * np.pi / 0.187 * speed_factor(kappa)
    theta = np.concatenate(([0.0], np.cumsum(0.5 * (omega[1:] + omega[:-1]) * 0.01)))

    def fx(k):
        return 3000.0 * np.sin(1.6 * np.arctan(15.0 * k))

    ripple = 24.0 * np.cos(theta + 0.3)
    frame = pd.DataFrame({"t": t, "kappa": kappa, "Fx": fx(kappa) + ripple, "omega": omega,
                          "Vx": 11.1, "segment": 0})
    return frame, fx, ripple


def test_revolution_average_leaves_a_fast_curved_sweep_in_place():
    """At a constant wheel speed: a plain one-revolution moving average (19 samples) is
    29.7 N off the curve near the peak (T^2/24 f''); the twiced mean over the wheel's angle
    1.6 N (the fourth-order term), and it lets 0.003 N of the 24 N ripple alone through."""
    frame, fx, ripple = _ripple_sweep(lambda k: np.ones_like(k))
    out, count = revolution_average(frame, SegmentSettings())
    assert count.removed == 40 and "wheel speed" in count.note  # a revolution at each end
    assert np.abs(out["Fx"] - fx(out["kappa"])).max() < 2.0
    plain = frame[["kappa", "Fx"]].rolling(19, center=True).mean().dropna()
    assert np.abs(plain["Fx"] - fx(plain["kappa"])).max() > 25.0
    alone, _ = revolution_average(frame.assign(Fx=ripple), SegmentSettings())
    assert np.abs(alone["Fx"]).max() < 0.05


def test_revolution_average_follows_the_wheel_speed_along_a_slip_sweep():
    """The wheel turns (1 + kappa) times as fast as when free rolling: +-20 % over the sweep.
    A window of one length in time (the median revolution, twiced) lets 8.5 N of the 24 N
    ripple through at the ends of the sweep; the mean over the wheel's angle 0.007 N."""
    frame, _, ripple = _ripple_sweep(lambda k: 1.0 + k)
    alone, _ = revolution_average(frame.assign(Fx=ripple), SegmentSettings())
    assert np.abs(alone["Fx"]).max() < 0.05
    fixed, _ = revolution_average(frame.assign(Fx=ripple, omega=frame["omega"].median()),
                                  SegmentSettings())  # one window length in time
    assert np.abs(fixed["Fx"]).max() > 5.0


def test_binning_gives_one_point_per_bin_and_sweep(segmentations):
    _, table = segmentations[12]
    binned = segment_trailer(table, SegmentSettings(bin_alpha_deg=0.5, bin_kappa=0.005))
    t = binned.table
    count = {f.name: f for f in binned.segmentation.filters}["binning"]
    assert count.applied and count.removed > 0.9 * (count.removed + count.remaining)
    a = t[t.sweep == "alpha"]
    bins = np.floor(a["alpha"] / np.deg2rad(0.5))
    assert not bins.groupby(a["segment"]).apply(lambda b: b.duplicated().any()).any()
    assert a.groupby("segment").size().between(40, 52).all()  # +-12 deg in 0.5 deg bins


def test_binning_per_pass_gives_one_point_per_bin_and_pass(segmentations):
    _, table = segmentations[12]
    binned = segment_trailer(table, SegmentSettings(bin_alpha_deg=0.5, bin_kappa=0.005,
                                                    bin_passes=True))
    t = binned.table
    count = {f.name: f for f in binned.segmentation.filters}["binning"]
    assert count.applied and count.removed > 0.8 * (count.removed + count.remaining)
    a = t[t.sweep == "alpha"].sort_values(["segment", "t"])
    bins = np.floor(a["alpha"] / np.deg2rad(0.5)).to_numpy()
    same = a["segment"].to_numpy()[1:] == a["segment"].to_numpy()[:-1]
    # in time order a sweep's points step from bin to bin, a bin one point per pass; only at
    # a turn may the extreme bin be seen twice in a row (the last pass's, and the next's
    # where the sweep came back to it after a step back of less than PASS_TURN bins)
    repeats = pd.Series((np.diff(bins) == 0) & same).groupby(a["segment"].to_numpy()[1:]).sum()
    assert repeats.max() <= 2
    # 0 -> +12 -> -12 -> 0 deg: three passes crossing 24 + 48 + 24 bins of 0.5 deg (a partial
    # sweep fewer), not the 48 of merged passes
    assert a.groupby("segment").size().between(76, 100).all()
    assert a.groupby("segment").size().median() > 90


def test_sweep_passes_split_a_sweep_where_it_turns_back():
    up, down = np.arange(10.0), np.arange(9.0, -1.0, -1.0)
    passes = sweep_passes(np.r_[up, down, up[1:5]])
    # the extreme bin's samples end the pass; the samples after them start the next
    np.testing.assert_array_equal(passes, np.r_[np.zeros(11), np.ones(9), np.full(4, 2)])
    # a turn of one bin (jitter at a bin edge) is no pass; one of PASS_TURN bins is
    jitter = np.array([0.0, 1, 0, 1, 2, 3, 2, 3, 4])
    assert (sweep_passes(jitter) == 0).all()
    assert sweep_passes(np.array([0.0, 1, 2, 3, 1])).tolist() == [0, 0, 0, 0, 1]
    assert sweep_passes(np.zeros(0)).size == 0


def test_revolution_average_fits_each_speed_step():
    """Two sweeps of one table at 40 and 72 km/h (wheel speeds 34 and 61 rad/s): the mean
    over the wheel's angle removes the 24 N ripple from both; one window sized by the table's
    median wheel speed cannot fit both (its leak: over 5 N)."""
    parts = []
    for seg, omega in enumerate((34.0, 61.0)):
        t = np.arange(0.0, 3.0, 0.01)
        parts.append(pd.DataFrame({"t": t + 10 * seg, "Fx": 24.0 * np.cos(omega * t + 0.3),
                                   "omega": omega, "Vx": omega * 0.33, "segment": seg}))
    frame = pd.concat(parts, ignore_index=True)
    out, count = revolution_average(frame, SegmentSettings())
    assert set(out["segment"]) == {0, 1} and np.abs(out["Fx"]).max() < 0.05
    one, _ = revolution_average(frame.assign(omega=frame["omega"].median()), SegmentSettings())
    assert np.abs(one["Fx"]).max() > 5.0


def test_revolution_average_drops_a_repeated_time_stamp_not_the_sweep():
    """A logger that writes a time stamp twice (seen in a real TTC session): that sample is
    dropped, the rest of the sweep is filtered as before."""
    frame, fx, _ = _ripple_sweep(lambda k: np.ones_like(k))
    dup = frame.copy()
    dup.loc[150, "t"] = dup.loc[149, "t"]
    out, count = revolution_average(dup, SegmentSettings())
    assert count.removed == 41 and 150 not in out.index
    assert np.abs(out["Fx"] - fx(out["kappa"])).max() < 2.5


def test_revolution_average_keeps_a_nan_sample_local():
    """An optional channel with a spike set NaN at load (identify.io.trailer.quirks) keeps its value
    on the rest of the sweep: the NaN leaves the revolutions around it with the pieces that
    remain (a constant stays exact), and only where less than half a revolution is measured
    is the mean NaN. A running sum carried the NaN to every later sample of the segment."""
    frame, _, _ = _ripple_sweep(lambda k: np.ones_like(k))
    my = np.full(len(frame), 50.0)
    my[100] = np.nan  # one spike
    my[200:215] = np.nan  # a dropout of 15 samples: most of a revolution
    out, _ = revolution_average(frame.assign(My=my), SegmentSettings())
    at = out.index.to_numpy()
    near = (np.abs(at - 207) < 20)
    np.testing.assert_allclose(out["My"].to_numpy()[~near], 50.0, rtol=1e-12)
    assert np.isnan(out["My"].to_numpy()[near]).any() and np.isfinite(out["My"][at > 240]).all()


def test_revolution_average_fills_a_single_nan_on_a_steep_sweep():
    """A NaN on the steep part of a fast drive/brake sweep (90 N a sample; the loader drops
    the row for Fx, but an optional channel that follows the sweep, such as My, keeps its NaN
    and meets the same mechanism, shown here on Fx): left out of the revolution's integral
    it moved the centre of the average by up to half a sample and put the twiced mean up to
    140 N off the curve; filled linearly in the wheel's angle it stays within the 2 N of the
    clean sweep."""
    frame, fx, _ = _ripple_sweep(lambda k: np.ones_like(k))
    spiked = frame.copy()
    spiked.loc[150, "Fx"] = np.nan
    out, count = revolution_average(spiked, SegmentSettings())
    assert count.removed == 40 and np.isfinite(out.loc[150, "Fx"])
    assert np.abs(out["Fx"] - fx(out["kappa"])).max() < 2.0


def test_revolution_average_note_says_how_a_gap_in_the_wheel_speed_is_filled():
    """Without a radius channel a stretch of NaN wheel speed is interpolated in time, not
    V / R: the note said 'V / R (nan m)'."""
    frame, fx, _ = _ripple_sweep(lambda k: np.ones_like(k))
    frame.loc[100:130, "omega"] = np.nan
    out, count = revolution_average(frame, SegmentSettings())
    assert "nan" not in count.note and "interpolated in time for 10 %" in count.note
    assert np.abs(out["Fx"] - fx(out["kappa"])).max() < 2.0
    _, count = revolution_average(frame.assign(re=0.3), SegmentSettings())
    assert "V / R (0.300 m) for 10 %" in count.note


def test_revolution_average_does_not_average_across_a_gap_in_the_log():
    """30 samples missing (1.6 revolutions; the loader drops a NaN stretch's rows, and the
    TTC generator's gap is as long): averaged across, the straight line between the gap's
    ends let 14 N of the 24 N ripple through and put Fx 15 N off the curve; each side
    averaged on its own, a revolution of it trimmed as at a segment's ends, the sweep
    keeps the 2 N of a clean one."""
    frame, fx, ripple = _ripple_sweep(lambda k: np.ones_like(k))
    gap = frame.drop(index=range(150, 180))
    out, count = revolution_average(gap, SegmentSettings())
    assert count.removed == 80  # a revolution at each end of both sides
    assert np.abs(out["Fx"] - fx(out["kappa"])).max() < 2.0
    alone, _ = revolution_average(gap.assign(Fx=ripple[gap.index]), SegmentSettings())
    assert np.abs(alone["Fx"]).max() < 0.05
