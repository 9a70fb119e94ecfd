"""The written model against every loaded trailer sample (identify.fit.every_sample): the
pooled and per-level errors against their closed forms, the groups a sample falls in, the
offset note, and the record's round trip."""
from __future__ import annotations

import json
import math

import numpy as np
import pandas as pd
import pytest

from identify.core.jsonsafe import json_text
from identify.fit.every_sample import (
    EverySample,
    every_sample,
    pressure_levels,
    run_kinds,
    segment_kinds,
)
from identify.io.tir import read_tir
from identify.model.evaluate import evaluate
from identify.model.modes import FIT_MODE
from identify.segment.result import Segment
from identify.simulate import default_tir_path


@pytest.fixture(scope="module")
def truth():
    return read_tir(default_tir_path()).params()


def _session(truth, mx_offset=0.0):
    """A cornering run (slip angle swept, free rolling) at two pressures and a drive/brake run
    (slip ratio swept at alpha 0) at one, forces and moments the model's own; the drive/brake
    run's Mx shifted by ``mx_offset`` [N m]."""
    a = np.deg2rad(np.linspace(-8, 8, 81))
    k = np.linspace(-0.15, 0.15, 81)
    parts = []
    for p in (2.0e5, 2.6e5):
        parts.append(pd.DataFrame({"run": f"corner {p:g}", "Fz": 4000.0, "p": p, "Vx": 16.7,
                                   "alpha": a, "kappa": 0.0, "gamma": 0.0}))
    parts.append(pd.DataFrame({"run": "drive", "Fz": 4000.0, "p": 2.0e5, "Vx": 16.7,
                               "alpha": 0.0, "kappa": k, "gamma": 0.0}))
    t = pd.concat(parts, ignore_index=True)
    out = evaluate(truth, *(t[c].to_numpy() for c in ("Fz", "kappa", "alpha", "gamma", "Vx")),
                   p=t["p"].to_numpy(), mode=FIT_MODE)
    t = t.assign(**{c: np.asarray(out[c], float) for c in ("Fx", "Fy", "Mz", "Mx")})
    t.loc[t["run"] == "drive", "Mx"] += mx_offset
    return t


def test_the_model_itself_has_no_error_and_every_group_is_there(truth):
    t = _session(truth)
    es = every_sample(truth, t)
    assert es.samples == es.loaded == len(t) == 243
    names = [(g.by, g.name, g.samples) for g in es.groups]
    assert names == [("all", "every sample", 243), ("run", "free rolling", 162),
                     ("run", "drive/brake", 81), ("pressure", "2.00 bar", 162),
                     ("pressure", "2.60 bar", 81)]
    for g in es.groups:
        for c, e in g.channels.items():
            assert e.pooled_pct < 1e-9 and abs(e.mean_error) < 1e-9, (g.name, c)
    assert es.notes == ()
    assert "Fx 0.0 %" in es.summary_line() and "243 of 243" in es.summary_line()


def test_an_offset_on_one_kind_of_run_is_measured_and_named(truth):
    t = _session(truth, mx_offset=30.0)
    es = every_sample(truth, t)
    drive = es.group("run", "drive/brake").channels["Mx"]
    mx = t.loc[t["run"] == "drive", "Mx"].to_numpy()
    # model - measured is -30 everywhere there: RMS 30, mean -30
    assert drive.mean_error == pytest.approx(-30.0, abs=1e-9)
    assert drive.pooled_pct == pytest.approx(100 * 30 / np.sqrt(np.mean(mx ** 2)), rel=1e-12)
    rolling = es.group("run", "free rolling").channels["Mx"]
    assert rolling.pooled_pct < 1e-9
    # all samples: the offset's share of the squares; the thesis metric per pressure level
    all_mx = t["Mx"].to_numpy()
    sq = np.where(t["run"] == "drive", 900.0, 0.0)
    e = es.group("all", "every sample").channels["Mx"]
    assert e.pooled_pct == pytest.approx(100 * np.sqrt(sq.mean() / np.mean(all_mx ** 2)))
    low = (t["p"] == 2.0e5).to_numpy()
    per = [100 * np.sqrt(sq[low].mean() / np.mean(all_mx[low] ** 2)), 0.0]
    assert e.thesis_pct == pytest.approx(np.mean(per))
    assert es.notes == (f"Mx on the drive/brake samples: the model is 30 N m below the "
                        f"measurement on average (RMS error 30 N m, "
                        f"{drive.pooled_pct:.0f} %)",)


def test_rows_the_model_cannot_take_are_left_out(truth):
    t = _session(truth)
    t.loc[:9, "Fz"] = -5.0  # the tyre off the road
    t.loc[10:19, "alpha"] = np.nan
    es = every_sample(truth, t)
    assert es.samples == len(t) - 20 and es.loaded == len(t)
    # a table without an input the model needs has nothing to judge (and no page)
    none = every_sample(truth, t.drop(columns="p"))
    assert none.groups == () and none.samples == 0 and none.summary_line() == ""


def test_the_segment_kind_of_every_row():
    t = pd.DataFrame({"run": ["a"] * 6 + ["b"] * 3})
    segs = [Segment("a", "transition", "", 0, 2, 0.0, 1.0),
            Segment("a", "sweep", "alpha", 2, 5, 1.0, 2.0)]
    kinds = segment_kinds(t, segs, ["a"])
    assert list(kinds) == ["transition"] * 2 + ["sweep"] * 3 + ["between segments"] \
        + ["not segmented"] * 3


def test_groups_by_segmentation(truth):
    t = _session(truth)
    seg = np.where(t["run"] == "drive", "not segmented",
                   np.where(np.abs(t["alpha"]) > np.deg2rad(5.1), "transition", "sweep"))
    es = every_sample(truth, t, seg)
    got = {g.name: g.samples for g in es.groups if g.by == "segmentation"}
    # |alpha| beyond 5.1 deg: 15 of the 0.2 deg steps each side, in each of the two runs
    assert got == {"kept: sweeps": 102, "left out: transitions": 60, "runs used as loaded": 81}
    assert es.group("segmentation", "left out: transitions").channels["Fy"].pooled_pct < 1e-9


def test_pressure_levels_are_the_held_levels_a_ramp_does_not_join():
    """A session's pressure held at 2.0 and 2.6 bar, and changed slowly between them (the
    sorted samples then chain with no step over the gap): two levels, every sample at the
    nearer one, NaN where the pressure is."""
    rng = np.random.default_rng(0)
    held = np.r_[2.0e5 + 300 * rng.standard_normal(500), 2.6e5 + 300 * rng.standard_normal(500)]
    ramp = np.linspace(2.02e5, 2.58e5, 20)
    p = np.r_[held, ramp, np.nan]
    assert np.max(np.diff(np.sort(p[:-1]))) < 5000.0
    lv = pressure_levels(p)
    assert np.unique(lv[:-1]) == pytest.approx([2.0e5, 2.6e5], abs=100)
    assert np.all(lv[1000:1010] < 2.3e5) and np.all(lv[1010:1020] > 2.3e5)
    assert math.isnan(lv[-1])


def test_kinds_of_run(truth):
    t = _session(truth)
    t.loc[(t["run"] == "drive") & (t.index % 2 == 0), "alpha"] = np.deg2rad(3.0)
    k = run_kinds(t)
    assert set(k[t["run"] != "drive"]) == {"free rolling"}
    assert set(k[t["run"] == "drive"]) == {"drive/brake", "combined"}


def test_the_record_round_trips(truth):
    es = every_sample(truth, _session(truth, mx_offset=30.0))
    d = json.loads(json_text(es.to_dict()))
    assert EverySample.from_dict(d).to_dict() == d
    assert EverySample.from_dict({}) is None
