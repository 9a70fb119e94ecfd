"""Fitting imported trailer sessions (issue 14): the coverage table of the MF stages before
fitting, stages skipped with one line saying why (their coefficients marked as defaults),
implausible channels never fitted, the data-quality record in fit.json, and ``mfid import`` ->
``mfid fit`` without hand edits on a TTC session in .mat and in .dat (acceptance 1, 4, 6)."""
from __future__ import annotations

import hashlib
import json
import tomllib

import numpy as np
import pytest
from pypdf import PdfReader
from typer.testing import CliRunner

from identify.cli.app import app
from identify.fit.coverage import StageCoverage, coverage_text, mf_coverage
from identify.fit.run import FitRun
from identify.fit.sources import DEFAULT
from identify.io.folder import load_folder
from identify.io.tir import read_tir
from identify.workflows.fit import _skipped_sources
from identify.workflows.import_session import import_session
from identify.workflows.trailer_prep import prepare_trailer
from tests.ttc_cases import UNUSABLE, decimated, session

runner = CliRunner()


def _tree_hashes(*roots):
    return {p: hashlib.sha256(p.read_bytes()).hexdigest()
            for root in roots for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def cornering(tmp_path_factory):
    """A cornering-only session with the three implausible channels of a real one."""
    root = tmp_path_factory.mktemp("corner")
    s = session(root / "ttc", seed=5, cornering_only=True, implausible=("N", "RE", "SR"))
    out = import_session([s.files[0]], root / "folder")
    mset = load_folder(out.path)
    td = prepare_trailer(mset)
    return s, mset, td, mf_coverage(td.table, mset.manifest.tyre.nominal_load_N,
                                    unavailable=td.unavailable)


def test_cornering_only_coverage_skips_fx0_and_fx_and_says_why(cornering):
    s, mset, td, cov = cornering
    by = {c.stage: c for c in cov}
    assert [c.stage for c in cov if c.fitted] == ["Fy0", "Mz0", "Mx"]
    assert by["Fx0"].line() == "Fx0: no slip-ratio sweep"
    assert by["Fx"].skipped == by["Fy"].skipped == by["Mz"].skipped == "no slip-ratio sweep"
    assert by["My"].skipped == "no My channel"
    # the wheel speed (N near zero at 40 kph) was dropped while loading: the geometry stage
    # says so instead of fitting Re = V/omega of hundreds of metres
    assert by["geometry"].skipped.startswith("wheel speed (omega) dropped as implausible (N in "
                                             "SIM1run4: wheel speed inconsistent")
    text = coverage_text(cov)
    assert "skipped Fx0: no slip-ratio sweep" in text and "skipped Fx: no slip-ratio sweep" in text
    plan = s.truth["plan"]
    fy0 = by["Fy0"]  # the segmented sweeps hold every set point of the programme
    assert len(fy0.loads) == len(plan["loads_N"]) and len(fy0.pressures) == 3
    np.testing.assert_allclose(fy0.loads, sorted(plan["loads_N"]), rtol=0.02)
    np.testing.assert_allclose(fy0.cambers, sorted(plan["cornering_cambers_deg"]), atol=0.2)
    assert fy0.identifiable and not fy0.not_identifiable
    assert by["Fx0"].points == 0 and by["Fx0"].not_identifiable["PDX1"] == "stage skipped"


def test_skipped_stage_coefficients_are_defaults_with_the_reason(cornering):
    _, _, _, cov = cornering
    sources = _skipped_sources(cov)
    assert sources["PDX1"].kind == DEFAULT
    assert sources["PDX1"].text() == ("default, not identified by these data (MF/Fx0 skipped: "
                                      "no slip-ratio sweep)")
    assert sources["RBX1"].detail == "MF/Fx skipped: no slip-ratio sweep"
    assert sources["Q_RE0"].detail.startswith("MF/geometry skipped: wheel speed (omega) dropped")
    assert "PDY1" not in sources and "QBZ1" not in sources  # fitted stages


def test_a_dropped_slip_ratio_skips_every_stage_with_the_reason(cornering):
    _, mset, td, _ = cornering
    table = td.table.assign(kappa=np.nan)
    why = "dropped as implausible (SL in SIM1run4: slip ratio pinned at -1)"
    cov = mf_coverage(table, mset.manifest.tyre.nominal_load_N,
                      unavailable={**td.unavailable, "kappa": why})
    by = {c.stage: c.skipped for c in cov}
    assert not any(c.fitted for c in cov)
    assert by["Fy0"] == by["Mx"] == by["Fx0"] == f"slip ratio (kappa) {why}"
    assert by["geometry"].startswith("wheel speed (omega) dropped")  # the first reason


def test_coverage_round_trips_through_json(cornering):
    _, _, _, cov = cornering
    for c in cov:
        assert StageCoverage.from_dict(json.loads(json.dumps(c.to_dict()))) == c


def test_segmentation_drops_warmups_cold_tread_and_records_filters(cornering):
    _, mset, td, _ = cornering
    seg = td.segmentation
    assert td.segmented_runs == ("SIM1run4",)
    assert seg.counts()["warmup"] >= 2 and len(td.table) == seg.kept < len(mset.trailer)
    removed = {f.name: f.removed for f in seg.filters}
    assert removed["cold tread"] > 0
    assert (td.table["T_tread_centre"] >= 273.15 + 39.5).all()  # halfway, ambient 25 to 55 degC
    doc = td.to_dict()
    assert doc["rows_fitted"] == len(td.table) and doc["segmentation"]["kept"] == seg.kept
    assert set(doc["unavailable"]) == {"omega", "My"}


def _fit(folder, out):
    return runner.invoke(app, ["fit", str(folder), "--out", str(out / "fits"),
                               "--reports", str(out / "reports")])


def _check_fit(folder, out, result, before):
    assert result.exit_code == 0, result.stdout + result.stderr
    assert _tree_hashes(folder) == before  # the measurement folder is only read
    doc = json.loads(next((out / "fits").glob("*/fit.json")).read_text())
    assert doc["failed"] == []
    assert FitRun.from_dict(doc).to_dict() == doc  # coverage and data_quality round-trip
    cov = {c["stage"]: c for c in doc["coverage"]}
    assert cov["My"]["skipped"] == "no My channel"
    fitted = [f["form"] for f in doc["fits"] if f["relation"] == "MF"]
    assert fitted == [s for s, c in cov.items() if not c["skipped"]]
    # the MF standard errors are the staged sweep jackknife (docs/intervals.md), with the
    # coefficients that are not identifiable on their own named
    mf_fits = [f for f in doc["fits"] if f["relation"] == "MF"]
    assert {f["covariance"] for f in mf_fits} == {"staged-sweep-jackknife"}
    assert all(f["clusters"] >= 10 and isinstance(f["unidentified"], dict) for f in mf_fits)
    quality = doc["data_quality"]
    assert quality["warnings"] and all(w["count"] > 0 for w in quality["warnings"])
    # the cornering run is segmented here; a drive/brake run is handed on as logged (to
    # sweep_bins.mf_table, which segments it on its own): its rows come on top of the kept ones
    trailer = quality["trailer"]
    tests = {r["id"]: r["test"]
             for r in tomllib.loads((folder / "tyre.toml").read_text())["runs"]}
    assert trailer["segmentation"]["kept"] <= trailer["rows_fitted"]
    assert trailer["segmented_runs"] == sorted(r for r, t in tests.items()
                                               if t not in ("braking_driving", "combined"))
    assert doc["tir"]["key_sources"]["QSY1"]["detail"] == "MF/My skipped: no My channel"
    assert "skipped My: no My channel" in result.stdout
    (pdf,) = (out / "reports").glob("*.pdf")
    titles = [o.title for o in PdfReader(pdf).outline]
    assert "data quality: trailer" in titles and "loading warnings" in titles
    # by default: each pressure level predicted without it, and the .tir judged on every
    # loaded sample, grouped by kind of run and by what the segmentation made of it
    assert "pressure prediction" in titles and "every sample" in titles
    assert len(doc["pressure_holdout"]["levels"]) >= 2
    every = doc["every_sample"]
    by = {(g["by"], g["name"]) for g in every["groups"]}
    assert ("run", "free rolling") in by and ("segmentation", "kept: sweeps") in by
    assert every["samples"] <= every["loaded"] and "every loaded trailer sample" in result.stdout
    return doc


@pytest.mark.parametrize("suffix", [".mat"])  # .dat: tests/trials/test_ttc_fit_trials.py
def test_import_then_fit_a_short_session_without_hand_edits(tmp_path, suffix):
    """The default-suite variant of acceptance 1: the two-run programme decimated 10x
    (about 6k + 7.7k samples), imported from .mat (.dat: in the trials, the same fit after a
    text reader) and fitted with exit 0 (about 1 min on the loaded 2-core machine)."""
    full = session(tmp_path / "ttc", seed=7)
    files = [f for f in decimated(full, tmp_path / "short", 10) if f.suffix == suffix]
    before_in = _tree_hashes(tmp_path / "short")
    folder = tmp_path / "folder"
    result = runner.invoke(app, ["import", *map(str, files), "--out", str(folder)])
    assert result.exit_code == 0, result.stderr
    assert _tree_hashes(tmp_path / "short") == before_in
    before = _tree_hashes(folder)
    doc = _check_fit(folder, tmp_path, _fit(folder, tmp_path), before)
    assert all(not c["skipped"] for c in doc["coverage"] if c["stage"] != "My")
    # the written pressure limits span the session's three pressure blocks (a run holds all
    # of them; grouped by run they were 2.56-2.57 bar), each block's level within its warm-up
    # rise (a few kPa) of the pressure set
    tir = read_tir(next((tmp_path / "fits").glob("*/*.tir"))).params()
    plan = full.truth["plan"]["pressures_Pa"]
    assert min(plan) <= tir["PRESMIN"] <= min(plan) + 5e3
    assert max(plan) <= tir["PRESMAX"] <= max(plan) + 5e3


_MANIFEST = """[tyre]
id = "bad"
nominal_pressure_Pa = 83000.0
nominal_load_N = 1000.0
unloaded_radius_m = 0.26
source = "measured"

[[runs]]
id = "B1run1"
file = "trailer/B1run1.mat"
kind = "trailer"
test = "cornering"
axes = "SAE"
"""


@pytest.mark.parametrize("name,make,expected",
                         [c for c in UNUSABLE if c[0] in ("no-FZ", "unknown-unit",
                                                          "truncated-mat")],
                         ids=["no-FZ", "unknown-unit", "truncated-mat"])
def test_fit_of_a_folder_with_an_unusable_file_exits_2_with_one_line(tmp_path, name, make,
                                                                      expected):
    """Acceptance 4: each unusable file class stops ``mfid fit`` (not only ``mfid import``)
    with one line naming the file and the channel, writes nothing and changes nothing."""
    folder = tmp_path / "folder"
    (folder / "trailer").mkdir(parents=True)
    (folder / "tyre.toml").write_text(_MANIFEST)
    path = make(folder / "trailer" / "B1run1.mat")
    before = _tree_hashes(folder)
    result = runner.invoke(app, ["fit", str(folder), "--out", str(tmp_path / "fits"),
                                 "--no-report"])
    assert result.exit_code == 2
    (line,) = result.stderr.splitlines()
    text = "error: " + expected.format(p=path)
    assert line.startswith(text[:-3]) if text.endswith("...") else line == text
    assert _tree_hashes(folder) == before and not (tmp_path / "fits").exists()


def test_a_swept_camber_is_reported_as_its_range():
    """Levels closer than 0.5 deg merge, so a camber sweep in 0.25 deg steps is one level: the
    coverage gives its range (the stage's data), not that level."""
    swept = StageCoverage("Fy0", 6418, cambers=(0.0,), camber_deg=(-8.0, 8.0))
    assert swept.camber_swept and swept.camber_text() == "-8.0 .. 8.0 swept"
    assert "camber -8.0 .. 8.0 deg swept" in swept.line()
    levels = StageCoverage("Fy0", 600, cambers=(-4.0, 0.0, 4.0), camber_deg=(-4.1, 4.1))
    assert not levels.camber_swept and levels.camber_text() == "-4.0 0.0 4.0"
    assert "3 camber(s)" in levels.line()
    assert StageCoverage.from_dict(swept.to_dict()) == swept
    old = {k: v for k, v in swept.to_dict().items() if k != "camber_deg"}  # older fit.json
    assert StageCoverage.from_dict(old).camber_text() == "0.0"
    from identify.report.trailer_pages import coverage_rows
    assert coverage_rows([swept])[0][4] == "-8.0 .. 8.0 swept"
