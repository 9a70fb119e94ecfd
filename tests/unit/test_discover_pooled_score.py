"""The pooled score variance of a pressure candidate (identify.discover.score
.pooled_score_variance) and the shape it pools along (identify.discover.pressure_shape).

The session is the one of test_discover_cluster_score: sweeps at the nominal pressure and a
few at each of four other pressures and two loads, noise correlated along every sweep (AR(1),
phi = 0.95) plus an offset per sweep; the candidate scales the slope with pressure
(G1 = dpi x Fz), its shape is x Fz on every sweep.
"""
from __future__ import annotations

import numpy as np
import pytest

from identify.discover.final_accepted import taken_over_note
from identify.discover.library import Candidate
from identify.discover.noise import Sweeps
from identify.discover.problems import trailer_problems
from identify.discover.scenarios import base_tir, make_session
from identify.discover.score import pooled_score_variance, project_basis, score_candidates
from identify.fit.relations.problems import Context
from tests.unit.test_discover_cluster_score import _session

SIMS = 400
"""Simulated sessions per rate: a rate's binomial standard error is at most 2.5 %."""


def _rates(c1: float, per: int, seed: int) -> tuple[float, float]:
    """(pooled, sweep-robust) rejection rates at the 5 % level of candidate G1."""
    rng = np.random.default_rng(seed)
    hits = np.zeros(2)
    for _ in range(SIMS):
        r, J, cols, sweeps = _session(rng, c1=c1, per=per)
        x = np.tile(np.linspace(-1.0, 1.0, 60), len(sweeps))
        shape = x * J[:, 3]  # x Fz: G1 without its dpi
        g1 = {"G1": cols["G1"]}
        pooled = score_candidates(r, J, g1, kind="cluster", clusters=sweeps,
                                  shapes={"G1": shape})[0]["G1"]
        robust = score_candidates(r, J, g1, kind="cluster", clusters=sweeps)[0]["G1"]
        hits += [pooled.p_value < 0.05, robust.p_value < 0.05]
    return tuple(hits / SIMS)


def test_pooled_variance_of_independent_noise_is_its_variance():
    """Independent N(0, sigma^2) residuals: every sweep's score along a unit shape has the
    variance sigma^2 per unit norm; 200 sweeps of 50 points give kappa near it (relative
    standard error sqrt(2 / 200) = 10 %: within three of them), and the degrees of freedom
    count the sweeps (equal norms: 200)."""
    rng = np.random.default_rng(4)
    sigma, C, m = 0.3, 200, 50
    sweeps = Sweeps(np.repeat(np.arange(C), m))
    h = np.tile(np.sin(np.linspace(0.0, np.pi, m)), C)
    kappa, dof = pooled_score_variance(h, sigma * rng.standard_normal(C * m), sweeps)
    assert kappa == pytest.approx(sigma ** 2, rel=3 * np.sqrt(2.0 / C))
    assert dof == pytest.approx(C)
    assert pooled_score_variance(np.zeros(C * m), np.ones(C * m), sweeps) is None


def test_pooled_test_holds_its_level_where_one_sweep_per_condition_carries_pressure():
    """No pressure effect, eight off-nominal sweeps: the pooled test rejects at its level
    (5 %, within three binomial standard errors of 400 sessions); the sweep-robust one rests
    on the eight and falls well below it."""
    pooled, robust = _rates(0.0, per=1, seed=3)
    assert abs(pooled - 0.05) < 3 * np.sqrt(0.05 * 0.95 / SIMS)
    assert robust < pooled


def test_pooled_test_finds_a_pressure_law_the_sweep_robust_test_misses():
    """A pressure law carried by eight sweeps: the pooled test finds it in about two thirds
    of the sessions, the sweep-robust test in well under half."""
    pooled, robust = _rates(0.3, per=1, seed=3)
    assert pooled > 0.6
    assert pooled > robust + 0.2


def test_shape_is_the_candidate_column_at_one_pressure():
    """``at_pressure`` moves every point of a trailer problem to p0 (1 + dpi): PPY1's column
    there is its shape. At PPY1's neutral value the column is linear in each point's dpi, so
    on the off-nominal points the measured column is the moved one times dpi / 0.2 (to
    rounding), and on the nominal points, where the measured column vanishes, the shape
    does not."""
    frame, _ = make_session(np.random.default_rng(1), samples=4000)
    tir = base_tir()
    ctx = Context(fz0=tir["FNOMIN"], p0_bar=tir["NOMPRES"] / 1e5, tir=tir)
    fy = {p.extra["name"]: p for p in trailer_problems(frame, tir, ctx, with_rr=False)}["MF/Fy"]
    vals = fy.values(fy.x0())
    moved = fy.extra["at_pressure"](vals, 0.2)
    assert moved.measured.size == fy.measured.size
    def column(problem, h=1e-4):  # central difference at PPY1 = 0: exact for a linear term
        up, down = ({**vals, "PPY1": v} for v in (h, -h))
        return (np.asarray(problem.model(up)) - np.asarray(problem.model(down))) / (2 * h)

    col, shape = column(fy), column(moved)
    dpi = fy.pressure_bar * 1e5 / tir["NOMPRES"] - 1.0
    off = np.abs(dpi) > 0.05
    assert off.any() and (~off).any()
    np.testing.assert_allclose(col[off], shape[off] * dpi[off] / 0.2,
                               rtol=1e-6, atol=1e-9 * np.abs(shape).max())
    assert np.abs(col[~off]).max() < 1e-9 * np.abs(shape).max()
    assert np.abs(shape[~off]).max() > 0.1 * np.abs(shape).max()


def test_sweeps_that_carry_the_effect_are_not_controls():
    """A strong pressure law: the off-nominal sweeps' scores along the shape hold it. Pooled
    over the controls only (the nominal sweeps, where the column vanishes) kappa is what the
    nominal sweeps alone give, and the statistic keeps the effect's size; pooled over every
    sweep, the effect inflates kappa and the statistic falls."""
    r, J, cols, sweeps = _session(np.random.default_rng(7), c1=2.0, per=4)
    x = np.tile(np.linspace(-1.0, 1.0, 60), len(sweeps))
    shape, g1 = x * J[:, 3], cols["G1"][:, 0]
    Q = project_basis(J)
    with_g = pooled_score_variance(shape, r, sweeps, g1, Q)
    nominal = np.repeat(np.arange(len(sweeps)) < 30, 60)  # _session puts them first
    alone = pooled_score_variance(shape[nominal], r[nominal],
                                  Sweeps(np.repeat(np.arange(30), 60)), None, Q[nominal])
    assert with_g[0] == pytest.approx(alone[0], rel=1e-12)
    every = pooled_score_variance(shape, r, sweeps, None, Q)
    assert every[0] > 10 * with_g[0]


def test_an_effect_later_additions_took_over_says_so():
    """The drift named first on a session whose pressure blocks follow in time, then the
    pressure terms: its final coefficient 0.002 +- 0.019 is within two standard errors of
    neutral, and the report says the later effects took it over; at 0.12 +- 0.016 it does
    not."""
    drift = Candidate(name="DRIFT", coefficients={"MFID_DRIFT": 0.0},
                      bounds={"MFID_DRIFT": (-1.0, 1.0)}, relations=("MF/*",),
                      equation="F = F_MF (1 + MFID_DRIFT tau)", description="a drift")
    assert "took it over" in taken_over_note(drift, {"MFID_DRIFT": 0.002},
                                             {"MFID_DRIFT": 0.019})
    assert taken_over_note(drift, {"MFID_DRIFT": 0.12}, {"MFID_DRIFT": 0.016}) == ""
    assert taken_over_note(drift, {"MFID_DRIFT": 0.002}, {"MFID_DRIFT": float("nan")}) == ""
