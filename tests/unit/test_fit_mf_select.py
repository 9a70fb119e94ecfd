"""Which trailer points each MF stage fits (identify.fit.mf.stage_data.select) when the slip-ratio
channel of a cornering run is noisy, as SL of a real TTC cornering run is (and SR, the
older rounds' stand-in, more so)."""
import numpy as np
import pandas as pd

from identify.fit.coverage import mf_coverage
from identify.fit.mf.problem import stage_problem
from identify.fit.mf.stage_data import pressure_groups, rolling_kappa, run_sweeps, select
from identify.model.parameters import defaults


def _table(kappa_noise: float, seed: int = 0) -> pd.DataFrame:
    """A cornering run (alpha sweep, kappa = noise only) and a drive/brake run (kappa sweeps
    at alpha 0 and 4 deg)."""
    rng = np.random.default_rng(seed)
    n = 2000
    corner = pd.DataFrame({"run": "corner", "alpha": np.deg2rad(np.linspace(-10, 10, n)),
                           "kappa": kappa_noise * rng.standard_normal(n)})
    corner.loc[7, "kappa"] = 0.05  # one stray sample must not make it a kappa sweep
    drive = pd.DataFrame({"run": "drive",
                          "alpha": np.repeat(np.deg2rad([0.0, 4.0]), n // 2),
                          "kappa": np.tile(np.linspace(-0.2, 0.2, n // 2), 2)})
    t = pd.concat([corner, drive], ignore_index=True)
    return t.assign(gamma=0.0, Vx=16.0, p=2e5, Fz=4000.0, Fx=1.0, Fy=1.0, Mz=1.0, omega=50.0)


def _held(t: pd.DataFrame) -> pd.DataFrame:
    """The cornering run of ``t`` (:func:`_table`) as run "held": its alpha sweep at a held
    slip ratio of 0.05 (plus a tenth of the cornering run's kappa noise)."""
    corner = t[t["run"] == "corner"]
    return corner.assign(run="held", kappa=0.05 + 0.1 * corner["kappa"])


def _params() -> dict[str, float]:
    """The numeric defaults of every .tir key."""
    return {k: float(v) for k, v in defaults().items() if not isinstance(v, str)}


def test_a_noisy_kappa_in_a_cornering_run_is_rolling_not_slip():
    t = _table(kappa_noise=0.003)
    corner = (t["run"] == "corner").to_numpy()
    lateral = select(t, "lateral", "Fy")
    # every cornering point is pure lateral, though 50 % of them have |kappa| > 0.002
    assert corner[lateral].sum() == corner.sum()
    assert np.mean(np.abs(t.loc[corner, "kappa"]) > 0.002) > 0.4
    # the drive/brake run's lateral points are its near-zero kappa ones only
    drive_lat = t.iloc[lateral][t["run"].iloc[lateral] == "drive"]
    assert (np.abs(drive_lat["kappa"]) <= 0.002).all() and len(drive_lat) > 0
    # no cornering point is a combined-slip point for the Fx/Mz stages or the Fy stage
    for selection in ("combined", "kappa_slip"):
        rows = select(t, selection, "Fx")
        assert not corner[rows].any() and len(rows) > 0
    combined = t.iloc[select(t, "combined", "Fx")]
    assert np.allclose(np.rad2deg(combined["alpha"]), 4.0)
    # free rolling: the cornering run only
    assert set(t.iloc[select(t, "free_rolling", "Re")]["run"]) == {"corner"}


def test_clean_kappa_selects_as_before():
    t = _table(kappa_noise=0.0)
    t.loc[7, "kappa"] = 0.0
    corner = (t["run"] == "corner").to_numpy()
    assert corner[select(t, "lateral", "Fy")].sum() == corner.sum()
    drive = ~corner
    longitudinal = select(t, "longitudinal", "Fx")
    # the drive/brake run's zero-angle sweep, and the cornering run's points at zero slip
    # angle: its Fx at kappa = 0 pins the offsets at its loads and pressures
    zero = corner & (np.abs(t["alpha"].to_numpy()) <= np.deg2rad(0.25))
    assert drive[longitudinal].sum() == 1000 and zero.sum() == 50  # 0.01 deg apart
    np.testing.assert_array_equal(np.flatnonzero(zero | (drive & (t["alpha"] == 0))),
                                  longitudinal)


def test_a_rolling_runs_kappa_is_taken_as_zero_a_held_slip_ratio_is_not():
    """The cornering run's noisy kappa becomes 0 (the MF stages would take it for a slip: Kx
    times 0.003 is 6 % of Fz of Fx); the drive/brake run's sweep and an alpha sweep at a held
    slip ratio of 0.05 keep theirs, and the latter is combined slip, not pure lateral."""
    t = _table(kappa_noise=0.003)
    held = _held(t)
    t = pd.concat([t, held], ignore_index=True)
    out = rolling_kappa(t)
    corner, drive, at_slip = (t["run"] == r for r in ("corner", "drive", "held"))
    assert (out.loc[corner, "kappa"] == 0).all()
    pd.testing.assert_series_equal(out.loc[~corner, "kappa"], t.loc[~corner, "kappa"])
    assert (t.loc[corner, "kappa"] != 0).any()  # not modified
    lateral = set(t.iloc[select(t, "lateral", "Fy")]["run"])
    assert "held" not in lateral and "corner" in lateral
    assert "held" in set(t.iloc[select(t, "combined", "Fx")]["run"])


def test_the_run_sweeps_of_a_table_hold_for_it_with_rolling_kappa_taken_as_zero():
    """identify.fit.mf.stages.fit_mf takes run_sweeps once, on the raw table, and every stage
    selects its rows on the table with rolling kappa set to 0 with them: they must be that
    table's own (and rolling_kappa given them must not modify them)."""
    t = _table(kappa_noise=0.003)
    held = _held(t)
    t = pd.concat([t, held], ignore_index=True)
    sweeps = run_sweeps(t)
    given = tuple(a.copy() for a in sweeps)
    rolled = rolling_kappa(t, sweeps)
    for a, b, c in zip(sweeps, given, run_sweeps(rolled)):
        np.testing.assert_array_equal(a, b)
        np.testing.assert_array_equal(a, c)
    pd.testing.assert_frame_equal(rolled, rolling_kappa(t))
    for selection in ("lateral", "combined", "kappa_slip", "longitudinal", "free_rolling"):
        np.testing.assert_array_equal(select(rolled, selection, "Fx", sweeps),
                                      select(rolled, selection, "Fx"))


def test_a_stage_problem_built_again_on_the_raw_table_fits_what_fit_mf_fitted():
    """stage_mcmc and mf_uncertainty.propagate build a stage's problem again on the table the
    caller holds, not on fit_mf's copy with the rolling runs' kappa at 0: the problem takes
    that 0 itself, or the Fy0 model at the cornering points is combined slip at the noise."""
    t = _table(kappa_noise=0.003)
    params = _params()
    raw = stage_problem("Fy0", t, params)
    fitted = stage_problem("Fy0", rolling_kappa(t), params)
    np.testing.assert_array_equal(raw.rows, fitted.rows)
    np.testing.assert_array_equal(raw.state.kappa, fitted.state.kappa)
    x = fitted.problem.x0()
    np.testing.assert_array_equal(raw.problem.predict(x), fitted.problem.predict(x))


def test_the_coverage_table_counts_the_points_the_stages_fit():
    """mf_coverage decides which stages are fitted and shows their slip ranges: it takes a
    rolling run's kappa as 0 as the stages do (free rolling: every point of the cornering
    run; Fy0: kappa within the drive run's +-PURE_KAPPA, not the noise's +-0.01)."""
    t = _table(kappa_noise=0.004)
    params = _params()
    stages = ("geometry", "Fx0", "Fy0", "Fx", "Fy")
    for c in mf_coverage(t, params["FNOMIN"], stages=stages):
        sp = stage_problem(c.stage, t, params, screen=False)
        assert c.points == sp.rows.size
        k = sp.state.kappa
        assert c.kappa == (k.min(), k.max())


def test_the_coverage_table_counts_the_combined_points_of_a_held_slip_ratio():
    """An alpha sweep at a held slip ratio is combined slip for the Fx, Fy and Mz stages
    (select); the coverage table counted the combined points of the kappa sweeps only (990 of
    the 2940 the Fx stage fits)."""
    t = _table(kappa_noise=0.003)
    held = _held(t)
    t = pd.concat([t, held], ignore_index=True)
    params = _params()
    for c in mf_coverage(t, params["FNOMIN"], stages=("Fx0", "Fx", "Fy", "Mz0", "Mz")):
        assert not c.skipped, c
        assert c.points == stage_problem(c.stage, t, params, screen=False).rows.size, c.stage


def test_stray_slip_ratio_samples_do_not_make_a_held_slip_ratio_run_a_sweep_for_coverage():
    """The coverage table's sweeps are mf_data.run_sweeps' (1st to 99th percentile span):
    before, a max - min span of its own took two stray samples (0.09, 0.01) of an alpha sweep
    held at kappa 0.05 for a slip-ratio sweep, so with no kappa sweep in the session Fx0 was
    '0 point(s), 50 needed' and the combined Fy stage was fitted, not 'no slip-ratio sweep'."""
    t = _table(kappa_noise=0.003)
    held = _held(t)
    clean = pd.concat([t[t["run"] != "drive"], held], ignore_index=True)
    stray = clean.copy()
    stray.loc[np.flatnonzero(stray["run"] == "held")[[10, 20]], "kappa"] = [0.09, 0.01]
    fnomin = float(defaults()["FNOMIN"])
    stages = ("Fx0", "Fy0", "Fy")
    expected = {"Fx0": "no slip-ratio sweep", "Fy0": "", "Fy": "no slip-ratio sweep"}
    for table in (clean, stray):
        assert {c.stage: c.skipped for c in mf_coverage(table, fnomin, stages=stages)
                } == expected


def test_pressure_groups_are_the_pressure_levels_not_the_runs():
    """A TTC run holds every pressure block: its sweeps (segments) at 212, 250 and 288 kPa set,
    the second of each block 2 kPa warmer, each rising 1.5 kPa over its 50 samples, group as
    three pressures whatever run they are in, each the median of its rows' sweep medians (set
    + 1.75 kPa: 2.1375, 2.5175, 2.8975 bar, rounded to 0.01 bar); a sweep without a pressure
    is NaN. Grouped by run, all were the run's median, 2.52 bar."""
    rng = np.random.default_rng(0)
    blocks = []
    for run, sets in (("corner", (212e3, 250e3, 288e3)), ("drive", (250e3, 288e3))):
        for seg, p_set in enumerate(sets):
            for sweep in range(2):
                p = (p_set + 2e3 * sweep + np.linspace(0, 1.5e3, 50)
                     + 300 * rng.standard_normal(50))
                blocks.append(pd.DataFrame({"run": run, "segment_id": 2 * seg + sweep,
                                            "p_set": p_set, "p": p}))
    blocks.append(pd.DataFrame({"run": "drive", "segment_id": 99, "p_set": 0.0,
                                "p": np.full(5, np.nan)}))
    t = pd.concat(blocks, ignore_index=True)
    g = pressure_groups(t.drop(columns="p_set"))
    assert np.isnan(g[-5:]).all()
    level = {212e3: 2.14, 250e3: 2.52, 288e3: 2.90}
    assert np.array_equal(g[:-5], t["p_set"].iloc[:-5].map(level).to_numpy())
    # without the segment labels a run is one sweep, its median (so for runs at one
    # pressure each, as before)
    by_run = pressure_groups(t.drop(columns=["segment_id", "p_set"]))
    assert set(np.unique(by_run[t["run"] == "corner"])) == {2.52}


def test_the_overturning_moment_is_fitted_on_the_rolling_runs_or_on_all_without_one():
    """The Mx stage's selection ("rolling_runs"): the cornering run's points only, beside a
    drive/brake run (whose Mx follows Fx, a term the MF's Mx has not); every point of a table
    of drive/brake runs only; held-slip alpha sweeps are not rolling."""
    from identify.fit.mf.stage_specs import STAGES
    assert STAGES["Mx"].selection == "rolling_runs"
    t = _table(kappa_noise=0.003)
    t = pd.concat([t, _held(t)], ignore_index=True).assign(Mx=1.0)
    rows = select(t, "rolling_runs", "Mx")
    assert set(t.iloc[rows]["run"]) == {"corner"}
    assert len(rows) == (t["run"] == "corner").sum()
    drive_only = t[t["run"] != "corner"].reset_index(drop=True)
    assert len(select(drive_only, "rolling_runs", "Mx")) == len(drive_only)
    # a rolling run whose Mx is all NaN does not count: the other runs are fitted
    no_mx = t.assign(Mx=np.where(t["run"] == "corner", np.nan, 1.0))
    assert set(no_mx.iloc[select(no_mx, "rolling_runs", "Mx")]["run"]) == {"drive", "held"}


def test_the_drag_and_the_arm_of_fx_are_fitted_where_they_act():
    """The Fx stage's reduction Gxa is the whole of a cornering run's Fx at kappa = 0
    (Gxa(alpha) Fx0(0): the run's drag), and the Mz stage's arm s of Fx acts at alpha = 0 as
    well (a drive/brake run's Mz is -t Fy + Mzr + s Fx): the Fx stage fits the combined
    points and the cornering run's points off zero slip angle, the Mz stage every point with
    a slip ratio, at any slip angle; neither fits a cornering point as combined slip."""
    t = _table(kappa_noise=0.003)
    corner = (t["run"] == "corner").to_numpy()
    a = np.abs(t["alpha"].to_numpy())
    drag = select(t, "drag", "Fx")
    np.testing.assert_array_equal(
        drag, np.flatnonzero((corner & (a > np.deg2rad(0.25)))
                             | np.isin(np.arange(len(t)), select(t, "combined", "Fx"))))
    arm = select(t, "any_kappa", "Mz")
    assert not corner[arm].any()
    np.testing.assert_array_equal(arm, np.flatnonzero(~corner & (np.abs(t["kappa"]) > 0.002)))
    # a session without combined slip: the Mz stage still has its points; Fy has none
    pure = t[(t["run"] == "corner") | (t["alpha"] == 0)].reset_index(drop=True)
    assert select(pure, "any_kappa", "Mz").size == 990
    assert select(pure, "kappa_slip", "Fy").size == 0
    fnomin = float(defaults()["FNOMIN"])
    skipped = {c.stage: c.skipped for c in mf_coverage(pure, fnomin,
                                                       stages=("Fx0", "Fy0", "Mz0", "Fx",
                                                               "Fy", "Mz"))}
    assert skipped == {"Fx0": "", "Fy0": "", "Mz0": "", "Fx": "", "Mz": "",
                       "Fy": "no slip-ratio sweep at a non-zero slip angle (combined slip)"}
