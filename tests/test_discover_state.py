"""One model state in ``mfid discover`` (issue 18): every .tir key has one source, accepted
effects reach the problems built on them, and the .tir, discovery.json and the printed
conclusion agree."""
from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from identify.discover.library import load_library
from identify.discover.problems import (Base, apply_base, relation_problems,
                                        trailer_problems)
from identify.discover.scenarios import base_tir, make_session
from identify.discover.search import Settings, discover
from identify.discover.stages import stage_problem
from identify.discover.working import total_error_pct
from identify.fit.relations import Context
from identify.io.folder import load_folder
from identify.io.tir import read_tir
from identify.workflows.discover import discover_folder

ROOT = Path(__file__).resolve().parents[1]
THESIS = ROOT / "measurements" / "thesis-225-50R17"


def tir_values(path: Path) -> dict[str, float]:
    return {k: float(v) for k, v in read_tir(path).params().items()
            if isinstance(v, (int, float))}


def _problem_values(name: str, params, tir: dict) -> dict | None:
    """The problem's parameters from the .tir (None when one is not a .tir key)."""
    if name == "CMz":  # T1 nested in T2: the .tir's form back to the problem's
        t2 = tir["CMZ_FORM"] == 2
        return {"YAW_STIFFNESS": tir["YAW_STIFFNESS"],
                "PCMZ1": tir["PCMZ3"] if t2 else tir["PCMZ1"],
                "PCMZ2": tir["PCMZ2"] if t2 else 0.0}
    if not all(k in tir for k in params):
        return None
    return {k: tir[k] for k in params}


def assert_consistent(out: Path, folder: Path, tyre_id: str) -> int:
    """Every accepted coefficient of discovery.json is the .tir's value, the printed
    coefficients are those, and every problem evaluated with the .tir alone has the final
    error discovery.json reports. Returns the number of problems checked."""
    doc = json.loads((out / "discovery.json").read_text())
    tir = tir_values(out / f"{tyre_id}.tir")
    for a in doc["accepted"]:
        for k, v in a["coefficients"].items():
            assert tir[k] == v, (a["name"], k, tir[k], v)
            assert f"{k} = {v:.3g}" in doc["conclusion"]
    for k, v in doc["model"]["parameters"].items():
        if k in tir and not k.startswith("PCMZ"):
            assert tir[k] == v, k
    mset = load_folder(folder)
    chars = mset.characteristics if mset.characteristics is not None else pd.DataFrame()
    if len(chars) and ("p_Pa" not in chars or chars["p_Pa"].isna().any()):
        chars = chars.assign(p_Pa=chars["pi_bar"] * 1e5)
    ctx = Context(fz0=tir["FNOMIN"], p0_bar=tir["NOMPRES"] / 1e5, tir=tir)
    built = {p.extra["name"]: p for p in relation_problems(chars, ctx)}
    built.update({p.extra["name"]: p for p in trailer_problems(mset.trailer, tir, ctx)})
    checked = 0
    for s in doc["base"]["problems"]:
        p = built[s["name"]]
        vals = _problem_values(s["name"], p.parameters, tir)
        if vals is None:
            continue  # a parameter that is not a .tir key (sidewall F0_*)
        pred = p.model({**p.values(), **vals})
        assert total_error_pct(p, pred) == pytest.approx(s["final_error_pct"], rel=1e-6), \
            s["name"]
        checked += 1
    return checked


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


def test_fy_effect_reaches_the_moment_stages():
    """A pressure effect on the cornering stiffness accepted on MF/Fy is in the lateral force
    MF/Mz and MF/Mx use: rebuilt from the final state, they reproduce their final errors
    (before the fix they kept the base Fy)."""
    rng = np.random.default_rng(5)
    frame, truth = make_session(rng, 12_000, hidden={"PPY1": 0.6}, rho=0.0)
    tir = base_tir()
    ctx = Context(fz0=tir["FNOMIN"], p0_bar=tir["NOMPRES"] / 1e5, tir=tir)
    lib = load_library()
    problems = [apply_base(p, Base(), lib, tir)
                for p in trailer_problems(frame, tir, ctx, with_rr=False)]
    d = discover(problems, lib, Settings())
    fy = [a for a in d.accepted if a.problem == "MF/Fy"]
    assert fy and fy[0].name == "PPY1"
    assert fy[0].coefficients["PPY1"] == pytest.approx(0.6, abs=0.05)
    assert d.sources["PPY1"] == "MF/Fy" and d.state["PPY1"] == fy[0].coefficients["PPY1"]
    from identify.discover.stages import label_sweeps
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
    absorbs it; no pressure coefficient is named with confidence, none reaches the state."""
    rng = np.random.default_rng(6)
    frame, _ = make_session(rng, 12_000, drift=0.03, rho=0.0)
    tir = base_tir()
    ctx = Context(fz0=tir["FNOMIN"], p0_bar=tir["NOMPRES"] / 1e5, tir=tir)
    lib = load_library()
    problems = [apply_base(p, Base(), lib, tir)
                for p in trailer_problems(frame, tir, ctx, with_rr=False)]
    d = discover(problems, lib, Settings())
    names = {a.problem: a.name for a in d.accepted}
    assert names.get("MF/Fy") == "DRIFT" and names.get("MF/Fx") == "DRIFT"
    assert all(a.name == "DRIFT" or a.ambiguous_with for a in d.accepted), d.conclusion
    drift = next(a for a in d.accepted if a.problem == "MF/Fy")
    assert drift.coefficients["MFID_DRIFT"] == pytest.approx(0.03, abs=0.005)
    assert "MFID_DRIFT" not in d.state
