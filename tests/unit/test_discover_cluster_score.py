"""The cluster-robust score test where few sweeps carry a pressure law (a TTC session: many
sweeps at the nominal pressure, two or three at each other one).

A small linear problem built like such a session: 30 sweeps at the nominal pressure and two
sweeps at each of four other pressures and two loads, noise correlated along every sweep
(AR(1), phi = 0.95) plus an offset per sweep; the base model fits an offset, the load terms
and the slope; the candidates scale the slope with pressure ("PPY1": G1 = dpi x Fz) and move
its load dependence with pressure ("PPY2": G2 = dpi x x Fz^2), and their block.
"""
from __future__ import annotations

import numpy as np
import pytest

from identify.discover.noise import Sweeps
from identify.discover.score import left_out_score_variance, project_basis, score_candidates

PRESSURES = (-0.3, -0.15, 0.15, 0.3)
"""dpi of the off-nominal sweeps [-]."""
LOADS = (0.6, 1.4)
"""Fz / Fz0 of the sweeps [-]."""


def _session(rng, c1: float = 0.0, c2: float = 0.0, n_nominal: int = 30, per: int = 2,
             m: int = 60, phi: float = 0.95):
    """(residuals of the base fit, its Jacobian, candidate columns, sweeps)."""
    cond = [(0.0, LOADS[k % 2]) for k in range(n_nominal)]
    cond += [(dp, fz) for dp in PRESSURES for fz in LOADS for _ in range(per)]
    x = np.tile(np.linspace(-1.0, 1.0, m), len(cond))
    dp = np.repeat([c[0] for c in cond], m)
    fz = np.repeat([c[1] for c in cond], m)
    z = rng.standard_normal((len(cond), m))
    e = np.empty_like(z)
    e[:, 0] = z[:, 0]
    for t in range(1, m):
        e[:, t] = phi * e[:, t - 1] + np.sqrt(1 - phi ** 2) * z[:, t]
    noise = 0.1 * e.ravel() + 0.05 * np.repeat(rng.standard_normal(len(cond)), m)
    J = np.column_stack([np.ones_like(x), x * fz, np.sin(2 * x) * fz, fz, x * fz ** 2])
    g1, g2 = dp * x * fz, dp * x * fz ** 2
    y = J @ np.array([0.1, 1.0, 0.3, 0.2, -0.1]) + c1 * g1 + c2 * g2 + noise
    beta, *_ = np.linalg.lstsq(J, y, rcond=None)
    cols = {"G1": g1[:, None], "G2": g2[:, None], "G1+G2": np.column_stack([g1, g2])}
    return J @ beta - y, J, cols, Sweeps(np.repeat(np.arange(len(cond)), m))


def _scores(rng, **effect):
    r, J, cols, sweeps = _session(rng, **effect)
    return score_candidates(r, J, cols, kind="cluster", clusters=sweeps)[0]


def test_a_consistent_effect_is_not_capped_by_the_sweeps_that_carry_it():
    """Sixteen sweeps carry the pressure law. Each sweep's raw score holds the effect: the
    uncentred sum of their squares capped W = (sum s_c)^2 / sum s_c^2 below 16 however strong
    the effect. Centred at the other sweeps' estimate, the statistic grows with the effect
    (about as its square) and its p-value falls."""
    stats = {}
    for c1 in (1.0, 2.0):
        r, J, cols, sweeps = _session(np.random.default_rng(11), c1=c1)
        Q = project_basis(J)
        g = cols["G1"] - Q @ (Q.T @ cols["G1"])
        s_c = sweeps.sums(g[:, 0] * r)
        uncentred = s_c.sum() ** 2 / (len(sweeps) / (len(sweeps) - 1) * (s_c @ s_c))
        assert uncentred < 16.0  # the cap of the test before
        sc = score_candidates(r, J, cols, kind="cluster", clusters=sweeps)[0]["G1"]
        assert sc.statistic > 10 * uncentred and sc.p_value < 1e-4
        assert sc.step[0] == pytest.approx(c1, rel=0.1)
        stats[c1] = sc.statistic
    assert stats[2.0] > 3.0 * stats[1.0]


def test_an_effect_spread_over_two_correlated_columns_is_found_by_their_block():
    """The effect moves the slope and its load dependence with pressure (both columns, which
    are correlated, carry it); the block of the two is significant."""
    rng = np.random.default_rng(12)
    r, J, cols, _ = _session(rng)
    Q = project_basis(J)
    a, b = (c - Q @ (Q.T @ c) for c in (cols["G1"], cols["G2"]))
    cos = float(a[:, 0] @ b[:, 0] / np.linalg.norm(a) / np.linalg.norm(b))
    assert abs(cos) > 0.5  # correlated candidates
    hits = [_scores(rng, c1=0.6, c2=0.5)["G1+G2"].p_value < 1e-3 for _ in range(10)]
    assert sum(hits) >= 9


@pytest.mark.parametrize("name", ["G1", "G2", "G1+G2"])
def test_null_rejects_at_its_level_with_few_sweeps_per_pressure(name):
    """Nothing hidden: the share of p-values below 0.05 stays near 0.05 (referred to
    F(q, C - 1), the centred test rejects well above that here, as few sweeps carry the
    variance; the Satterthwaite degrees of freedom of those sweeps keep the level)."""
    rng = np.random.default_rng(13)
    p = np.array([_scores(rng)[name].p_value for _ in range(200)])
    assert 0.015 <= np.mean(p < 0.05) <= 0.085


def test_degrees_of_freedom_count_the_sweeps_that_carry_the_candidate():
    """Equal sweeps: C - 1 (capped); one sweep carrying nearly everything: about 1."""
    rng = np.random.default_rng(14)
    g = rng.standard_normal((400, 1))
    r = rng.standard_normal(400)
    even = Sweeps(np.repeat(np.arange(20), 20))
    _, dof = left_out_score_variance(g, r, even)
    assert 15.0 < dof <= 19.0
    lopsided = g.copy()
    lopsided[20:] *= 1e-3
    _, dof1 = left_out_score_variance(lopsided, r, even)
    assert dof1 < 1.1


def test_reported_standard_errors_honour_the_correlation_along_the_sweeps():
    """The standard errors discovery prints beside an accepted coefficient are the confirming
    test's cluster-robust ones where the noise runs along the sweeps: with AR(1) noise at
    phi = 0.95 and an offset per sweep, a sweep of 60 samples holds about one independent
    sample of a coefficient that is constant along it (the load term), whose residual-variance
    error is then about sqrt(60 / 2) ~ 5 times too small."""
    from identify.discover.conclude import standard_errors
    from identify.fit.solve.engine import covariance

    r, J, _, sweeps = _session(np.random.default_rng(5), c1=0.0)
    names = ["offset", "slope", "shape", "load", "slope_load"]
    robust = standard_errors(J, r, names, sweeps)
    plain = standard_errors(J, r, names)
    cov = covariance(J, r, clusters=sweeps)
    assert robust["load"] == pytest.approx(np.sqrt(cov[3, 3]), rel=1e-12)
    assert robust["load"] > 3.0 * plain["load"]
