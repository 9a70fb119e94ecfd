"""A TTC session generated from a tyre other than the bundled one (the golden test tyre,
tests/data/tir/testA_61.tir: RVY4 = 40, RVY6 = -10, RBY3 = -0.03 against the defaults 20, 10,
0), imported and fitted from the defaults as ``mfid fit`` does: the Fy stage's re-fit with
RVY4..6 (which have no effect until RVY1..3 move) stops at its budget far below the optimum
without them, and must be solved on (identify.fit.mf.stages._continue_refit), not dropped."""
from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from identify.fit.identifiability import unidentified
from identify.fit.mf import stages as mf_stages
from identify.fit.mf.stage_specs import STAGES
from identify.fit.mf.stages import fit_mf
from identify.fit.run import FitSettings
from identify.io.folder import load_folder
from identify.io.tir import read_tir
from identify.model.parameters import defaults
from identify.simulate.ttc import simulate_ttc
from identify.workflows.import_session import import_session
from identify.workflows.sweep_bins import mf_table, segment_settings

TIR = Path(__file__).parents[1] / "data" / "tir" / "testA_61.tir"


@pytest.fixture(scope="module", params=[0, 1], ids=["seed0", "seed1"])
def other_tyre(request, tmp_path_factory):
    """The session of one seed: each test below takes the seed on which its mechanism is
    needed (at seed 0 the Fy re-fit converges within its budget, at seed 1 the Fx0 search's
    PKX2 lies within 2 standard errors of 0, where the other branch is not tried)."""
    root = tmp_path_factory.mktemp("testA")
    truth = read_tir(TIR).params()
    s = simulate_ttc(truth, root / "ttc", seed=request.param)
    out = import_session([f for f in s.files if f.suffix == ".mat"], root / "folder",
                         nominal_pressure_Pa=float(truth["NOMPRES"]),
                         unloaded_radius_m=float(truth["UNLOADED_RADIUS"]))
    mset = load_folder(out.path)
    tyre = mset.manifest.tyre
    base = {k: v for k, v in defaults().items() if not isinstance(v, str)}
    base.update(FNOMIN=float(tyre.nominal_load_N), NOMPRES=float(tyre.nominal_pressure_Pa),
                INFLPRES=float(tyre.nominal_pressure_Pa),
                UNLOADED_RADIUS=float(tyre.unloaded_radius_m))
    settings = FitSettings()
    table, _ = mf_table(mset.trailer, base["FNOMIN"], segment=settings.segment,
                        settings=segment_settings(settings))
    return table, base, truth


@pytest.mark.parametrize("other_tyre", [1], indirect=True)
def test_a_refit_that_stops_at_its_budget_far_below_the_optimum_is_solved_on(other_tyre,
                                                                          monkeypatch):
    """Fy0 then Fy from the defaults: RVY4..6 are freed after the fit and the stage ends
    within 1.5 % (thesis error; measured 0.88 % at seed 1) with RVY4 near the truth's 40
    (39.98); dropped, as before, the re-fit left RVY4 at 20, RBY2 at its bound 100 and a
    10.1 % error. The re-fit's budget is cut to 10 evaluations here, so that it stops far
    below the optimum: at its own 40 it now converges (Fy0 without PEY5, as the screen held it
    before its plausible change scaled with gamma^2, ran into it until the solves went on
    with the dogleg, engine.DOGLEG_AFTER)."""
    table, base, truth = other_tyre
    messages: list[str] = []
    without_pey5 = {"Fy0": [n for n in STAGES["Fy0"].coefficients if n != "PEY5"]}
    monkeypatch.setattr(mf_stages, "REFIT_NFEV", 10)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        mf = fit_mf(table, base, stages=("Fy0", "Fy"), progress=messages.append,
                    free=without_pey5)
    fy = mf.result("Fy")
    assert fy.converged and fy.error_total_pct < 1.5, fy.error_total_pct
    assert {"RVY4", "RVY5", "RVY6"} <= set(fy.free)
    assert any("solved on" in m for m in messages), messages
    assert abs(fy.parameters["RVY4"] - truth["RVY4"]) < 2.0, fy.parameters["RVY4"]


@pytest.mark.parametrize("other_tyre", [0], indirect=True)
def test_fx0_takes_the_better_branch_of_its_load_curve_and_names_the_other(other_tyre):
    """Kx/Fz = (PKX1 + PKX2 dfz) exp(PKX3 dfz): the search, near the defaults (PKX2 > 0),
    ends on the branch PKX2 = 13.3, PKX3 = -0.30 (seed 0); the truth's branch (PKX2 = -10,
    PKX3 = 0.5) fits lower. The re-fit with PKX3 and PEX4 (freed after the global fit), which
    also starts from Latin-hypercube points around the optimum, ends there (measured PKX2 =
    -13.43, PKX3 = 0.601; before those starts, identify.fit.mf.minima.branches took the stage there
    from the mirrored point, to the same values), and the search's end, 2.9 above on the
    intervals' scale, is a rival that leaves PKX2 and PKX3 not identifiable on their own."""
    table, base, truth = other_tyre
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        fx0 = fit_mf(table, base, stages=("Fx0",)).result("Fx0")
    assert fx0.converged
    assert fx0.parameters["PKX2"] < 0 < fx0.parameters["PKX3"], fx0.parameters
    # reached by the re-fit with PKX3 and PEX4 (its Latin-hypercube starts) before the other
    # branch is tried; the test below (seed 1) is the one where identify.fit.mf.minima.branches acts
    assert "re-fitted" in fx0.message
    assert any(r.values.get("PKX2", 0) > 0 for r in fx0.rivals), fx0.rivals
    # a rival names the coefficients it puts outside their reported 95 % interval (t, dof)
    for rival in fx0.rivals:
        for name, value in rival.values.items():
            lo, hi = fx0.interval(name)
            assert not lo <= value <= hi, (name, value, lo, hi)
    # as mfid fit assesses the stage (identify.workflows.fit)
    assert {"PKX2", "PKX3"} <= set(unidentified(fx0)), unidentified(fx0)


@pytest.mark.parametrize("other_tyre", [1], indirect=True)
def test_fx0_tries_the_other_branch_when_it_lies_outside_the_interval(other_tyre):
    """At seed 1 the search ends at PKX2 = 6.2 +- 3.7 (interval [-1.2, 13.5], truth -10): under
    2 standard errors from 0, but the mirrored -6.2 lies outside the interval, so the other
    branch is solved (measured: it fits as well, objective 0.9993 of the search's, and ends at
    PKX2 = -6.6, interval [-14.0, 0.9]); either end leaves PKX2 and PKX3 with a rival on the
    other branch, so neither is reported as identified on its own."""
    table, base, truth = other_tyre
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        fx0 = fit_mf(table, base, stages=("Fx0",)).result("Fx0")
    signs = {np.sign(r.values["PKX2"]) for r in fx0.rivals if "PKX2" in r.values}
    assert -np.sign(fx0.parameters["PKX2"]) in signs, fx0.rivals
    assert {"PKX2", "PKX3"} <= set(unidentified(fx0)), unidentified(fx0)
