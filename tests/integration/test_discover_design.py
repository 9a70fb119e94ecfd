"""Discovery's statistics along sweeps, its held-out folds and its table noise floors
(issue 19): vectorised statistics equal their definitions, folds fit the design, a table's
floor comes from replicates or the richest model and is never above the best model's error."""
from __future__ import annotations

import lmfit
import numpy as np
import pandas as pd
import pytest

from identify.discover.design import condition_cells, folds, pressure_is_crossed
from identify.discover.floor import replicate_sigma
from identify.discover.library import load_library
from identify.discover.noise import (
    PHI_MIN,
    Sweeps,
    group_variogram,
    lag1,
    sweep_index,
    variogram,
    whiten,
)
from identify.discover.prepared_problem import noise_scale
from identify.discover.scenarios import make_confounded
from identify.discover.search import Settings, discover
from identify.discover.stage_problems import label_sweeps
from identify.fit.solve.problem import FitProblem

PRESSURES = (1.9, 2.2, 2.5, 2.7, 3.0)


@pytest.fixture(scope="module")
def library():
    return load_library()


def _layout(rng, n_sweeps=40):
    sizes = rng.integers(1, 30, n_sweeps)
    labels = np.repeat(np.arange(n_sweeps), sizes)
    return labels, [np.flatnonzero(labels == s) for s in range(n_sweeps)]


def test_sweep_statistics_equal_their_definitions():
    """Variogram, lag-one correlation, prewhitening and per-sweep sums in one pass equal the
    loops over sweeps that define them (sweeps of 1 to 29 points)."""
    rng = np.random.default_rng(0)
    labels, index = _layout(rng)
    r = rng.standard_normal(labels.size)
    sw = sweep_index(labels, labels.size)
    assert [list(i) for i in sw] == [list(i) for i in index]
    for h in (1, 2, 3, 7):
        d = np.concatenate([r[i[h:]] - r[i[:-h]] for i in index if i.size > h])
        assert variogram(r, sw, h)[h - 1] == pytest.approx(0.5 * d @ d / d.size, rel=1e-12)
    num = sum(float((r[i] - r[i].mean())[1:] @ (r[i] - r[i].mean())[:-1]) for i in index
              if i.size > 1)
    den = sum(float((r[i] - r[i].mean()) @ (r[i] - r[i].mean())) for i in index if i.size > 1)
    assert lag1(r, sw) == pytest.approx(num / den, rel=1e-12)
    want = r.copy()
    for i in index:
        want[i[1:]] = r[i[1:]] - 0.7 * r[i[:-1]]
        want[i[0]] = np.sqrt(1 - 0.49) * r[i[0]]
    np.testing.assert_allclose(whiten(r, sw, 0.7), want, rtol=1e-14)
    np.testing.assert_allclose(sw.sums(r), [r[i].sum() for i in index], rtol=1e-12)
    masked = sw.subset(np.arange(labels.size) % 3 != 0)
    assert len(masked) == sum(1 for i in index if np.any(i % 3 != 0))


def test_group_variogram_per_noise_group():
    """Each group's lag-one semivariogram from its own within-sweep pairs; a group without
    pairs gets NaN."""
    rng = np.random.default_rng(1)
    labels, index = _layout(rng, 12)
    groups = labels % 3
    r = rng.standard_normal(labels.size) * (1 + groups)
    gam, _ = group_variogram(r, Sweeps(labels), groups)
    for g in range(3):
        d = np.concatenate([np.diff(r[i]) for i in index if i.size > 1 and labels[i[0]] % 3 == g])
        assert gam[groups == g][0] == pytest.approx(0.5 * d @ d / d.size, rel=1e-12)
    lone = np.arange(5)
    gam, _ = group_variogram(np.ones(5), Sweeps(lone), lone)
    assert np.isnan(gam).all()


def test_noise_scale_survives_a_one_sample_sweep():
    """A sweep fragment of one sample (no within-sweep pair) takes the level pooled over every
    pair, and the other groups keep their own: on a TTC session one such fragment made every
    std NaN, the noise floor 0, and the 10 % excess rule blocked PPY3."""
    rng = np.random.default_rng(3)
    labels = np.repeat(np.arange(4), [400, 400, 1, 400])
    scale = np.array([1.0, 2.0, 5.0, 4.0])[labels]
    e = rng.standard_normal(labels.size) * scale
    phi, sigma = noise_scale(e, Sweeps(labels), labels)
    assert phi < PHI_MIN  # independent noise
    assert np.all(np.isfinite(sigma))
    for g, s in ((0, 1.0), (1, 2.0), (3, 4.0)):
        assert sigma[labels == g][0] == pytest.approx(s, rel=0.1)
    pooled, _ = group_variogram(e, Sweeps(labels), np.zeros(labels.size, dtype=int))
    assert sigma[labels == 2][0] == pytest.approx(np.sqrt(pooled[0]), rel=1e-12)
    lone = np.arange(5)
    assert np.isnan(noise_scale(np.ones(5), Sweeps(lone), lone)[1]).all()


def _table(pb, fz, meas=None, reps=1):
    P = lmfit.Parameters()
    P.add("a", value=1.0)
    pb, fz = np.repeat(pb, reps), np.repeat(fz, reps)
    meas = fz.copy() if meas is None else meas
    return FitProblem("X", "y", P, lambda v: v["a"] * fz, meas, pb, extra={"Fz_N": fz})


def test_crossed_design_leaves_one_pressure_out():
    """The thesis grid (every load at every pressure): leave one pressure level out."""
    pb = np.repeat(PRESSURES, 3)
    fz = np.tile([3000.0, 5000.0, 7000.0], 5)
    masks, scheme = folds(_table(pb, fz), sweep_index(None, 15))
    assert scheme == "leave one pressure level out"
    assert [np.unique(pb[m]).tolist() for m in masks] == [[p] for p in PRESSURES]


def test_confounded_design_keeps_every_condition_in_training():
    """Five load/pressure pairs at four speeds: leaving a pressure out would leave its load
    out, so the folds rotate the speeds within each pair and every pair always trains."""
    problem, _ = make_confounded(np.random.default_rng(0))
    index = sweep_index(None, problem.measured.size)
    pres, other = condition_cells(problem, index)
    assert not pressure_is_crossed(pres, other)
    masks, scheme = folds(problem, index)
    assert scheme.startswith("4-fold over rows within pressure x load cells")
    assert "not varied independently" in scheme
    held = np.sum(masks, axis=0)
    assert np.all(held == 1)  # every point held out exactly once
    for m in masks:
        assert set(np.unique(problem.pressure_bar[~m])) == set(problem.pressure_bar)
        # no fold holds out one speed everywhere
        assert np.unique(problem.extra["Vx_mps"][m]).size > 1
    forced, name = folds(problem, index, scheme="pressure")
    assert name == "leave one pressure level out (forced)" and len(forced) == 5


def test_replicates_give_the_pure_error():
    """Two measurements per condition: the pure-error std recovers the noise (weighted
    values), identical copies of a row are not replicates."""
    rng = np.random.default_rng(2)
    pb = np.repeat(PRESSURES, 3)
    fz = np.tile([3000.0, 5000.0, 7000.0], 5)
    truth = np.repeat(fz, 40)
    noisy = truth * (1 + 0.01 * rng.standard_normal(truth.size))
    p = _table(pb, fz, noisy, reps=40)
    s, dof = replicate_sigma(p)
    assert dof == 15 * 39
    w = p.weights()
    assert s == pytest.approx(0.01 * np.sqrt(np.mean((truth * w) ** 2)), rel=0.1)
    assert replicate_sigma(_table(pb, fz, np.repeat(fz, 2), reps=2)) is None


def test_table_floor_never_above_the_best_error(library):
    """Tables without sweeps (the confounded trial tables, hidden and null): the printed floor
    comes from the richest candidate model and never exceeds the final error."""
    for seed, hidden in [(0, True), (1, True), (9, True), (351000, False), (351004, False)]:
        problem, _ = make_confounded(np.random.default_rng(seed), hidden)
        s = discover([problem], library, Settings()).problems[0]
        assert s.floor_source.startswith("richest candidate model")
        assert s.noise_floor_pct <= s.final_error_pct + 1e-12, (seed, s.noise_floor_pct)


def test_measured_pressure_channel_groups_into_levels():
    """A trailer session logs the pressure of every sample: the MF stage problem groups its
    points by pressure level (the sweep means, clustered), not by the 1e4 distinct readings;
    the model still takes each sample's reading."""
    from identify.discover.problems import Base, apply_base, trailer_problems
    from identify.discover.scenarios import base_tir, make_session
    from identify.fit.relations.problems import Context

    rng = np.random.default_rng(3)
    frame, _ = make_session(rng, 12_000, rho=0.0)
    exact = frame["p"].to_numpy(float).copy()
    frame["p"] = exact * (1 + 0.003 * rng.standard_normal(len(frame)))
    tir = base_tir()
    ctx = Context(fz0=tir["FNOMIN"], p0_bar=tir["NOMPRES"] / 1e5, tir=tir)
    problems = [apply_base(p, Base(), load_library(), tir)
                for p in trailer_problems(frame, tir, ctx, with_rr=False)]
    fy = next(p for p in problems if p.extra["name"] == "MF/Fy")
    got = np.unique(fy.pressure_bar)
    assert got.size == 3
    assert np.sort(got) == pytest.approx(np.sort(np.unique(exact)) / 1e5, rel=2e-3)


def test_session_log_keeps_its_sweeps_and_test_folders_stay(tmp_path):
    """A TTC session (warm-ups, transitions, stops between the sweeps) enters discovery with
    its sweeps only, each sample as logged; a folder of test runs stays whole."""
    from identify.io.folder import load_folder
    from identify.workflows.discover import sweeps_only
    from identify.workflows.import_session import import_session
    from tests.measurement_cases import sample_trailer_folder
    from tests.ttc_cases import session

    s = session(tmp_path / "s", seed=2, cornering_only=True)
    import_session([f for f in s.files if f.suffix == ".mat"], tmp_path / "f")
    trailer = load_folder(tmp_path / "f").trailer
    notes = []
    kept = sweeps_only(trailer, notes)
    assert 0.4 * len(trailer) < len(kept) < 0.9 * len(trailer)
    assert notes and "warm-ups" in notes[0]
    assert kept["Fz"].min() > 1000.0  # no stops: the log's Fz near zero is gone
    assert np.isin(kept["t"], trailer["t"]).all()  # samples as logged, not averaged
    sample = load_folder(sample_trailer_folder(tmp_path / "sample")).trailer
    assert sweeps_only(sample, notes) is sample and len(notes) == 1


def test_a_segment_of_identify_segment_is_one_sweep():
    """In a table segmented by identify.segment, a sweep is a segment: neither the 2 % load
    steps of a noisy load at high slip nor a sample left out by a filter cut it into fragments
    (on a TTC session they made 1-44-sample sweeps, one a metric group of its own); a segment
    change, a run change or a longer time gap still end it. Without segments the load rule
    stands."""
    rng = np.random.default_rng(4)
    n = 400
    t = np.arange(2 * n) * 0.01
    keep = np.ones(2 * n, dtype=bool)
    keep[[100, 150, 151]] = False  # samples a filter left out
    keep[600:630] = False  # a 0.3 s gap: a new sweep
    fz = np.r_[np.full(n, 2500.0), np.full(n, 5000.0)] * (1 + 0.03 * rng.standard_normal(2 * n))
    alpha = np.deg2rad(np.tile(np.linspace(-12.0, 12.0, n), 2))
    frame = pd.DataFrame({"run": "r1", "t": t, "Fz": fz, "alpha": alpha, "kappa": 0.0,
                          "gamma": 0.0, "Vx": 11.1, "p": 2.5e5,
                          "segment_id": np.repeat([3, 8], n)})[keep]
    sweeps = label_sweeps(frame)["sweep"].to_numpy()
    assert np.unique(sweeps).size == 3
    assert np.array_equal(np.unique(sweeps[:n - 3]), [0])
    unsegmented = label_sweeps(frame.drop(columns="segment_id"))["sweep"].to_numpy()
    assert np.unique(unsegmented).size > 3
