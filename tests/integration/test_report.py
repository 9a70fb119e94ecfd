"""The PDF fit report: rebuilt from a fit directory alone, every page drawn, no blank page.

A real fit of the bundled thesis folder (CFx only, a few seconds) gives the base directory; a
copy of it is extended with what a full run adds (MF-stage rows drawn from a .tir, a saved
MCMC chain, data-quality flags, many input files) so that every kind of page is exercised
without the slow stages. The pages are rasterised with pdftoppm when it is installed;
otherwise the PDF structure is checked with pypdf (page count, and drawing operators on every
page), never skipped.
"""
from __future__ import annotations

import dataclasses
import json
import math
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import scipy.stats
from typer.testing import CliRunner

from identify.cli.app import app
from identify.core.errors import InputError
from identify.io.fitdir import read_fit_dir
from identify.io.tir import read_tir
from identify.model.evaluate import evaluate
from identify.report import tables as T
from identify.report.pdf import write_report
from identify.report.slip_pages import mf_slip_pages
from identify.workflows.fit import FitSettings, fit_folder

ROOT = Path(__file__).resolve().parents[2]
THESIS = ROOT / "measurements" / "thesis-225-50R17"
TIR = Path(__file__).parents[1] / "data" / "tir" / "testA_61.tir"
runner = CliRunner()


# ----------------------------------------------------------------- fit directories

@pytest.fixture(scope="module")
def thesis_fit(tmp_path_factory) -> Path:
    """fits/thesis-225-50R17 of a real CFx-only fit."""
    out = tmp_path_factory.mktemp("fits")
    run = fit_folder(THESIS, out_root=out, settings=FitSettings(only=("CFx",)))
    return run.fit_dir


def _mf_rows(P: dict, rng) -> tuple[pd.DataFrame, list[dict]]:
    """Measured-vs-model rows of four MF stages at 2 pressures x 2 loads, from the .tir."""
    frames, fits = [], []
    sweeps = {"Fx0": ("Fx", "kappa", np.linspace(-0.2, 0.2, 21)),
              "Fy0": ("Fy", "alpha", np.deg2rad(np.linspace(-10, 10, 21))),
              "Mz0": ("Mz", "alpha", np.deg2rad(np.linspace(-10, 10, 21))),
              "Mx": ("Mx", "gamma", np.deg2rad(np.linspace(-5, 5, 11)))}
    for stage, (quantity, var, grid) in sweeps.items():
        rows = []
        for p_bar in (2.0, 2.5):
            for fz in (3000.0, 6000.0):
                n = grid.size
                x = {"kappa": np.zeros(n), "alpha": np.zeros(n), "gamma": np.zeros(n)}
                x[var] = grid
                fzs = fz + rng.normal(0, 20, n)
                out = evaluate(P, fzs, x["kappa"], x["alpha"], x["gamma"], np.full(n, 16.7),
                               p=np.full(n, p_bar * 1e5), mode=211)[quantity]
                meas = out + rng.normal(0, 0.01 * np.abs(out).max() + 1.0, n)
                rows.append(pd.DataFrame({
                    "relation": "MF", "form": stage, "quantity": quantity,
                    "unit": "N" if quantity.startswith("F") else "N*m", "pi_bar": p_bar,
                    "Fz_N": fzs, "gamma_deg": np.rad2deg(x["gamma"]), "alpha_rad": x["alpha"],
                    "kappa": x["kappa"], "Vx_mps": 16.7, "measured": meas, "model": out}))
        frame = pd.concat(rows, ignore_index=True)
        frames.append(frame)
        keys = {"Fx0": ["PCX1", "PDX1", "PDX2", "PKX1", "PPX1"],
                "Fy0": ["PCY1", "PDY1", "PDY2", "PKY1", "PKY2", "PPY1", "PPY2", "PEY1", "PEY2",
                        "PHY1", "PVY1", "PDY3", "PKY3", "PKY4", "PPY3", "PPY4", "PEY3",
                        "PHY2", "PVY2", "PVY3", "PVY4", "PKY6", "PKY7", "PPY5"],
                "Mz0": ["QBZ1", "QCZ1", "QDZ1"], "Mx": ["QSX1", "QSX2", "QSX3", "PPMX1"]}[stage]
        by_p = {}
        for p_bar in (2.0, 2.5):
            sel = frame["pi_bar"] == p_bar
            by_p[f"{p_bar:g}"] = 100 * float(np.sqrt(
                np.sum((frame.model[sel] - frame.measured[sel]) ** 2)
                / np.sum(frame.measured[sel] ** 2)))
        fits.append({"relation": "MF", "form": stage, "objective": "wls",
                     "parameters": {k: float(P[k]) for k in keys},
                     "fixed": {}, "stderr": {k: 0.01 * abs(float(P[k])) for k in keys},
                     "bounds": {k: [-10.0, 10.0] for k in keys},
                     "at_bound": keys[-1:], "active_constraints": ["Ex <= 1"],
                     "error_total_pct": float(np.mean(list(by_p.values()))),
                     "error_by_pressure_pct": by_p, "wls": 1.0, "n_points": len(frame),
                     "converged": True, "message": "ok", "n_starts": 8, "starts_at_best": 6,
                     "correlations": {}, "seconds": 1.0, "mcmc": None})
    return pd.concat(frames, ignore_index=True), fits


def _chain(path: Path, names: list[str], centre: np.ndarray, seed: int = 1) -> dict:
    """A short emcee chain (HDF backend, group "mcmc") around ``centre`` and its summary."""
    import emcee

    ndim = len(names) + 1
    mu = np.r_[centre, -3.0]
    sd = np.r_[0.02 * np.abs(centre) + 1e-3, 0.1]

    def logp(x):
        return -0.5 * np.sum(((x - mu) / sd) ** 2)
    backend = emcee.backends.HDFBackend(str(path), name="mcmc")
    backend.reset(16, ndim)
    rng = np.random.default_rng(seed)
    sampler = emcee.EnsembleSampler(16, ndim, logp, backend=backend)
    sampler.random_state = np.random.RandomState(seed).get_state()
    sampler.run_mcmc(mu + sd * rng.standard_normal((16, ndim)), 300, progress=False)
    flat = sampler.get_chain(discard=50, thin=5, flat=True)
    q = np.quantile(flat, [0.025, 0.16, 0.5, 0.84, 0.975], axis=0)
    pick = (lambda row: {n: float(q[row, i]) for i, n in enumerate(names)})
    return {"median": pick(2), "q16": pick(1), "q84": pick(3), "q025": pick(0),
            "q975": pick(4), "tau": {n: 20.0 for n in names + ["log_sigma"]},
            "acceptance": float(np.mean(sampler.acceptance_fraction)), "n_walkers": 16,
            "n_steps": 300, "n_discard": 50, "n_thin": 5, "n_samples": len(flat),
            "seed": seed, "converged": False, "seconds": 0.1, "chain_file": str(path),
            "correlations": {}, "noise": {"sigma": 0.05}, "effective_samples": len(flat)}


@pytest.fixture(scope="module")
def full_fit(thesis_fit, tmp_path_factory) -> Path:
    """The thesis fit directory plus MF stages, an MCMC chain, flags and 40 input files."""
    root = tmp_path_factory.mktemp("full") / thesis_fit.name
    shutil.copytree(thesis_fit, root)
    P = read_tir(TIR).params()
    shutil.copy(TIR, root / f"{thesis_fit.name}.tir")
    doc = json.loads((root / "fit.json").read_text())
    rows, mf_fits = _mf_rows(P, np.random.default_rng(7))
    points = pd.concat([rows, pd.read_csv(root / "measured_vs_model.csv")], ignore_index=True)
    points.to_csv(root / "measured_vs_model.csv", index=False)
    doc["fits"] = mf_fits + doc["fits"]
    for fit in mf_fits:
        for k in fit["parameters"]:
            doc["tir"]["key_sources"][k] = f"MF/{fit['form']} (trailer)"
    cfx = doc["fits"][len(mf_fits)]
    names = list(cfx["parameters"])
    (root / "mcmc").mkdir()
    cfx["mcmc"] = _chain(root / "mcmc" / f"CFx_{cfx['form']}.h5", names,
                         np.array([cfx["parameters"][n] for n in names]))
    doc["flags"] = [{"run": "camber_p250_fz5000_s1_g5", "test": "camber", "flag": "asymmetry",
                     "detail": "negative camber thrust 12 % larger"}]
    doc["provenance"]["inputs"] += [{"path": f"{THESIS}/flatplank/run_{i:03d}.csv",
                                     "sha256": f"{i:064x}"} for i in range(40)]
    (root / "fit.json").write_text(json.dumps(doc, indent=1))
    (root / "extraction.json").write_text(json.dumps({"runs": [
        {"run": "cornering_p190", "test": "parking", "flags": [
            {"run": "parking_p190_fz3000_s2", "test": "parking", "flag": "stick_slip",
             "detail": "3 slip events"}]},
        {"run": "relaxation_p300_fz7000_s1", "test": "relaxation", "flags": ["short_run"]}],
        "flags": [{"run": "relaxation_p300_fz7000_s1", "test": "relaxation",
                   "flag": "short_run", "detail": "ends at 2.1 sigma"}]}))
    return root


# ----------------------------------------------------------------- page checks

def _page_streams(pdf: Path) -> list[bytes]:
    """Decoded content stream of every page (pypdf)."""
    pypdf = pytest.importorskip("pypdf")
    reader = pypdf.PdfReader(str(pdf))
    return [page.get_contents().get_data() if page.get_contents() is not None else b""
            for page in reader.pages]


def _ink(pdf: Path, tmp_path: Path) -> list[float]:
    """Fraction of non-white pixels of every page, rendered with pdftoppm (30 dpi); None
    when pdftoppm is not installed."""
    if shutil.which("pdftoppm") is None:
        return None
    from matplotlib.image import imread

    subprocess.run(["pdftoppm", "-r", "30", "-png", str(pdf), str(tmp_path / "page")],
                   check=True)
    out = []
    for png in sorted(tmp_path.glob("page-*.png"), key=lambda p: int(p.stem.split("-")[-1])):
        img = imread(png)[..., :3]
        out.append(float(np.mean(np.any(img < 0.9, axis=-1))))
    return out


def _check_pages(pdf: Path, n_expected: int, tmp_path: Path) -> None:
    streams = _page_streams(pdf)
    assert len(streams) == n_expected
    for i, s in enumerate(streams, 1):
        # text (Tj/TJ) and paths (m/l ... S or f) on every page
        assert len(s) > 500, f"page {i} has almost no content"
        assert b"TJ" in s or b"Tj" in s, f"page {i} has no text"
        assert b" l" in s or b" re" in s or b" c\n" in s, f"page {i} draws nothing"
    ink = _ink(pdf, tmp_path)
    if ink is not None:
        assert len(ink) == n_expected
        for i, frac in enumerate(ink, 1):
            assert frac > 0.004, f"page {i} is blank ({frac:.4f} non-white)"


# ----------------------------------------------------------------- tests

def test_report_of_a_relation_fit(thesis_fit, tmp_path):
    report = write_report(thesis_fit, tmp_path / "r.pdf")
    fits = read_fit_dir(thesis_fit).run.results
    assert [f.form for f in fits] == ["linear_load", "quadratic_load"]
    assert report.pages == ("cover", "CFx [linear_load]", "CFx [quadratic_load]",
                            "data quality")
    assert report.notes == ()  # relation curves rebuilt, not joined points
    _check_pages(report.path, 4, tmp_path)
    assert not list(tmp_path.glob(".*.tmp"))


@pytest.fixture(scope="module")
def full_report(full_fit, tmp_path_factory):
    return write_report(full_fit, tmp_path_factory.mktemp("reports") / "full.pdf")


def test_report_with_mf_mcmc_flags_and_appendix(full_report, tmp_path):
    titles = list(full_report.pages)
    # cover, 4 MF stages (Fy0 with 24 parameters continues on a second page), 2 relation
    # pages, 4 MF slip pages (no combined slip was measured: no friction ellipse, and a note
    # says so), the pressure prediction page, MCMC posterior + traces, data quality and the
    # list of flags, input appendix
    assert titles[0] == "cover"
    assert titles[1:6] == ["MF [Fx0]", "MF [Fy0]", "MF [Fy0] parameters", "MF [Mz0]",
                           "MF [Mx]"]
    assert titles[6:8] == ["CFx [linear_load]", "CFx [quadratic_load]"]
    assert titles[8:12] == ["MF Fy - alpha", "MF Fx - kappa", "MF Mz - alpha", "MF Mx - gamma"]
    assert titles[12] == "pressure prediction"
    assert titles[13:15] == ["MCMC CFx [linear_load] posterior", "MCMC CFx [linear_load] traces"]
    assert titles[15:] == ["data quality", "data flags", "inputs"]
    assert len(full_report.notes) == 1
    assert full_report.notes[0].startswith("friction-ellipse page left out: no combined-slip")
    _check_pages(full_report.path, len(titles), tmp_path)


def test_report_command_is_reproducible_and_sets_metadata(full_fit, full_report, tmp_path,
                                                          monkeypatch):
    """``mfid report FITDIR`` writes reports/<id>.pdf, byte for byte the file write_report
    made earlier (CreationDate from fit.json), with the PDF metadata set."""
    pypdf = pytest.importorskip("pypdf")
    monkeypatch.chdir(tmp_path)
    result = runner.invoke(app, ["report", str(full_fit)])
    assert result.exit_code == 0, result.output
    out = tmp_path / "reports" / "thesis-225-50R17.pdf"
    assert f"wrote reports/thesis-225-50R17.pdf ({full_report.n_pages} pages)" in result.stdout
    assert out.read_bytes() == full_report.path.read_bytes()
    assert not list((tmp_path / "reports").glob(".*"))
    meta = pypdf.PdfReader(str(out)).metadata
    assert meta["/Title"] == "mfid fit report: thesis-225-50R17"
    assert meta["/Author"].startswith("mfid ")
    assert "thesis-225-50R17" in meta["/Subject"] and "CFx" in meta["/Keywords"]
    created = json.loads((full_fit / "fit.json").read_text())["provenance"]["created_utc"]
    assert meta["/CreationDate"].startswith("D:" + created[:10].replace("-", ""))
    assert runner.invoke(app, ["report", "--help"]).exit_code == 0
    missing = runner.invoke(app, ["report", str(tmp_path / "nope")])
    assert missing.exit_code == 2 and "no such fit directory" in missing.stderr


def test_tables_total_first_and_intervals(full_fit):
    fd = read_fit_dir(full_fit)
    cfx = fd.run.result("CFx/linear_load")
    # the form that supplied the .tir: the thesis CFx curves in load, the data choose quadratic
    assert fd.run.result("CFx") is fd.run.result("CFx/quadratic_load")
    rows = T.error_rows(cfx)
    assert rows[0][0] == "total (mean)"
    assert [r[0] for r in rows[1:]] == ["1.9 bar", "2.2 bar", "2.5 bar", "2.7 bar", "3 bar"]
    mean = np.mean([float(v) for _, v in rows[1:]])
    assert abs(float(rows[0][1]) - mean) < 2e-3
    params = T.parameter_rows(cfx, fd.key_sources)
    assert {p.interval for p in params} == {"MCMC 2.5-97.5 %"}
    plain = T.parameter_rows(fd.run.result("CFx/quadratic_load"), fd.key_sources)  # no MCMC
    quad = fd.run.result("CFx/quadratic_load")
    # iid: Student's t at n - k degrees of freedom (s^2 estimated from the residuals)
    t_nk = scipy.stats.t.ppf(0.975, quad.n_points - len(quad.free))
    assert t_nk > 1.97
    for p in plain:
        assert p.interval == f"LS +/-{t_nk:.3g} s.e."
        assert p.lo95 == pytest.approx(p.value - t_nk * p.stderr, rel=1e-12)
        assert p.hi95 == pytest.approx(p.value + t_nk * p.stderr, rel=1e-12)
    assert any(p.in_tir for p in plain) and not any(p.in_tir for p in params)
    # an MF-style result: the interval names its covariance, a coefficient that is not
    # identifiable on its own carries the reason (docs/intervals.md)
    first = quad.free[0]
    staged = T.parameter_rows(dataclasses.replace(
        quad, covariance="staged-sweep-jackknife", clusters=45,
        unidentified={first: "correlated +0.9950 with X"},
        dof={n: math.inf for n in quad.free}), fd.key_sources)
    assert {p.interval for p in staged} == {"LS +/-1.96 s.e. (staged sweep jackknife)"}
    assert [p.unidentified for p in staged][0] == "correlated +0.9950 with X"
    assert not any(p.unidentified for p in staged[1:])
    flags = T.data_flags(fd.run, fd.extraction)
    # the run's list of flag names repeats the detailed flag: listed once, with its detail
    assert [(f["flag"], f["detail"]) for f in flags] == [
        ("asymmetry", "negative camber thrust 12 % larger"), ("stick_slip", "3 slip events"),
        ("short_run", "ends at 2.1 sigma")]
    diags = T.fit_diagnostics(fd.run)
    assert any("on a bound" in d for d in diags) and any("Ex <= 1" in d for d in diags)
    # the fixture chain: 300 steps, tau 20 -> 55 tau = 1100 steps, rounded up to 2000
    assert any("MCMC chain shorter" in d and "300 steps, largest tau 20" in d
               and "--mcmc-max-steps 2000 " in d for d in diags)


def test_clean_fit_says_no_flags(thesis_fit):
    fd = read_fit_dir(thesis_fit)
    assert T.data_flags(fd.run, fd.extraction) == []
    assert T.summary_rows(fd.run)[0].relation == "CFx"


def test_joined_curves_when_relation_cannot_be_rebuilt(thesis_fit, tmp_path):
    """A recorded model that the plan cannot reproduce: lines join the recorded values and the
    data-quality page says so."""
    root = tmp_path / thesis_fit.name
    shutil.copytree(thesis_fit, root)
    csv = pd.read_csv(root / "measured_vs_model.csv")
    csv["model"] *= 1.01
    csv.to_csv(root / "measured_vs_model.csv", index=False)
    report = write_report(root, tmp_path / "j.pdf")
    assert len(report.notes) == 2 and all("join the model values" in n for n in report.notes)


@pytest.mark.parametrize("mutate, message", [
    (lambda d: (d / "fit.json").unlink(), "not a fit directory: no fit.json"),
    (lambda d: (d / "fit.json").write_text("{\n  bad"), "fit.json:2: not valid JSON"),
    (lambda d: (d / "fit.json").write_text('{"schema": "other"}'), "schema is 'other'"),
    (lambda d: (d / "measured_vs_model.csv").unlink(), "no measured_vs_model.csv"),
])
def test_bad_fit_directory(thesis_fit, tmp_path, mutate, message):
    root = tmp_path / "f"
    shutil.copytree(thesis_fit, root)
    mutate(root)
    with pytest.raises(InputError, match=message.replace("(", r"\(")):
        read_fit_dir(root)
    result = runner.invoke(app, ["report", str(root), "-o", str(tmp_path / "x.pdf")])
    assert result.exit_code == 2
    assert result.stderr.strip().count("\n") == 0 and message in result.stderr
    assert not (tmp_path / "x.pdf").exists()


def test_missing_tir_leaves_out_mf_pages_with_a_note(full_fit, tmp_path):
    root = tmp_path / "f"
    shutil.copytree(full_fit, root)
    (root / "thesis-225-50R17.tir").unlink()
    fd = read_fit_dir(root)
    assert any("is missing" in n for n in fd.notes)
    pages, notes = mf_slip_pages(fd)
    assert pages == [] and any("the .tir could not be read" in n for n in notes)
    pages, notes = mf_slip_pages(read_fit_dir(full_fit))
    assert [p.title.split(" (")[0] for p in pages] == [
        "Fy - alpha", "Fx - kappa", "Mz - alpha", "Mx - gamma"]  # no combined slip: no ellipse
    fy = pages[0]
    assert [p.pi_bar for p in fy.panels] == [2.0, 2.5]
    assert len(fy.panels[0].loads) == 2 and all(pt[0].size == 21 for pt in fy.panels[0].points)


def test_outline_has_one_bookmark_per_page(full_report):
    from pypdf import PdfReader

    reader = PdfReader(full_report.path)
    outline = reader.outline
    assert len(outline) == len(reader.pages) == full_report.n_pages
    assert [reader.get_destination_page_number(o) for o in outline] == \
        list(range(len(reader.pages)))
    titles = [o.title for o in outline]
    assert titles[0] == "cover" and "MF Mx - gamma" in titles
    assert "data quality" in titles
    assert reader.page_mode == "/UseOutlines"
    assert reader.metadata["/Title"].startswith("mfid fit report: ")


def test_the_report_drawn_in_two_processes_is_the_serial_one(full_fit, full_report, tmp_path):
    """write_report with worker processes (the cover and the fits' pages drawn in one of
    them): the same pages in the same order, titles, notes (the data-quality page lists the
    fits' notes too), page texts, outline and metadata."""
    from pypdf import PdfReader

    from identify.core.workers import process_pool

    with process_pool(1) as pool:
        two = write_report(full_fit, tmp_path / "two.pdf", pool=pool)
    assert two.pages == full_report.pages and two.notes == full_report.notes
    assert full_report.notes  # something for the data-quality page to list
    a, b = PdfReader(full_report.path), PdfReader(two.path)
    assert [o.title for o in a.outline] == [o.title for o in b.outline]
    assert a.metadata == b.metadata and b.page_mode == "/UseOutlines"
    assert [p.extract_text() for p in a.pages] == [p.extract_text() for p in b.pages]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["two.pdf"]  # no part left behind
