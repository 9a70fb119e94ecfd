"""A TTC session generated from a tyre other than the bundled one (the golden test tyre,
tests/data/tir/testA_61.tir: RVY4 = 40, RVY6 = -10, RBY3 = -0.03 against the defaults 20, 10,
0), imported and fitted from the defaults as ``mfid fit`` does: the Fy stage's re-fit with
RVY4..6 (which have no effect until RVY1..3 move) stops at its budget far below the optimum
without them, and must be solved on (identify.fit.mf_stages._continue_refit), not dropped."""
from __future__ import annotations

import warnings
from pathlib import Path

import pytest

from identify.fit.identifiability import unidentified
from identify.fit.mf_stage_defs import STAGES
from identify.fit.mf_stages import fit_mf
from identify.fit.run import FitSettings
from identify.io.folder import load_folder
from identify.io.tir import read_tir
from identify.model.parameters import defaults
from identify.simulate.ttc import simulate_ttc
from identify.workflows.import_session import import_session
from identify.workflows.sweep_bins import mf_table

TIR = Path(__file__).parent / "data" / "tir" / "testA_61.tir"


@pytest.fixture(scope="module")
def other_tyre(tmp_path_factory):
    root = tmp_path_factory.mktemp("testA")
    truth = read_tir(TIR).params()
    s = simulate_ttc(truth, root / "ttc", seed=0)
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
                        alpha_deg=settings.bin_alpha_deg, kappa=settings.bin_kappa)
    return table, base, truth


def test_a_refit_that_stops_at_its_budget_far_below_the_optimum_is_solved_on(other_tyre):
    """Fy0 then Fy from the defaults: RVY4..6 are freed after the fit and the stage ends
    within 1.5 % (thesis error; measured 0.80 %, the noise is 1 %) with RVY4 near the
    truth's 40 (measured 40.07); dropped, as before, the re-fit left RVY4 at 20, RBY2 at its
    bound 100 and a 10.1 % error. Fy0 is fitted without PEY5, as the screen held it before
    its plausible change scaled with gamma^2 (identify.fit.mf_screen): with PEY5 free, Fy0
    ends closer to the truth (0.87 % against 1.01 %) and the Fy re-fit converges within its
    budget (0.78 %, RVY4 = 40.07), so the budget case this test is about does not arise;
    without it the re-fit stops 70 times below the optimum and is solved on (one-off,
    2026-11-24)."""
    table, base, truth = other_tyre
    messages: list[str] = []
    without_pey5 = {"Fy0": [n for n in STAGES["Fy0"].coefficients if n != "PEY5"]}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        mf = fit_mf(table, base, stages=("Fy0", "Fy"), progress=messages.append,
                    free=without_pey5)
    fy = mf.result("Fy")
    assert fy.converged and fy.error_total_pct < 1.5, fy.error_total_pct
    assert {"RVY4", "RVY5", "RVY6"} <= set(fy.free)
    assert any("solved on" in m for m in messages), messages
    assert abs(fy.parameters["RVY4"] - truth["RVY4"]) < 2.0, fy.parameters["RVY4"]


def test_fx0_takes_the_better_branch_of_its_load_curve_and_names_the_other(other_tyre):
    """Kx/Fz = (PKX1 + PKX2 dfz) exp(PKX3 dfz): the search, near the defaults (PKX2 > 0),
    ends on the branch PKX2 = 12.4, PKX3 = -0.27; the truth's branch (PKX2 = -10, PKX3 = 0.5)
    fits 18 lower in iid chi^2. The stage is solved from the mirrored point
    (identify.fit.mf_branches): it ends there (measured PKX2 = -12.49, PKX3 = 0.572), and the
    search's end, 2.3 above on the intervals' scale, is a rival that leaves PKX2 and PKX3 not
    identifiable on their own."""
    table, base, truth = other_tyre
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        fx0 = fit_mf(table, base, stages=("Fx0",)).result("Fx0")
    assert fx0.converged
    assert fx0.parameters["PKX2"] < 0 < fx0.parameters["PKX3"], fx0.parameters
    assert "other branch" in fx0.message
    assert any(r.values.get("PKX2", 0) > 0 for r in fx0.rivals), fx0.rivals
    # as mfid fit assesses the stage (identify.workflows.fit)
    assert {"PKX2", "PKX3"} <= set(unidentified(fx0)), unidentified(fx0)
