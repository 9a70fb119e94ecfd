"""One model state in ``mfid discover`` (issue 18): every .tir key has one source, accepted
effects reach the problems built on them, and the .tir, discovery.json and the printed
conclusion agree."""
from __future__ import annotations

import re

import numpy as np
import pytest

from identify.discover.library import load_library
from identify.discover.prepared_problem import total_error_pct
from identify.discover.problems import Base, apply_base, trailer_problems
from identify.discover.scenarios import base_tir, make_session
from identify.discover.search import Settings, discover
from identify.discover.stage_problems import label_sweeps, stage_problem
from identify.fit.relations.problems import Context
from identify.workflows.discover import discover_folder
from tests.discover_cases import THESIS, assert_consistent, tir_values


def _discover_session(frame, tir):
    """Discovery on a trailer session's MF problems (no rolling resistance) from ``tir``."""
    ctx = Context(fz0=tir["FNOMIN"], p0_bar=tir["NOMPRES"] / 1e5, tir=tir)
    lib = load_library()
    problems = [apply_base(p, Base(), lib, tir)
                for p in trailer_problems(frame, tir, ctx, with_rr=False)]
    return discover(problems, lib, Settings())


def test_thesis_table_tir_equals_discovery(tmp_path):
    """The thesis table: PCFY3 and PCFY2 accepted on CFy are the .tir's (the relaxation
    problem reads them instead of overwriting them with its own), and the .tir reproduces
    every problem's final error."""
    out = tmp_path / "out"
    run = discover_folder(THESIS, out_dir=out)
    d = run.discovery
    names = [a.name for a in d.accepted]
    assert {"PCFY3", "PCFY2", "PFZ1", "PCFX3"} <= set(names)
    pcfy3 = next(a for a in d.accepted if a.name == "PCFY3").coefficients["PCFY3"]
    assert pcfy3 == pytest.approx(0.475, abs=0.01)
    tir = tir_values(run.tir_path)
    assert tir["PCFY3"] == pcfy3 and tir["PCFY2"] < -0.1
    relax = next(p for p in d.problems if p.name == "CFy/relaxation")
    assert relax.reads == {k: "CFy" for k in ("LATERAL_STIFFNESS", "PCFY1", "PCFY2", "PCFY3")}
    cfy = next(p for p in d.problems if p.name == "CFy")
    for k in relax.reads:
        assert relax.parameters[k] == cfy.parameters[k]
    assert d.sources["PCFY3"] == "CFy" and d.sources["PKY1"] == "CFy/relaxation"
    text = (out / f"{run.tir_path.name}").read_text()
    assert re.search(r"^PCFY3 .*mfid discover CFy", text, re.M)
    assert assert_consistent(out, THESIS, "thesis-225-50R17") == 4
    # issue 19, acceptance 5: a table's printed noise floor is never above its best error
    for p in d.problems:
        assert p.noise_floor_pct <= p.final_error_pct + 1e-12, (p.name, p.floor_source)


def test_fy_effect_reaches_the_moment_stages():
    """A pressure effect on the cornering stiffness accepted on MF/Fy is in the lateral force
    MF/Mz and MF/Mx use: rebuilt from the final state, they reproduce their final errors
    (before the fix they kept the base Fy)."""
    rng = np.random.default_rng(5)
    frame, truth = make_session(rng, 12_000, hidden={"PPY1": 0.6}, rho=0.0)
    tir = base_tir()
    d = _discover_session(frame, tir)
    fy = [a for a in d.accepted if a.problem == "MF/Fy"]
    assert fy and fy[0].name == "PPY1"
    assert fy[0].coefficients["PPY1"] == pytest.approx(0.6, abs=0.05)
    assert d.sources["PPY1"] == "MF/Fy" and d.state["PPY1"] == fy[0].coefficients["PPY1"]
    labelled = label_sweeps(frame)
    for s in d.problems:
        if s.name not in ("MF/Mx", "MF/Mz"):
            continue
        assert "MF/Fy" in s.upstream
        p = stage_problem(s.name.split("/")[1], labelled, {**tir, **d.state})
        pred = p.model({**p.values(), **{k: s.parameters[k] for k in p.parameters}})
        assert total_error_pct(p, pred) == pytest.approx(s.final_error_pct, rel=1e-6)


def test_drift_is_named_as_drift_not_as_a_pressure_law():
    """A 3 % drift of every force along the session and nothing hidden: the drift candidate
    absorbs it and no tyre effect is added (on every MF problem DRIFT is all that is named)."""
    rng = np.random.default_rng(6)
    frame, _ = make_session(rng, 12_000, drift=0.03, rho=0.0)
    d = _discover_session(frame, base_tir())
    names = {a.problem: a.name for a in d.accepted}
    assert names.get("MF/Fy") == "DRIFT" and names.get("MF/Fx") == "DRIFT"
    assert {a.name for a in d.accepted} == {"DRIFT"}, d.conclusion
    drift = next(a for a in d.accepted if a.problem == "MF/Fy")
    assert drift.coefficients["MFID_DRIFT"] == pytest.approx(0.03, abs=0.005)
    assert "MFID_DRIFT" not in d.state
