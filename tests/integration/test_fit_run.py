"""fit.json as typed data: ``FitRun.from_dict(doc).to_dict() == doc`` for the documents the
bundled folders produce, the fit-directory reader and writer, and the notebook conveniences.

Real documents: the sample folder's CFx fits (from raw Flatplank runs: flags, extraction.json
and 750 input checksums), an MF fit of the sample's three braking/driving trailer runs (the
Fx0, Mx and My stages), a discovery run's fit.json, the thesis folder's CFx table, and
(tests/integration/test_cli_fit.py) the thesis folder with ``--mcmc --mcmc-max-steps 500`` and a
failed fit. The whole sample folder was round-tripped by hand (see the commit message). Each slow
fixture is used by one test only, so that pytest-xdist workers do not build it twice.
"""
from __future__ import annotations

import dataclasses
import json
import math
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from identify.core.errors import InputError
from identify.core.jsonsafe import json_float, json_safe, json_text
from identify.core.tyre import TyreInfo
from identify.fit.identifiability import problems, unidentified
from identify.fit.result import FitResult, MCMCSummary, Rival
from identify.fit.run import SCHEMA, FitRun, FitSettings, Provenance
from identify.fit.solve import engine
from identify.io.fitdir import read_fit_dir, write_fit_dir
from identify.io.tir.write import FIT_DIGITS
from identify.workflows.discover import discover_folder
from identify.workflows.fit import fit_folder

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "measurements" / "sample-225-50R17"
THESIS = ROOT / "measurements" / "thesis-225-50R17"


def _doc(run: FitRun) -> dict:
    return json.loads(run.json_path.read_text(encoding="utf-8"))


def _round_trips(doc: dict) -> FitRun:
    run = FitRun.from_dict(doc)
    assert run.to_dict() == doc
    assert FitRun.from_dict(run.to_dict()) == run
    return run


# ----------------------------------------------------------------- real documents

@pytest.fixture(scope="module")
def thesis_tables(tmp_path_factory) -> FitRun:
    """The thesis folder's CFx characteristics (a few seconds)."""
    out = tmp_path_factory.mktemp("fits")
    return fit_folder(THESIS, out_root=out, settings=FitSettings(only=("CFx",)))


def _sample_mf(folder: Path) -> FitRun:
    """MF stages on the sample's braking/driving runs only (three pressures)."""
    (folder / "trailer").mkdir(parents=True)
    text = (SAMPLE / "tyre.toml").read_text()
    head, *runs = text.split("[[runs]]")
    keep = [r for r in runs if 'test = "braking_driving"' in r]
    assert len(keep) == 3
    (folder / "tyre.toml").write_text(head + "".join("[[runs]]" + r for r in keep))
    for r in keep:
        name = r.split('file = "')[1].split('"')[0]
        shutil.copy(SAMPLE / name, folder / name)
    return fit_folder(folder, out_root=folder.parent / "fits", settings=FitSettings(only=("MF",)))


def _same_results(typed: FitRun, run: FitRun) -> None:
    """Every number of every fit survives fit.json exactly."""
    assert typed.names == run.names
    for a, b in zip(typed.results, run.results):
        assert a.parameters == b.parameters and a.stderr == b.stderr
        assert a.error_by_pressure_pct == b.error_by_pressure_pct
        assert a.error_total_pct == b.error_total_pct and a.bounds == b.bounds
        assert a == b  # compare=False leaves out the per-point arrays only


def test_sample_relation_fit_round_trips_and_reads_back(tmp_path):
    run = fit_folder(SAMPLE, out_root=tmp_path / "fits", settings=FitSettings(only=("CFx",)))
    doc = _doc(run)
    typed = _round_trips(doc)
    assert doc["schema"] == SCHEMA and typed.ok and run.ok
    assert typed.names == ("CFx/linear_load", "CFx/quadratic_load")
    _same_results(typed, run)
    assert typed.flags == run.flags and typed.key_sources == run.key_sources
    assert typed.tyre == TyreInfo("sample-225-50R17", 250000.0, 5000.0, 0.3205, "simulated",
                                  "225/50 R17")
    assert typed.settings == FitSettings(only=("CFx",))
    assert typed.provenance.inputs == run.provenance.inputs
    assert len(typed.provenance.inputs) > 700  # every raw run file with its checksum
    # the directory reads back: the typed run, the per-point arrays from the CSV, the .tir
    fd = read_fit_dir(run.fit_dir)
    assert fd.run == run and fd.run.fit_dir == run.fit_dir and fd.notes == ()
    assert fd.extraction is not None and fd.extraction["runs"]
    # the .tir holds FIT_DIGITS significant digits: half a unit of the last one at most
    assert fd.run.tir_values["LONGITUDINAL_STIFFNESS"] == pytest.approx(
        run.tir_values["LONGITUDINAL_STIFFNESS"], rel=0.5 * 10.0 ** (1 - FIT_DIGITS))
    for a, b in zip(fd.run.results, run.results):
        assert a.measured.size == a.n_points == b.measured.size
        np.testing.assert_allclose(a.measured, b.measured, rtol=1e-14)
        np.testing.assert_allclose(a.predicted, b.predicted, rtol=1e-14)
        np.testing.assert_array_equal(a.pressure_bar, b.pressure_bar)
    # and writes again to the same files
    again = write_fit_dir(fd.run, tmp_path / "again", points=fd.points,
                          extraction=fd.extraction)
    assert sorted(p.name for p in again.fit_dir.iterdir()) == [
        "extraction.json", "fit.json", "measured_vs_model.csv", "sample-225-50R17.tir"]
    for name in ("fit.json", "extraction.json", "sample-225-50R17.tir"):
        assert (again.fit_dir / name).read_text() == (run.fit_dir / name).read_text(), name
    assert not list(again.fit_dir.glob(".*"))


def test_sample_mf_stages_round_trip(tmp_path):
    run = _sample_mf(tmp_path / "sample-bd")
    typed = _round_trips(_doc(run))
    assert typed.names == ("MF/Fx0", "MF/Mx", "MF/My") and typed.ok
    _same_results(typed, run)
    fitted = [s for s in typed.key_sources.values() if s.kind == "fitted"]
    assert fitted and all(s.detail.startswith("MF/") for s in fitted)
    with pytest.raises(KeyError, match=r"'MF' is ambiguous: give relation/form, one of "
                                       r"MF/Fx0, MF/Mx, MF/My"):
        run.result("MF")
    fd = read_fit_dir(run.fit_dir)
    csv = pd.read_csv(run.csv_path)
    for r in fd.run.results:
        rows = csv[(csv.relation == "MF") & (csv.form == r.form)]
        assert r.measured.size == len(rows) > 0
        np.testing.assert_array_equal(r.predicted, rows["model"].to_numpy(float))


def test_discovery_fit_json_round_trips(tmp_path):
    run = discover_folder(THESIS, only=("CFx",), out_dir=tmp_path, command="mfid discover")
    doc = json.loads(run.fit_json_path.read_text())
    typed = _round_trips(doc)
    assert typed.settings is None and typed.provenance.command == "mfid discover"
    assert typed.names == ("CFx/linear_load",)
    assert typed.tir_name == "thesis-225-50R17.tir" and (tmp_path / typed.tir_name).is_file()
    assert run.fit_run == typed
    # discovery.json keeps its provenance without a settings entry (its settings are its own)
    assert "settings" not in json.loads(run.json_path.read_text())["provenance"]


# ----------------------------------------------------------------- the fit directory

def test_thesis_tables_round_trip(thesis_tables):
    typed = _round_trips(_doc(thesis_tables))
    _same_results(typed, thesis_tables)
    assert typed.flags == () and typed.failed == ()


def test_write_error_names_the_file_and_leaves_no_temporary(thesis_tables, tmp_path):
    fd = read_fit_dir(thesis_tables.fit_dir)
    out = tmp_path / "f"
    (out / "measured_vs_model.csv").mkdir(parents=True)  # a file cannot replace a directory
    with pytest.raises(InputError, match="measured_vs_model.csv"):
        write_fit_dir(fd.run, out, points=fd.points)
    assert not list(out.glob(".*.tmp"))


@pytest.mark.parametrize("mutate, key", [
    (lambda d: d["fits"][0].pop("relation"), "fits[0]"),
    (lambda d: d["fits"][1].update(n_points="many"), "fits[1]"),
    (lambda d: d.pop("tyre"), "tyre"),
    (lambda d: d["provenance"].update(settings={"colour": "red"}), "provenance"),
])
def test_malformed_fit_json_names_the_entry(thesis_tables, tmp_path, mutate, key):
    root = tmp_path / "f"
    shutil.copytree(thesis_tables.fit_dir, root)
    doc = _doc(thesis_tables)
    mutate(doc)
    (root / "fit.json").write_text(json.dumps(doc))
    with pytest.raises(InputError) as err:
        read_fit_dir(root)
    assert err.value.key == key and err.value.file == str(root / "fit.json")
    assert "\n" not in str(err.value)


# ----------------------------------------------------------------- conveniences

def test_result_by_name_and_report(thesis_tables):
    run = thesis_tables
    assert run.result("CFx/quadratic_load").form == "quadratic_load"
    # a relation alone: the form whose coefficients went into the .tir (the thesis CFx curves
    # in load: the data choose the quadratic form)
    assert run.result("CFx").name == run.key_sources["PCFX1"].supplied_by == \
        "CFx/quadratic_load"
    assert run.form_choice("CFx").form == "quadratic_load"
    with pytest.raises(KeyError, match=r"no fit named 'MF/Fy0'; the fits are: CFx/linear_load"):
        run.result("MF/Fy0")
    text = run.report()
    lines = text.splitlines()
    assert lines[0].startswith("fit summary")
    assert len(lines) == 3 + len(run.results) + len(run.form_choices)
    row = lines[3].split()
    assert row[:5] == ["CFx", "linear_load", f"{run.results[0].error_total_pct:.3f}", "15", "ok"]
    assert row[5].startswith("LONGITUDINAL_STIFFNESS=")  # not in the .tir
    row = lines[4].split()
    assert row[:2] == ["CFx", "quadratic_load"] and row[5] == "x*"
    assert lines[3 + len(run.results)].startswith("form CFx: quadratic_load (chosen by the data)")
    failed = dataclasses.replace(run, failed=("CFx[linear_load]: no",))
    assert failed.report().endswith("FAILED CFx[linear_load]: no") and not failed.ok


# ----------------------------------------------------------------- small parts

def _result(**kw) -> FitResult:
    base = {"relation": "CFx", "form": "linear_load", "objective": "thesis",
            "parameters": {"A": 1.5, "B": np.float64(2.0), "C": np.nan},
            "free": ("A", "C"), "stderr": {"A": 0.1, "C": np.inf},
            "bounds": {"A": (0.0, np.inf), "C": (-np.inf, np.inf)}, "at_bound": ("A",),
            "active_constraints": (), "error_total_pct": 1.25,
            "error_by_pressure_pct": {1.9: 1.0, 2.5: 1.5}, "wls": 0.5,
            "n_points": np.int64(4), "converged": True, "message": "ok", "n_starts": 3,
            "starts_at_best": 2, "correlations": {"A|C": np.nan}, "predicted": np.ones(4),
            "measured": np.ones(4), "pressure_bar": np.full(4, 2.5), "seconds": 0.25,
            "nfev": 17, "status": 2}
    base.update(kw)
    return FitResult(**base)


def test_fit_result_round_trip_with_nan_inf_and_numpy():
    r = _result()
    d = json.loads(json_text(r.to_dict()))
    assert d["parameters"] == {"A": 1.5, "C": None} and d["fixed"] == {"B": 2.0}
    assert d["bounds"] == {"A": [0.0, None], "C": [None, None]}
    assert d["nfev"] == 17 and d["status"] == 2
    back = FitResult.from_dict(d)
    assert back.to_dict() == d
    assert back.bounds == {"A": (0.0, math.inf), "C": (-math.inf, math.inf)}
    assert math.isnan(back.parameters["C"]) and back.fitted.keys() == {"A", "C"}
    assert back.fixed == {"B": 2.0} and back.free == ("A", "C")
    assert back.predicted.size == 0 and back.measured.size == 0
    # an entry written before nfev/status were recorded reads as 0
    old = {k: v for k, v in d.items() if k not in ("nfev", "status")}
    assert FitResult.from_dict(old).nfev == 0


def test_covariance_and_unidentified_round_trip():
    r = _result(covariance="sweep-jackknife", clusters=45,
                unidentified={"A": "correlated +0.9950 with C"})
    d = json.loads(json_text(r.to_dict()))
    assert d["covariance"] == "sweep-jackknife" and d["clusters"] == 45
    back = FitResult.from_dict(d)
    assert back.to_dict() == d and back.unidentified == {"A": "correlated +0.9950 with C"}
    assert "standard errors: sweep-jackknife over 45 sweeps" in back.report()
    # written before they were recorded: every standard error was iid
    old = {k: v for k, v in d.items() if k not in ("covariance", "clusters", "unidentified")}
    assert (FitResult.from_dict(old).covariance, FitResult.from_dict(old).clusters) == ("iid", 0)


def test_a_coefficient_without_effect_at_the_optimum_is_not_identifiable():
    """A free coefficient whose Jacobian column is 0 at the optimum (Mx's QSX6 run to 8e4 on a
    generated TTC session of the golden tyre, atan((QSX6 Fz/Fz0)^2) = pi/2 at every point)
    gets a standard error of 0 from the pseudo-inverse; that is no interval."""
    rng = np.random.default_rng(3)
    J = np.column_stack([rng.normal(size=50), np.zeros(50)])
    cov = engine.covariance(J, rng.normal(size=50))
    se, _ = engine.standard_errors(("A", "C"), cov)
    assert se["C"] == 0.0 and se["A"] > 0
    r = _result(parameters={"A": 1.5, "B": 2.0, "C": 8.4e4}, stderr=se, at_bound=())
    assert unidentified(r) == {"C": "no effect on the data at the optimum"}
    assert problems(r) == [
        "C = 8.4e+04 has no effect on the data at the optimum (standard error 0)"]


def test_degrees_of_freedom_round_trip_and_intervals():
    r = _result(covariance="sweep-jackknife", clusters=45, dof={"A": 3.0, "C": math.inf},
                rivals=(Rival({"A": 2.5}, 1.7),))
    d = json.loads(json_text(r.to_dict()))
    assert d["dof"] == {"A": 3.0, "C": None}
    assert d["rivals"] == [{"values": {"A": 2.5}, "dchi2": 1.7}]
    back = FitResult.from_dict(d)
    assert back.to_dict() == d and back.dof == {"A": 3.0, "C": math.inf}
    assert back.rivals == (Rival({"A": 2.5}, 1.7),)
    se = back.stderr["A"]
    lo, hi = back.interval("A")
    assert (hi - lo) / 2 == pytest.approx(3.182446 * se, rel=1e-6)  # t(0.975, 3)
    assert back.quantile("C") == pytest.approx(1.959964, abs=1e-6)
    # written before dof was recorded: 1.96 standard errors
    old = {k: v for k, v in d.items() if k != "dof"}
    assert FitResult.from_dict(old).quantile("A") == pytest.approx(1.959964, abs=1e-6)
    # the report names the t quantiles of the free coefficients with finite dof: one, a span
    assert "; 95 % intervals +/- 3.18 s.e. (Student's t)" in back.report()
    spread = dataclasses.replace(back, dof={"A": 3.0, "C": 10.0})
    assert "+/- 2.23-3.18 s.e. (Student's t)" in spread.report()
    assert "Student's t" not in FitResult.from_dict(old).report()


def test_mcmc_summary_round_trip():
    m = MCMCSummary(median={"A": 1.0}, q16={"A": 0.9}, q84={"A": 1.1}, q025={"A": 0.8},
                    q975={"A": 1.2}, tau={"A": np.float64(20.5), "log_sigma": np.nan},
                    acceptance=np.float64(0.31), n_walkers=32, n_steps=np.int64(500),
                    n_discard=60, n_thin=10, n_samples=1600, correlations={},
                    noise={"sigma": 0.01}, seed=0, converged=False, seconds=1.5,
                    chain_file=Path("/x/CFx_linear_load.h5"))
    d = json.loads(json_text(m.to_dict()))
    assert d["chain_file"] == "/x/CFx_linear_load.h5" and d["tau"]["log_sigma"] is None
    assert d["effective_samples"] == 1600.0
    assert MCMCSummary.from_dict(d).to_dict() == d
    r = _result(mcmc=m)
    assert FitResult.from_dict(json.loads(json_text(r.to_dict()))).mcmc.n_steps == 500


def test_settings_provenance_and_tyre_round_trip():
    s = FitSettings(seed=3, mcmc=True, only=("CFx", "MF"), fittyp=62, mcmc_max_steps=1000)
    assert s.to_dict()["only"] == ["CFx", "MF"]
    assert FitSettings.from_dict(s.to_dict()) == s
    # a record without a setting predates it: it says what that fit ran with
    old = FitSettings.from_dict({"seed": 1})
    assert old == FitSettings(seed=1, mf_passes=1, segment=False, mcmc_reparam=False,
                              mcmc_budget_s=None, bin_alpha_deg=None, bin_kappa=None,
                              pressure_holdout=False)
    assert FitSettings.from_dict(FitSettings(seed=1).to_dict()) == FitSettings(seed=1)
    p = Provenance.now(command="mfid fit x", seed=3, settings=s,
                       checksums={"b.csv": "2" * 64, "a.csv": "1" * 64}, folder="m")
    assert [i.path for i in p.inputs] == [str(Path("m") / "a.csv"), str(Path("m") / "b.csv")]
    assert Provenance.from_dict(p.to_dict()) == p and p.created.tzinfo is not None
    t = TyreInfo("t", 2.5e5, 4000.0, math.nan)
    assert t.to_dict()["unloaded_radius_m"] is None
    back = TyreInfo.from_dict(t.to_dict())
    assert back.id == "t" and math.isnan(back.unloaded_radius_m)
    assert back.to_dict() == t.to_dict()


def test_one_json_rule():
    assert json_safe({1: (np.float32(0.5), np.nan, -np.inf, Path("a/b")),
                      "x": np.arange(2), "y": np.bool_(True), "z": None}) == {
        "1": [0.5, None, None, "a/b"], "x": [0, 1], "y": True, "z": None}
    assert json_float(None) is None and json_float(np.int64(3)) == 3.0
    assert json_float(float("nan")) is None
    assert json_text({"a": float("inf")}) == '{\n "a": null\n}'


def test_schema_is_checked():
    with pytest.raises(InputError, match="schema is 'mfid.fit/0', expected 'mfid.fit/2'"):
        FitRun.from_dict({"schema": "mfid.fit/0", "fits": []})
    with pytest.raises(InputError, match="schema is 'list'"):
        FitRun.from_dict([])
