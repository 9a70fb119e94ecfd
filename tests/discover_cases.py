"""Shared checks of discovery outputs: the .tir, discovery.json and the printed conclusion
agree, and the .tir alone reproduces every problem's final error (issue 18)."""
from __future__ import annotations

import json
from pathlib import Path

import pytest

from identify.discover.prepared_problem import total_error_pct
from identify.discover.problems import relation_problems, trailer_problems
from identify.fit.relations.problems import Context
from identify.io.folder import load_folder
from identify.io.tir import read_tir
from identify.workflows.discover import _characteristics

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
    chars = _characteristics(mset, [])  # the tables and the extracted Flatplank runs
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
