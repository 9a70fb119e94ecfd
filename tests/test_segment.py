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
from identify.segment.filters import revolution_average
from tests.segment_cases import check, segmented
from tests.ttc_cases import session


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    return {seed: session(tmp_path_factory.mktemp("seg") / f"s{seed}", seed=seed)
            for seed in (11, 12)}


@pytest.mark.parametrize("seed", [11, 12])
def test_levels_are_the_set_points_and_warmups_are_dropped(sessions, seed):
    result = check(sessions[seed])
    seg = result.segmentation
    counts = seg.counts()
    assert counts["sweep"] == 45 + 90 and counts["warmup"] >= 4
    names = [f.name for f in seg.filters]
    assert names == ["revolution average", "set slip angle", "cold tread", "low speed",
                     "binning"]
    assert seg.kept == len(result.table) == seg.in_sweeps - sum(f.removed for f in seg.filters)
    assert seg.kept == sum(s.kept for s in seg.segments)


def test_segmentation_round_trips_through_json(sessions):
    result, _ = segmented(sessions[11])
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
    assert removed.applied and removed.removed == 2 * 18 * 45  # n - 1 = 18 at both ends


def test_revolution_average_leaves_a_fast_curved_sweep_in_place():
    """A drive/brake sweep of 0.125/s through the peak of Fx = 3000 sin(1.6 atan(15 kappa)) N
    with a 24 N once-per-revolution ripple, 18.7 samples a revolution at 100 Hz: a plain
    one-revolution moving average (19 samples) is 29.7 N off the curve near the peak
    (T^2/24 f''); the twiced filter over 18.7 samples 1.6 N (the fourth-order term), and it
    lets 0.009 N of the ripple alone through (0.4 N would pass a window rounded to 19)."""
    dt = 0.01
    omega = 2 * np.pi / (18.7 * dt)
    t = np.arange(0.0, 3.2, dt)
    kappa = -0.2 + 0.125 * t

    def fx(k):
        return 3000.0 * np.sin(1.6 * np.arctan(15.0 * k))

    ripple = 24.0 * np.cos(omega * t + 0.3)
    frame = pd.DataFrame({"t": t, "kappa": kappa, "Fx": fx(kappa) + ripple,
                          "omega": omega, "Vx": 11.1, "segment": 0})
    out, count = revolution_average(frame, SegmentSettings(), dt)
    assert count.removed == 2 * 18 and "18.7 samples" in count.note
    assert np.abs(out["Fx"] - fx(out["kappa"])).max() < 2.0
    plain = frame[["kappa", "Fx"]].rolling(19, center=True).mean().dropna()
    assert np.abs(plain["Fx"] - fx(plain["kappa"])).max() > 25.0
    alone, _ = revolution_average(frame.assign(Fx=ripple), SegmentSettings(), dt)
    assert np.abs(alone["Fx"]).max() < 0.05  # of 24 N


def test_binning_gives_one_point_per_bin_and_sweep(sessions):
    _, table = segmented(sessions[12])
    binned = segment_trailer(table, SegmentSettings(bin_alpha_deg=0.5, bin_kappa=0.005))
    t = binned.table
    count = {f.name: f for f in binned.segmentation.filters}["binning"]
    assert count.applied and count.removed > 0.9 * (count.removed + count.remaining)
    a = t[t.sweep == "alpha"]
    bins = np.floor(a["alpha"] / np.deg2rad(0.5))
    assert not bins.groupby(a["segment"]).apply(lambda b: b.duplicated().any()).any()
    assert a.groupby("segment").size().between(40, 52).all()  # +-12 deg in 0.5 deg bins
