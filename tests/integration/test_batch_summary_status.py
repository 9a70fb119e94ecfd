"""The batch summary says what every fit says: batch_summary.csv and batch_summary.pdf agree
with each fit.json, fit by fit (ok, poorly identified, failed); a later batch keeps the rows of
the tyres it did not touch; ``mfid batch`` takes every fit option of ``mfid fit``; the progress
line counts against the tasks to run; folders that share a tyre id refuse only the repeats.

The simulated folders are the small grid fitted with ``--only MF`` (its stages: some poorly
identified, a few seconds) or ``--only CFz`` (one relation, about a second). The sample
(measurements/sample-225-50R17, all relations) runs under ``-m trials``.
"""
from __future__ import annotations

import io
import json
from pathlib import Path

import pandas as pd
import pytest
import typer.main
from pypdf import PdfReader
from rich.console import Console
from typer.testing import CliRunner

from identify.cli.app import app
from identify.cli.batch_cmd import RichBatchEvents
from identify.fit.run import FitSettings
from identify.io.tir import read_tir
from identify.simulate import default_tir_path, simulate_folder
from identify.workflows.batch.run import run_batch
from identify.workflows.batch.task import OK, TaskOutcome

ROOT = Path(__file__).resolve().parents[2]
SAMPLE = ROOT / "measurements" / "sample-225-50R17"


@pytest.fixture(scope="module")
def folders(tmp_path_factory) -> Path:
    """Small simulated measurement folders s1, s2 (seeds 1, 2)."""
    root = tmp_path_factory.mktemp("measurements")
    tir = read_tir(default_tir_path()).params()
    for i, name in enumerate(("s1", "s2"), start=1):
        simulate_folder(tir, root / name, seed=i, grid="small", tyre_id=name)
    return root


def _fit_statuses(fit_dir: Path) -> dict[tuple[str, str], str]:
    """(relation, form) -> status as fit.json gives it (the status ``mfid fit`` prints)."""
    doc = json.loads((fit_dir / "fit.json").read_text())
    out = {}
    for r in doc["fits"]:
        out[(r["relation"], r["form"])] = r["identification"] if r["converged"] else "failed"
    return out


def _check_summary_agrees(run, out: Path, tyres: list[str]) -> None:
    table = pd.read_csv(run.summary_csv, keep_default_na=False)
    pdf = "\n".join(p.extract_text() for p in PdfReader(run.summary_pdf).pages)
    fits_text = pdf.replace("\n", " ")
    for tyre in tyres:
        truth = _fit_statuses(out / tyre)
        rows = table[table["tyre"] == tyre]
        got = {(r.relation, r.form): r.status for r in rows.itertuples()}
        assert got == truth, tyre
        poor = [k for k, s in truth.items() if s != "ok"]
        for (rel, form), status in truth.items():
            row = rows[(rows["relation"] == rel) & (rows["form"] == form)].iloc[0]
            assert (row["message"] != "") == (status != "ok"), (tyre, rel, form)
        # the overview counts the fits by status, and the per-fit pages give each one
        n_poor = sum(s == "poorly identified" for s in truth.values())
        n_ok = sum(s == "ok" for s in truth.values())
        cell = ", ".join(p for p in (f"{n_ok} ok" if n_ok else "",
                                     f"{n_poor} poorly identified" if n_poor else "")
                         if p) + f" of {len(truth)}"
        assert cell in fits_text, (tyre, cell)
        for rel, form in poor:
            assert f"{tyre} {rel} {form}" in fits_text
        lines = [ln for ln in pdf.splitlines() if ln.startswith(f"{tyre} ")]
        for (rel, form), status in truth.items():
            assert any(ln.startswith(f"{tyre} {rel} {form} ") and f" {status}" in ln
                       for ln in lines), (tyre, rel, form, status)


def test_summary_and_pdf_say_what_every_fit_says(folders, tmp_path):
    """A batch of MF fits, some poorly identified: every row and the PDF give fit.json's
    status (the summary used to write ok for every converged fit)."""
    out = tmp_path / "fits"
    run = run_batch([folders / "s1"], out_root=out, reports=tmp_path / "reports",
                    settings=FitSettings(only=("MF",)), workers=1)
    assert [o.status for o in run.outcomes] == [OK]
    truth = _fit_statuses(out / "s1")
    assert "poorly identified" in truth.values() and "ok" in truth.values()
    _check_summary_agrees(run, out, ["s1"])


def test_a_later_batch_keeps_the_rows_of_tyres_it_did_not_touch(folders, tmp_path):
    out, reports = tmp_path / "fits", tmp_path / "reports"
    settings = FitSettings(only=("CFz",))
    run_batch([folders / "s1", folders / "s2"], out_root=out, reports=reports,
              settings=settings, workers=1)
    before = pd.read_csv(out / "batch_summary.csv", dtype=str, keep_default_na=False)
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "tyre.toml").write_text("not toml [[[\n")
    run = run_batch([bad, folders / "s2"], out_root=out, reports=reports, settings=settings,
                    workers=1)
    assert run.exit_code == 2
    after = pd.read_csv(out / "batch_summary.csv", dtype=str, keep_default_na=False)
    kept = after[after["tyre"] == "s1"].reset_index(drop=True)
    pd.testing.assert_frame_equal(kept, before[before["tyre"] == "s1"].reset_index(drop=True))
    assert list(after["tyre"]).count("s2") == (before["tyre"] == "s2").sum()
    assert (after["folder"] == str(bad)).sum() == 1
    overview = PdfReader(reports / "batch_summary.pdf").pages[0].extract_text()
    assert "Batch summary: 3 tyres" in overview and "s1" in overview
    # a kept tyre whose fit directory has gone is not vouched for
    import shutil
    shutil.rmtree(out / "s1")
    run_batch([folders / "s2"], out_root=out, reports=None, settings=settings, workers=1)
    last = pd.read_csv(out / "batch_summary.csv", dtype=str, keep_default_na=False)
    gone = last[last["tyre"] == "s1"]
    assert list(gone["task"]) == ["missing"] and "fit directory is missing" in gone.iloc[0].message


def test_repeated_folder_is_fitted_once_and_only_the_duplicate_id_is_refused(folders,
                                                                             tmp_path):
    copy = tmp_path / "copy-of-s1"
    copy.mkdir()
    for f in (folders / "s1").rglob("*"):
        target = copy / f.relative_to(folders / "s1")
        target.parent.mkdir(parents=True, exist_ok=True)
        if f.is_file():
            target.write_bytes(f.read_bytes())
    out = tmp_path / "fits"
    run = run_batch([folders / "s1", folders / "s1" / "tyre.toml", copy], out_root=out,
                    reports=None, settings=FitSettings(only=("CFz",)), workers=1)
    assert [o.status for o in run.outcomes] == [OK, "bad input"]
    message = run.outcomes[1].message
    assert str(copy) in message and str(folders / "s1") in message and "refused" in message


def _fit_options(command: str) -> set[str]:
    click = typer.main.get_command(app).commands[command]
    return {o for p in click.params for o in p.opts if o.startswith("--")}


def test_batch_takes_every_fit_option_of_fit():
    # a single characteristics CSV; a vehicle on which to put the one fitted tyre; one fit's
    # worker processes (batch's --workers counts the fits run at once, each in one process)
    fit_only = {"--nominal-pressure", "--nominal-load", "--vehicle", "--workers"}
    batch_only = {"--workers", "--scheduler", "--retries", "--force"}
    assert _fit_options("fit") - fit_only == _fit_options("batch") - batch_only


def test_batch_records_the_shared_options_in_each_fit(folders, tmp_path):
    out = tmp_path / "fits"
    result = CliRunner().invoke(app, ["batch", str(folders / "s1"), "--out", str(out),
                                      "--no-report", "--only", "CFz", "--no-segment",
                                      "--bin-alpha", "0.5", "--no-revolution-average"])
    assert result.exit_code == 0, result.output
    doc = json.loads((out / "s1" / "fit.json").read_text())
    settings = doc["provenance"]["settings"]
    assert settings["segment"] is False and settings["revolution_average"] is False
    assert settings["bin_alpha_deg"] == 0.5
    command = doc["provenance"]["command"]
    assert "--no-segment" in command and "--bin-alpha 0.5" in command


@pytest.mark.parametrize("args, message", [
    (["--mcmc-budget", "60"], "error: --mcmc-budget: --mcmc-budget needs --mcmc"),
    (["--no-bin", "--bin-kappa", "0.01"],
     "error: --no-bin: --no-bin and --bin-alpha/--bin-kappa contradict each other"),
    (["--bin-alpha", "0"], "error: --bin-alpha: --bin-alpha must be a positive number, not 0"),
])
def test_shared_options_are_checked_alike(folders, tmp_path, args, message):
    for command in ("fit", "batch"):
        result = CliRunner().invoke(app, [command, str(folders / "s1"), "--out",
                                          str(tmp_path / "fits"), *args])
        assert result.exit_code == 2, result.output
        assert result.stderr.strip() == message
    assert not (tmp_path / "fits").exists()


def test_progress_line_counts_against_the_tasks_to_run():
    buf = io.StringIO()
    events = RichBatchEvents(Console(file=buf, width=200, force_terminal=False))
    events.start("process pool", 2, [])
    events.ended(TaskOutcome("a", "a", OK, seconds=1.0))
    assert "1/2 done" in buf.getvalue()
