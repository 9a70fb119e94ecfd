"""``mfid fit`` end to end (CliRunner and a real subprocess), and ``make fits`` batch runs.

Fits use the bundled thesis folder with ``--only`` to stay short. A real failing fit: camber
thrust data that are all zero (the thesis error of any non-zero model is infinite, the
constrained solver reports incompatible constraints), which must exit 1 with the reason.
"""
from __future__ import annotations

import dataclasses
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from identify.cli.app import app
from identify.cli.fit_cmd import chain_text
from identify.fit.run import FitRun

ROOT = Path(__file__).resolve().parents[2]
THESIS = ROOT / "measurements" / "thesis-225-50R17"
MFID = Path(sys.executable).parent / "mfid"
runner = CliRunner()


def _fit(tmp_path: Path, *args) -> object:
    return runner.invoke(app, ["fit", *[str(a) for a in args], "--out", str(tmp_path / "fits"),
                               "--reports", str(tmp_path / "reports")])


def _leftovers(*dirs: Path) -> list[Path]:
    """Temporary files an atomic writer would leave (.name.XXXX.tmp)."""
    return [p for d in dirs if d.exists() for p in d.rglob(".*.tmp")]


# ----------------------------------------------------------------- success

def test_fit_thesis_writes_outputs_and_summary(tmp_path):
    result = _fit(tmp_path, THESIS, "--only", "CFx")
    assert result.exit_code == 0, result.output
    fit_dir = tmp_path / "fits" / "thesis-225-50R17"
    tir = fit_dir / "thesis-225-50R17.tir"
    pdf = tmp_path / "reports" / "thesis-225-50R17.pdf"
    for path in (tir, fit_dir / "fit.json", fit_dir / "measured_vs_model.csv", pdf):
        assert path.is_file(), path
        assert str(path) in result.stdout  # the output paths are printed
    out = result.stdout
    # progress per stage, then the summary table: relation, form, total error, coefficients
    assert "load: " in out and "fit: CFx [linear_load]" in out and "report: PDF" in out
    assert "fit summary" in out
    # the thesis CFx curves in load: the data choose the quadratic form (x* in the .tir column)
    # and the line after the table says why
    assert re.search(r"CFx\s+linear_load\s+\d+\.\d{3}\s+15\s+ok\s+LONGITUDINAL_STIFFNESS=",
                     out), out
    assert re.search(r"CFx\s+quadratic_load\s+\d+\.\d{3}\s+15\s+ok\s+x\*\s+LONGITUDINAL_STIFF",
                     out)
    assert re.search(r"form CFx: quadratic_load \(chosen by the data\): F = [\d.]+, p = ", out)
    assert "(4 pages)" in out
    doc = json.loads((fit_dir / "fit.json").read_text())
    assert doc["provenance"]["command"].startswith(f"mfid fit {THESIS} --out ")
    assert doc["provenance"]["command"].endswith("--only CFx")
    assert doc["provenance"]["settings"]["only"] == ["CFx"]
    assert doc["failed"] == [] and result.stderr == ""
    assert not _leftovers(tmp_path)


def test_mcmc_stopped_at_the_cap_is_a_warning_with_the_cap_that_suffices(tmp_path):
    """A 100-step cap stops the CFx chains (tau ~ 3-5) short of 50 tau: the run succeeds, and
    stderr names each short chain, its tau and a --mcmc-max-steps that would suffice."""
    result = _fit(tmp_path, THESIS, "--only", "CFx", "--mcmc", "--mcmc-max-steps", "100",
                  "--no-report")
    assert result.exit_code == 0, result.output
    doc = json.loads((tmp_path / "fits" / "thesis-225-50R17" / "fit.json").read_text())
    run = FitRun.from_dict(doc)
    assert run.to_dict() == doc  # fit.json with MCMC summaries round-trips
    short = [f for f in run.results if not f.mcmc.converged]
    assert short and all(f.mcmc.n_steps == 100 for f in short)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == len(short), result.stderr
    for fit, line in zip(short, lines):
        tau = max(fit.mcmc.tau.values())
        assert line.startswith(f"warning: CFx [{fit.form}]: MCMC chain shorter than 50 "
                               f"autocorrelation times (100 steps, largest tau {tau:.0f}")
        cap = int(re.search(r"--mcmc-max-steps (\d+) ", line).group(1))
        assert 50 * tau < cap <= 55 * tau + 1000


def test_mcmc_stopped_by_the_budget_is_a_warning_with_a_budget_that_suffices(tmp_path):
    """--mcmc-budget 0.02 stops every CFx chain (tau ~ 20: ~1000 steps) long before 50 tau:
    the run succeeds, fit.json says stopped = "budget", and stderr names each chain with its
    steps, seconds and a --mcmc-budget that would suffice."""
    result = _fit(tmp_path, THESIS, "--only", "CFx", "--mcmc", "--mcmc-budget", "0.02",
                  "--no-report")
    assert result.exit_code == 0, result.output
    doc = json.loads((tmp_path / "fits" / "thesis-225-50R17" / "fit.json").read_text())
    assert doc["provenance"]["command"].endswith("--mcmc-budget 0.02 --only CFx --no-report")
    assert doc["provenance"]["settings"]["mcmc_budget_s"] == 0.02
    run = FitRun.from_dict(doc)
    assert run.results and all(not f.mcmc.converged and f.mcmc.stopped == "budget"
                               and f.mcmc.n_steps < 40000 for f in run.results)
    lines = result.stderr.strip().splitlines()
    assert len(lines) == len(run.results), result.stderr
    for fit, line in zip(run.results, lines):
        assert line.startswith(f"warning: CFx [{fit.form}]: MCMC chain stopped by the time "
                               "budget (--mcmc-budget) shorter than 50 autocorrelation "
                               f"times ({fit.mcmc.n_steps} steps in "), line
    # the chain files are in place (renamed from their temporary names), no temporary left
    assert sorted(p.name for p in (tmp_path / "fits" / "thesis-225-50R17" / "mcmc").iterdir()) \
        == sorted(f"CFx_{f.form}.h5" for f in run.results)
    assert not _leftovers(tmp_path)


def test_chain_text_says_steps_tau_and_time_left():
    from identify.fit.mcmc.steps import ChainProgress

    running = ChainProgress(steps=1000, max_steps=40000, tau=40.0, target=2001, elapsed=10.0,
                            budget=None)
    assert running.eta == pytest.approx(1001 * 10.0 / 1000)
    assert chain_text(running) == "1000/2001 steps (50 tau; cap 40000), tau 40, ~0:10 left"
    capped = dataclasses.replace(running, budget=15.0)  # the budget leaves 5 s, not 10
    assert capped.eta == 5.0 and chain_text(capped).endswith("~0:05 left, budget 0:15")
    early = dataclasses.replace(running, steps=0, tau=math.nan, target=40000)
    assert chain_text(early) == "0/40000 steps (50 tau; cap 40000), tau -, ~-:-- left"
    done = dataclasses.replace(running, steps=2500, stop="budget", elapsed=75.0)
    assert done.eta == 0.0
    assert chain_text(done) == ("2500 steps, tau 40: STOPPED at the time budget, < 50 tau "
                                "(1:15)")


def test_single_csv_with_nominal_conditions_and_no_report(tmp_path):
    csv = tmp_path / "cfx.csv"
    lines = (THESIS / "characteristics.csv").read_text().splitlines()
    csv.write_text("\n".join([lines[0]] + [ln for ln in lines if ln.startswith("CFx,")]) + "\n")
    result = _fit(tmp_path, csv, "--nominal-pressure", "250000", "--nominal-load", "4000",
                  "--no-report", "--fittyp", "62", "--seed", "3")
    assert result.exit_code == 0, result.output
    doc = json.loads((tmp_path / "fits" / "cfx" / "fit.json").read_text())
    assert doc["tyre"]["nominal_load_N"] == 4000 and doc["tyre"]["nominal_pressure_Pa"] == 250000
    assert doc["tir"]["fittyp"] == 62 and doc["provenance"]["seed"] == 3
    assert not (tmp_path / "reports").exists()
    assert "--no-report" in doc["provenance"]["command"]


# ----------------------------------------------------------------- errors

@pytest.mark.parametrize("args, message", [
    (["{tmp}/absent"], "absent: no such file or directory"),
    (["{thesis}", "--only", "CFq"], "--only: unknown relation(s) CFq; choose from CFz, CFx"),
    (["{thesis}", "--only", "sidewall"], "nothing to fit"),
    (["{thesis}", "--fittyp", "63"], "--fittyp: FITTYP must be 61 or 62, not 63"),
    (["{thesis}", "--mcmc-ar1"], "--mcmc-ar1 needs --mcmc"),
    (["{thesis}", "--mcmc-max-steps", "5000"], "--mcmc-max-steps needs --mcmc"),
    (["{thesis}", "--mcmc", "--mcmc-max-steps", "50"], "--mcmc-max-steps must be at least 100"),
    (["{thesis}", "--mcmc-budget", "60"], "--mcmc-budget needs --mcmc"),
    (["{thesis}", "--mcmc", "--mcmc-budget", "0"], "--mcmc-budget must be a positive number"),
    (["{tmp}/bad.csv"], "bad.csv:2: value: not a number: 'abc'"),
])
def test_bad_input_exits_2_with_one_line(tmp_path, args, message):
    (tmp_path / "bad.csv").write_text("quantity,pi_bar,Fz_N,value,unit\nCFx,2.5,4000,abc,N/m\n")
    args = [a.format(tmp=tmp_path, thesis=THESIS) for a in args]
    result = _fit(tmp_path, *args)
    assert result.exit_code == 2, result.output
    err = result.stderr.strip()
    assert "\n" not in err and err.startswith("error: ") and message in err, err
    assert "Traceback" not in result.output
    assert not (tmp_path / "fits").exists() or not list((tmp_path / "fits").rglob("*.tir"))


@pytest.mark.filterwarnings("ignore::RuntimeWarning")
def test_failed_fit_exits_1_with_the_reason_and_marked_outputs(tmp_path):
    csv = tmp_path / "flat_camber.csv"
    rows = ["quantity,pi_bar,Fz_N,value,unit,gamma_deg"]
    rows += [f"Fy_gamma,{p},{fz},0,N,{g}" for p in (2.0, 2.5, 3.0) for fz in (3000, 5000)
             for g in (-5, 5)]
    csv.write_text("\n".join(rows) + "\n")
    result = _fit(tmp_path, csv)
    assert result.exit_code == 1, result.output
    err = result.stderr.strip()
    assert err.startswith("error: fit failed: camber[Fy_gamma]: ") and "\n" not in err
    # outputs are complete and say that the fit failed; the summary shows it
    fit_dir = tmp_path / "fits" / "flat_camber"
    doc = json.loads((fit_dir / "fit.json").read_text())
    run = FitRun.from_dict(doc)
    assert run.to_dict() == doc and not run.ok
    assert run.failed[0].startswith("camber[Fy_gamma]")
    assert not run.result("camber/Fy_gamma").converged
    assert (tmp_path / "reports" / "flat_camber.pdf").is_file()
    assert re.search(r"camber\s+Fy_gamma\s+\S+\s+12\s+FAILED", result.stdout)
    debug = runner.invoke(app, ["--debug", "fit", str(csv), "--out", str(tmp_path / "f2"),
                                "--no-report"])
    assert debug.exit_code != 0 and type(debug.exception).__name__ == "FitError"


def test_help_lists_fit_and_report():
    out = runner.invoke(app, ["--help"]).stdout
    assert "fit" in out and "report" in out
    fit_help = runner.invoke(app, ["fit", "--help"]).stdout
    for option in ("--out", "--reports", "--mcmc", "--seed", "--only", "--nominal-pressure",
                   "--nominal-load", "--no-report"):
        assert option in fit_help


# ----------------------------------------------------------------- interruption

def _default_sigint() -> None:
    # a shell without job control starts background jobs (`make test &`) with SIGINT ignored,
    # and children inherit that; give mfid the disposition of a foreground command
    signal.signal(signal.SIGINT, signal.SIG_DFL)


def _start(args, tmp_path):
    env = dict(os.environ, PYTHONUNBUFFERED="1", MPLBACKEND="Agg")
    return subprocess.Popen([str(MFID), "fit", *map(str, args), "--out", str(tmp_path / "fits"),
                             "--reports", str(tmp_path / "reports")],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                            cwd=tmp_path, preexec_fn=_default_sigint)


def _interrupt_when(proc, marker: str, delay: float, timeout: float = 600.0,
                    sig: int = signal.SIGINT) -> str:
    """Send ``sig`` ``delay`` s after ``marker`` is printed. The timeout is generous: on a
    heavily shared machine the fit took over 120 s to reach the CFy chain."""
    seen = []
    deadline = time.monotonic() + timeout
    for line in proc.stdout:
        seen.append(line)
        if marker in line:
            time.sleep(delay)  # inside the stage
            proc.send_signal(sig)
            break
        if time.monotonic() > deadline:
            proc.kill()
            proc.communicate()
            pytest.fail(f"{marker!r} not printed within {timeout:.0f} s: {''.join(seen)}")
    out, err = proc.communicate(timeout=timeout)
    return "".join(seen) + out + err


@pytest.mark.skipif(not MFID.exists(), reason=f"{MFID} not installed (pip install -e .)")
@pytest.mark.parametrize("stage", ["fit", "report"])
def test_sigint_leaves_no_partial_output(tmp_path, stage):
    """SIGINT while fitting leaves no output at all; while writing the report it leaves the
    complete .tir and fit.json but no PDF; never a temporary file. Exit code 130."""
    if stage == "fit":
        proc = _start([THESIS, "--only", "CFy"], tmp_path)
        text = _interrupt_when(proc, "fit: CFy [quadratic_load]", 0.3)
    else:
        proc = _start([THESIS, "--only", "CFx"], tmp_path)
        text = _interrupt_when(proc, "report: PDF", 0.0)
    assert proc.returncode == 130, text
    assert "interrupted" in text and "Traceback" not in text
    fits, reports = tmp_path / "fits", tmp_path / "reports"
    assert not _leftovers(fits, reports, tmp_path)
    assert not list(reports.glob("*.pdf")) if reports.exists() else True
    tirs = list(fits.rglob("*.tir")) if fits.exists() else []
    if stage == "fit":
        assert tirs == [] and not list(fits.rglob("*.json")) if fits.exists() else True
    else:
        from identify.io.tir import read_tir

        assert len(tirs) == 1 and read_tir(tirs[0]).params()["LONGITUDINAL_STIFFNESS"] > 0
        doc = json.loads((tirs[0].parent / "fit.json").read_text())
        assert doc["schema"] == "mfid.fit/2"


@pytest.mark.skipif(not MFID.exists(), reason=f"{MFID} not installed (pip install -e .)")
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_signal_mid_chain_leaves_no_chain_file(tmp_path, sig):
    """SIGINT or SIGTERM while an MCMC chain runs (a chain before it complete, its file not
    yet renamed into place): exit 130 or 143, no chain file, no temporary file, no mcmc/
    folder, nothing else written. CFx's two forms with AR(1) noise: two chains of thousands of
    steps, the second interrupted, reached without CFy's multi-start relaxation fit (the
    chains' files are handled alike for every relation)."""
    proc = _start([THESIS, "--only", "CFx", "--mcmc", "--mcmc-ar1"], tmp_path)
    text = _interrupt_when(proc, "mcmc: CFx [quadratic_load]", 0.3, sig=sig)
    assert proc.returncode == (130 if sig == signal.SIGINT else 143), text
    assert ("interrupted" if sig == signal.SIGINT else "terminated") in text
    assert "Traceback" not in text
    assert "mcmc CFx_linear_load: " in text  # the first chain had finished (its log line)
    fits = tmp_path / "fits"
    assert not _leftovers(fits, tmp_path)
    left = sorted(p.relative_to(tmp_path) for p in tmp_path.rglob("*") if p.is_file())
    assert left == [], left
    assert not (fits / "thesis-225-50R17" / "mcmc").exists()


# ----------------------------------------------------------------- make fits

def _make(*args, cwd=ROOT) -> subprocess.CompletedProcess:
    return subprocess.run(["make", "--no-print-directory", *args], cwd=cwd, text=True,
                          capture_output=True, timeout=600)


@pytest.mark.skipif(shutil.which("make") is None, reason="make not installed")
@pytest.mark.skipif(not MFID.exists(), reason=f"{MFID} not installed (pip install -e .)")
def test_make_fits_batch(tmp_path):
    """make -j2 fits over two folders (and one without tyre.toml, left out): all outputs; a
    second make does nothing; touching one input refits that folder only."""
    meas = tmp_path / "measurements"
    for tid in ("tyreA", "tyreB"):
        d = meas / tid
        d.mkdir(parents=True)
        shutil.copy(THESIS / "characteristics.csv", d)
        toml = (THESIS / "tyre.toml").read_text().replace('"thesis-225-50R17"', f'"{tid}"')
        (d / "tyre.toml").write_text(toml)
    (meas / "reference").mkdir()
    (meas / "reference" / "notes.csv").write_text("x\n1\n")
    var = [f"MEASUREMENTS={meas}", f"FITS={tmp_path}/fits", f"REPORTS={tmp_path}/reports",
           "FIT_NEEDS=", "FIT_FLAGS=--only CFx"]
    first = _make("-j2", "fits", *var)
    assert first.returncode == 0, first.stdout + first.stderr
    outputs = {tid: (tmp_path / "fits" / tid / f"{tid}.tir", tmp_path / "reports" / f"{tid}.pdf")
               for tid in ("tyreA", "tyreB")}
    for tir, pdf in outputs.values():
        assert tir.is_file() and pdf.is_file()
    assert first.stdout.count("mfid fit") == 2 and "reference" not in first.stdout
    assert not (tmp_path / "fits" / "reference").exists()
    # nothing changed: nothing to do
    assert _make("-q", "fits", *var).returncode == 0
    assert "mfid" not in _make("-n", "fits", *var).stdout
    # touch one input: only that folder is refitted
    before = {tid: [p.stat().st_mtime_ns for p in ps] for tid, ps in outputs.items()}
    time.sleep(0.05)
    os.utime(meas / "tyreB" / "characteristics.csv")  # now: newer than tyreB's outputs
    plan = _make("-n", "fits", *var).stdout
    assert "measurements/tyreB" in plan and "measurements/tyreA" not in plan
    second = _make("-j2", "fits", *var)
    assert second.returncode == 0, second.stdout + second.stderr
    after = {tid: [p.stat().st_mtime_ns for p in ps] for tid, ps in outputs.items()}
    assert after["tyreA"] == before["tyreA"]
    assert all(a > b for a, b in zip(after["tyreB"], before["tyreB"]))
    assert _make("-q", "fits", *var).returncode == 0


@pytest.fixture(scope="module")
def small_folder(tmp_path_factory) -> Path:
    """A small simulated folder (Flatplank and trailer runs, seed 1)."""
    from identify.io.tir import read_tir
    from identify.simulate import default_tir_path, simulate_folder

    folder = tmp_path_factory.mktemp("small") / "s1"
    simulate_folder(read_tir(default_tir_path()).params(), folder, seed=1, grid="small")
    return folder


class _Stop(Exception):
    """Raised by the test's stand-in once it has recorded the segmentation settings."""


@pytest.mark.parametrize("flag, averaged", [((), True), (("--no-revolution-average",), False)])
def test_revolution_average_option_reaches_the_segmentation(tmp_path, monkeypatch, flag,
                                                            averaged, small_folder):
    """``--no-revolution-average`` switches the filter off in both segmentations of the MF
    stages' samples: the session logs' (prepare_trailer) and the other runs with a warm-up
    (sweep_bins.mf_table). The fit is stopped there: only the wiring is under test; what the
    filter does is tests/unit/test_segment.py's and tests/integration/test_sweep_bins.py's."""
    import identify.workflows.fit as fit_workflow

    seen = {}
    prepare = fit_workflow.prepare_trailer

    def record_prepare(mset, settings, **kw):
        seen["prepare_trailer"] = settings.revolution_average
        return prepare(mset, settings, **kw)

    def record_table(*args, settings, **kw):
        seen["mf_table"] = settings.revolution_average
        raise _Stop

    monkeypatch.setattr(fit_workflow, "prepare_trailer", record_prepare)
    monkeypatch.setattr(fit_workflow, "mf_table", record_table)
    result = _fit(tmp_path, small_folder, "--only", "MF",
                  "--no-report", *flag)
    assert isinstance(result.exception, _Stop)
    assert seen == {"prepare_trailer": averaged, "mf_table": averaged}
