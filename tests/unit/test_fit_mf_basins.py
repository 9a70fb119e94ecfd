"""The MF stage search reports the lowest minimum it can reach (identify.fit.mf.stages, issue 14).

A generated Fx0 stage like a TTC session's drive/brake run (slip-ratio sweeps to |kappa| =
0.146, just past the force peak; 5 loads x 3 pressures x 2 cambers, 1 % noise) has two
minima a fraction of a per cent apart: the truth's (PCX1 = 1.6, PEX1 = 0.3) side and one at a
higher PCX1 and PEX1 with a smaller PEX4, the two trading the post-peak fall-off the sweeps
barely reach. The search's starts find both. With PEX4 held (no effect while PEX1 = 0 at the
start) the high-PCX1 one is the lower; once PEX4 is freed (the re-fit after the global fit) the
other one is. The reported optimum must be at least as low as a local solve started at the
truth's coefficients.
"""
from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from identify.fit.identifiability import POOR, assess
from identify.fit.mf.minima.branches import other_branch
from identify.fit.mf.search import search, start_points
from identify.fit.mf.stages import fit_mf, stage_problem
from identify.fit.optimize import fit
from identify.io.tir import read_tir
from identify.model.evaluate import evaluate
from identify.model.modes import FIT_MODE
from identify.model.parameters import defaults
from identify.simulate import default_tir_path

NOISE = 0.01
"""Noise of Fx, standard deviation relative to the largest |Fx| (the TTC generator's level)."""
NOISE_SEED = 120
"""One of the 3 of 40 noise seeds (100-139) where the search before the re-fit from its other
candidates reported the higher minimum (the objective 1.4e-3 above; one-off scan)."""


def _fx0_table(truth: dict[str, float], seed: int, noise: float = NOISE) -> pd.DataFrame:
    """Pure longitudinal-slip sweeps with noisy Fx [N] from ``truth`` (useMode 211); ``noise``
    relative to the largest |Fx|."""
    rows = []
    kappa = np.linspace(-0.146, 0.146, 41)
    for pf in (0.85, 1.0, 1.15):
        for lf in (0.5, 0.75, 1.0, 1.25, 1.5):
            for gamma_deg in (0.0, 2.0):
                rows.append(pd.DataFrame({
                    "run": "drive_brake", "Fz": lf * truth["FNOMIN"], "p": pf * truth["NOMPRES"],
                    "Vx": 11.1, "kappa": kappa, "alpha": 0.0, "gamma": np.deg2rad(gamma_deg)}))
    t = pd.concat(rows, ignore_index=True)
    fx = np.asarray(evaluate(truth, *(t[c].to_numpy() for c in ("Fz", "kappa", "alpha", "gamma",
                                                                   "Vx")),
                             p=t["p"].to_numpy(), mode=FIT_MODE)["Fx"])
    rng = np.random.default_rng(seed)
    return t.assign(Fx=fx + noise * np.max(np.abs(fx)) * rng.standard_normal(fx.size))


def _truth_and_start() -> tuple[dict[str, float], dict[str, float]]:
    """The bundled tyre (the TTC generator's truth), and the table defaults with its nominal
    conditions (the start of mfid fit)."""
    truth = read_tir(default_tir_path()).params()
    start = {k: float(v) for k, v in defaults().items() if not isinstance(v, str)}
    start.update({k: truth[k] for k in ("FNOMIN", "NOMPRES", "INFLPRES", "UNLOADED_RADIUS",
                                         "LONGVL")})
    return truth, start


@pytest.fixture(scope="module")
def case():
    truth, start = _truth_and_start()
    table = _fx0_table(truth, NOISE_SEED)
    mf = fit_mf(table, start, stages=("Fx0",), seed=1)
    return truth, start, table, mf.result("Fx0")


def test_fx0_reports_the_lower_of_two_minima(case):
    truth, start, table, result = case
    # a local solve of the same problem (the same free coefficients) from the truth's values
    hold = {n: "held in the fit" for n in result.parameters if n not in result.free}
    sp = stage_problem("Fx0", table, {**start, **{n: truth[n] for n in result.free}},
                       free={"Fx0": list(result.parameters)}, hold=hold)
    assert sp.problem.free == result.free
    from_truth = fit(sp.problem, starts=sp.problem.x0()[None, :])
    # the other minimum is 1.4e-3 above in relative objective (about 1.7 in chi^2 units of
    # the 1230 points); the solves' own stop leaves well under 1e-5
    assert result.wls <= from_truth.wls * (1 + 1e-5), (result.parameters, from_truth.parameters)
    assert result.parameters["PCX1"] < 1.6  # the truth's side: the other minimum has 1.9


def test_search_keeps_two_minima_whose_objectives_differ_by_little():
    """At 0.1 % noise the two minima's objectives (0.5 r^T r of the pressure-weighted
    residuals, 3.0e-6) differ by 1e-10, 3e-5 of the objective and far below
    identify.fit.optimize.BEST_ATOL (1e-8): still two optima, both candidates."""
    truth, start = _truth_and_start()
    p = stage_problem("Fx0", _fx0_table(truth, NOISE_SEED, noise=0.001), start).problem
    found = search(p, start_points(p, 2, 1))
    pcx1 = sorted(float(c[p.free.index("PCX1")]) for c in found.candidates)
    assert len(pcx1) == 2 and pcx1[1] - pcx1[0] > 0.1, pcx1
    objs = [p.objective_value(c) for c in found.candidates]
    assert abs(objs[0] - objs[1]) < 1e-8
    assert found.starts_at_best < found.n_starts


def test_the_other_minimum_within_the_95_percent_region_is_reported(case):
    """The other basin (chi^2 about 1.7 above the reported one, within a 95 % region of 3.84)
    is kept as a rival, and the coefficients it puts outside their intervals are not
    identifiable on their own: their linearised intervals here miss the truth (PCX1 1.6)."""
    truth, _, _, result = case
    basins = [r for r in result.rivals if "PCX1" in r.values]
    assert len(basins) == 1
    # the only other one: the solve from the other branch of the slip-stiffness load curve
    # (identify.fit.mf.minima.branches) ends at PKX2 ~ 0 as low as the optimum, PKX2 = 0.002: the
    # data do not fix PKX2's sign (it is also correlated 0.997 with PKX3)
    assert all(set(r.values) == {"PKX2"} for r in result.rivals if r not in basins)
    rival = basins[0]
    assert 0.5 < rival.dchi2 < 3.84
    assert {"PCX1", "PEX1"} <= set(rival.values)
    lo, hi = result.interval("PCX1")
    assert not lo <= truth["PCX1"] <= hi  # the linearised interval misses the truth
    assessed = assess(result)
    assert assessed.identification == POOR
    for name in ("PCX1", "PEX1"):
        assert assessed.unidentified[name].startswith("another minimum within the 95 % region")
    assert any("another minimum" in why for why in assessed.reasons)


def test_the_other_branch_draws_the_same_value_and_slope_at_nominal_load():
    """(c0 + c1 dfz) exp(c2 dfz) and its mirror (c1 -> -c1, c2 -> c2 + 2 c1 / c0) agree in
    value and slope at dfz = 0 (central differences, 1e-9 relative) and differ only in
    curvature (the golden tyre's PKX1..3 = 30, -10, 0.5); no mirror for a stage
    without a load curve or with c0 or c1 at 0."""
    c0, c1, c2 = 30.0, -10.0, 0.5
    mirror = other_branch("Fx0", {"PKX1": c0, "PKX2": c1, "PKX3": c2})
    assert set(mirror) == {"PKX2", "PKX3"} and mirror["PKX2"] == -c1

    def curve(b, c, dfz):
        return (c0 + b * dfz) * np.exp(c * dfz)

    h = 1e-5
    for b, c in ((c1, c2), (mirror["PKX2"], mirror["PKX3"])):
        assert curve(b, c, 0.0) == c0
        slope = (curve(b, c, h) - curve(b, c, -h)) / (2 * h)
        np.testing.assert_allclose(slope, c1 + c0 * c2, rtol=1e-9)
    assert other_branch("Fy0", {"PKX1": c0, "PKX2": c1, "PKX3": c2}) is None
    assert other_branch("Fx0", {"PKX1": 0.0, "PKX2": c1, "PKX3": c2}) is None
    assert other_branch("Fx0", {"PKX1": c0, "PKX2": 0.0, "PKX3": c2}) is None


def test_noise_free_data_fitted_from_the_truth_end_there():
    """Fx data without noise, fitted from the truth's values: the optimum is exact (objective
    0, so a residual variance of 0), and the other branch's solve is compared with it without
    dividing by that 0 (it raised ZeroDivisionError)."""
    truth, _ = _truth_and_start()
    fx0 = fit_mf(_fx0_table(truth, 0, noise=0.0), truth, stages=("Fx0",), seed=1).result("Fx0")
    assert fx0.converged and fx0.wls == 0.0
    assert fx0.parameters["PKX2"] == truth["PKX2"]
