"""Segmentation of logs shaped like a real TTC programme (identify.segment).

Real Tire Test Consortium logs differ from clean generated ones in ways that broke the
segmentation: the load control lags the side force, so the load of a high-load sweep wanders
by a quarter of its set point while the slip angle moves; the gas pressure swings by a few
per cent within a sweep; the logger pauses between sweeps (every load and pressure step lies
in a time gap); a small tyre at 40 km/h works its tread at 30-45 degC; and a drive/brake run
may end in a lock-up that stretches one slip-ratio span far beyond the programme's. These
small synthetic logs (50 Hz, one sweep 0 -> +12 -> -12 -> 0 deg per set point, as a TTC
round sweeps) carry each of those and check that every set point that holds sweeps is one
level, and every full sweep a sweep.
"""
from __future__ import annotations

import numpy as np
import pandas as pd

from identify.segment import segment_trailer
from identify.segment.filters import cold_mark
from identify.segment.plateaus import full_span
from identify.segment.settings import SegmentSettings

RATE = 50.0  # [Hz]
V = 40 / 3.6  # [m/s]


def _sweep_alpha(amplitude_deg: float = 12.0, rate_deg_s: float = 3.0) -> np.ndarray:
    """0 -> +A -> -A -> 0 at a constant rate [rad], sampled at RATE."""
    a = amplitude_deg
    path = np.concatenate((np.linspace(0, a, int(a / rate_deg_s * RATE)),
                           np.linspace(a, -a, int(2 * a / rate_deg_s * RATE)),
                           np.linspace(-a, 0, int(a / rate_deg_s * RATE))))
    return np.deg2rad(path)


def _programme(blocks, *, rng, run="r1", tread_C=35.0, ambient_C=22.0, kappa_sweeps=False):
    """A log of ``blocks``: (pressure [kPa], camber [deg], load [N]) per sweep, in order. Each
    sweep: 1 s at zero slip and the set load, a 4 s logger pause, the sweep (the load lags
    the slip: +25 % of its set point at full slip angle; the pressure swings +-2 % with a
    6 s period), a 4 s pause; a new pressure adds a 60 s pause (the tyre lifted)."""
    parts, t0, last_p = [], 0.0, None
    for p_kpa, gamma_deg, fz in blocks:
        if last_p is not None and p_kpa != last_p:
            t0 += 60.0
        last_p = p_kpa
        rest = np.zeros(int(RATE))
        if kappa_sweeps:
            swept = 0.25 * np.sin(np.linspace(0, 2 * np.pi, int(8 * RATE)))
            alpha, kappa = np.zeros_like(swept), swept
            follow = np.abs(swept) / 0.25
        else:
            alpha = _sweep_alpha()
            kappa = np.zeros_like(alpha)
            follow = np.abs(alpha) / np.deg2rad(12.0)
        for a, k, f, pause in ((rest, rest, rest, 4.0), (alpha, kappa, follow, 4.0)):
            n = a.size
            t = t0 + np.arange(n) / RATE
            load = fz * (1 + 0.25 * f ** 1.5) + rng.normal(0, 0.015 * fz, n)
            p = p_kpa * 1e3 * (1 + 0.02 * np.sin(2 * np.pi * (t - t0) / 6.0))
            parts.append(pd.DataFrame({
                "run": run, "t": t, "Vx": V + rng.normal(0, 0.02, n),
                "omega": V / 0.26 * (1 + k), "alpha": a + rng.normal(0, 2e-4, n),
                "kappa": k + rng.normal(0, 1e-3, n),
                "gamma": np.deg2rad(gamma_deg) + rng.normal(0, 3e-4, n),
                "p": p + rng.normal(0, 100.0, n), "Fz": load,
                "Fy": -1.6 * load * np.sin(1.4 * np.arctan(12 * a)),
                "Fx": 1.6 * load * np.sin(1.5 * np.arctan(15 * k)),
                "T_tread_centre": 273.15 + tread_C + 5 * f + rng.normal(0, 0.3, n),
                "T_ambient": 273.15 + ambient_C + rng.normal(0, 0.1, n)}))
            t0 = t[-1] + pause
    return pd.concat(parts, ignore_index=True)


def _sweeps(result, run="r1"):
    return [g for g in result.segmentation.segments
            if g.run == run and g.kind not in ("transition", "steady")]


def test_five_pressures_with_the_load_following_the_slip_are_five_levels():
    """A pressure sweep run (8-16 psi in 2 psi steps, one sweep at 650 and one at 1550 N
    each): five pressure levels and two load levels, all ten sweeps whole. The load of the
    1550 N sweeps runs up to 1940 N and back with the slip angle (80 N/s, over the 5 %/s of
    the run's median load a settled set point may drift); the pressure swings 2 %."""
    rng = np.random.default_rng(1)
    pressures = (55.0, 70.0, 83.0, 97.0, 110.0)
    table = _programme([(p, 0.0, fz) for p in pressures for fz in (1550.0, 650.0)], rng=rng)
    result = segment_trailer(table)
    seg = result.segmentation
    p = np.array(seg.level_values("p")) / 1e3
    assert p.size == 5 and np.all(np.abs(p / np.array(pressures) - 1) < 0.01), p
    assert [lv.segments for lv in seg.levels["p"]] == [2] * 5
    fz = np.array(seg.level_values("Fz"))
    # the level is the median of the sweeps' medians: the set point plus the lag at the
    # median slip angle (+-12 deg swept evenly: 0.25 * 0.5^1.5 = 8.8 %)
    assert fz.size == 2 and np.all(np.abs(fz / np.array([650.0, 1550.0]) - 1.09) < 0.02), fz
    kinds = [(g.kind, g.sweep) for g in _sweeps(result)]
    assert kinds == [("sweep", "alpha")] * 10
    sweep_rows = sum(g.stop - g.start for g in _sweeps(result))
    assert sweep_rows >= 10 * 0.95 * _sweep_alpha().size


def test_camber_steps_of_one_degree_at_five_loads_are_levels():
    """A camber run at 12 psi: 0-4 deg in 1 deg steps, at 200, 650, 1100, 1550, 2000 N
    (the TTC's order, the highest load last); segmented alone it holds five camber and five
    load levels, every sweep whole."""
    rng = np.random.default_rng(2)
    loads = (1550.0, 1100.0, 650.0, 200.0, 2000.0)
    table = _programme([(83.0, g, fz) for g in range(5) for fz in loads], rng=rng)
    result = segment_trailer(table)
    seg = result.segmentation
    gamma = np.rad2deg(seg.level_values("gamma"))
    np.testing.assert_allclose(gamma, [0, 1, 2, 3, 4], atol=0.05)
    assert len(seg.level_values("Fz")) == 5 and len(seg.level_values("p")) == 1
    assert [(g.kind, g.sweep) for g in _sweeps(result)] == [("sweep", "alpha")] * 25


def test_a_load_step_at_rest_still_ends_a_plateau():
    """Without a pause in the log: a load step of 40 % while the slip angle rests at zero
    between two sweeps still separates two plateaus at two levels (only the drift while the
    slip moves belongs to the sweep)."""
    rng = np.random.default_rng(3)
    table = _programme([(83.0, 0.0, 1000.0), (83.0, 0.0, 1000.0), (83.0, 0.0, 600.0),
                        (83.0, 0.0, 600.0)], rng=rng)
    table["t"] = np.arange(len(table)) / RATE  # the pauses taken out: one continuous log
    seg = segment_trailer(table).segmentation
    assert len(seg.level_values("Fz")) == 2
    assert [g.kind for g in seg.segments].count("sweep") == 4


def test_one_overlong_slip_ratio_span_leaves_the_other_sweeps_whole():
    """A drive/brake run of nine sweeps of +-0.25 and a tenth that ends in a lock-up
    (slip ratio to 0.7): the nine are sweeps, not partial (the full span is the one a
    quarter of the plateaus reach, not the largest)."""
    rng = np.random.default_rng(4)
    table = _programme([(83.0, 0.0, fz) for fz in (1500.0, 1100.0, 650.0) * 3 + (1100.0,)],
                       rng=rng, kappa_sweeps=True)
    last = table.index[table["t"] > table["t"].iloc[-1] - 1.0]
    table.loc[last, "kappa"] = np.linspace(0.0, 0.7, last.size)
    kinds = [(g.kind, g.sweep) for g in _sweeps(segment_trailer(table))]
    assert kinds[:9] == [("sweep", "kappa")] * 9
    assert full_span([0.5] * 9 + [0.95]) == 0.5
    assert full_span([0.5]) == 0.5 and full_span([]) == 0.0


def test_a_cool_running_tread_is_not_cold():
    """A small tyre at 40 km/h works its tread at 35-40 degC (ambient 22): halfway from
    ambient to that is the cold mark, not 40 degC, so its sweeps are kept; a tread at 24 degC
    (just lifted for a pressure change) is below the run's working range and less than
    halfway up: cold."""
    rng = np.random.default_rng(5)
    table = _programme([(83.0, 0.0, fz) for fz in (1100.0, 650.0) * 2], rng=rng)
    first = table["t"] < table["t"].iloc[0] + 10.0  # the first sweep's first 5 s: cold
    table.loc[first, "T_tread_centre"] = 273.15 + 24.0
    result = segment_trailer(table)
    sweeps = result.table  # median 35 + 5 * 0.5 = 37.5 degC: halfway from 22 is 29.75
    mark = cold_mark(sweeps, SegmentSettings())
    assert 273.15 + 29 < mark["r1"] < 273.15 + 31
    removed = {f.name: f.removed for f in result.segmentation.filters}["cold tread"]
    assert 0 < removed <= first.sum()
    assert (result.table["T_tread_centre"] > 273.15 + 30).all()


def test_a_sweep_that_heats_its_own_tread_is_not_cold():
    """Each sweep starts on a tread near ambient (24 degC, ambient 22) and heats it by 20 K at
    full slip, as a small tyre's hard sweeps do: the cool start of every sweep is inside the
    run's working range (the fence Q1 - IQR is about 19 degC), nothing is cold, and the
    small slip angles stay. A mark halfway from ambient to the median alone (28 degC) would
    have cut about a fifth of every sweep, its small slip angles."""
    rng = np.random.default_rng(7)
    table = _programme([(83.0, 0.0, fz) for fz in (1100.0, 650.0) * 2], rng=rng,
                       tread_C=24.0)
    table["T_tread_centre"] = 273.15 + 24.0 + 4 * (table["T_tread_centre"] - 273.15 - 24.0)
    result = segment_trailer(table)
    assert {f.name: f.removed for f in result.segmentation.filters}["cold tread"] == 0
    t = result.table["T_tread_centre"] - 273.15
    halfway = 22.0 + 0.5 * (t.median() - 22.0)
    assert (t < halfway).mean() > 0.15  # what the fence keeps
    small = np.abs(np.rad2deg(result.table["alpha"])) < 2.0
    assert small.sum() > 0.1 * len(result.table)


def test_without_an_ambient_channel_the_working_range_alone_decides():
    """No ambient channel: a stretch at 24 degC in a run worked at 35-40 degC is below the
    fence (about 34 degC) and cold; the rest is kept."""
    rng = np.random.default_rng(5)
    table = _programme([(83.0, 0.0, fz) for fz in (1100.0, 650.0) * 2], rng=rng)
    first = table["t"] < table["t"].iloc[0] + 10.0
    table.loc[first, "T_tread_centre"] = 273.15 + 24.0
    result = segment_trailer(table.drop(columns="T_ambient"))
    mark = cold_mark(result.table, SegmentSettings())
    assert 273.15 + 32 < mark["r1"] < 273.15 + 35
    removed = {f.name: f.removed for f in result.segmentation.filters}["cold tread"]
    assert 0 < removed <= first.sum()
    assert (result.table["T_tread_centre"] > 273.15 + 30).all()


def test_a_set_point_visited_by_one_sweep_is_a_level_a_sweep_across_a_change_is_not():
    """Three sweeps at 83 kPa and one at 110 kPa: two pressure levels (the one sweep held its
    pressure from start to end). A fifth sweep during which the pressure was let down from
    110 to 70 kPa starts and ends 40 kPa apart: in no level (``isolated``)."""
    rng = np.random.default_rng(6)
    table = _programme([(83.0, 0.0, 1000.0)] * 3 + [(110.0, 0.0, 1000.0)], rng=rng)
    seg = segment_trailer(table).segmentation
    _near_p = np.array(seg.level_values("p")) / 1e3
    assert _near_p.size == 2 and abs(_near_p[1] - 110.0) < 1.0
    ramp = _programme([(50.0, 0.0, 1000.0)], rng=rng, run="r2")
    ramp["p"] = np.linspace(110e3, 70e3, len(ramp))
    both = segment_trailer(pd.concat([table, ramp], ignore_index=True)).segmentation
    assert [g.kind for g in both.segments if g.run == "r2"].count("isolated") == 1
    assert len(both.level_values("p")) == 2
