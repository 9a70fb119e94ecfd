"""``mfid batch`` end to end: the same outputs as ``mfid fit`` on the process pool and on Dask,
a worker killed mid-task, bad input among good folders, and a second batch that does nothing.

The folders are simulated on the small grid (seeds 1-4) and fitted with ``--only CFx,CFz``
(multi-start fits of two relations from extracted Flatplank characteristics: a few seconds
each). The reference is separate ``mfid fit`` processes with one BLAS thread, as ``make fits``
runs them: two folders on the process pool in the default suite, all four on the pool and on
Dask under ``-m trials`` (``make trials``).
"""
from __future__ import annotations

import io
import json
import os
import re
import shutil
import signal
import subprocess
import sys
import time
import tomllib
from pathlib import Path

import pandas as pd
import pytest
from pypdf import PdfReader
from rich.console import Console
from typer.testing import CliRunner

from identify.cli.app import app
from identify.cli.batch_cmd import RichBatchEvents
from identify.fit.run import FitSettings
from identify.io.tir import read_tir
from identify.simulate import default_tir_path, simulate_folder
from identify.workflows.batch.plan import Freshness, freshness, manifest_of
from identify.workflows.batch.run import run_batch
from identify.workflows.batch.task import TaskOutcome

MFID = Path(sys.executable).parent / "mfid"
ROOT = Path(__file__).resolve().parents[2]
ONLY = ["--only", "CFx,CFz"]
ENV = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1",
       "MKL_NUM_THREADS": "1", "MPLBACKEND": "Agg"}
IDS = ("t1", "t2", "t3", "t4")


@pytest.fixture(scope="module")
def folders(tmp_path_factory) -> Path:
    """Four small simulated measurement folders t1..t4 (seeds 1..4)."""
    root = tmp_path_factory.mktemp("measurements")
    tir = read_tir(default_tir_path()).params()
    for i, name in enumerate(IDS, start=1):
        simulate_folder(tir, root / name, seed=i, grid="small", tyre_id=name)
    return root


def mfid(*args, cwd: Path, **kw) -> subprocess.CompletedProcess:
    return subprocess.run([str(MFID), *map(str, args)], cwd=cwd, env=ENV, capture_output=True,
                          text=True, timeout=900, **kw)


def without_run_details(doc):
    """fit.json less what differs between two runs of the same fit: the creation time stamp
    (provenance.created_utc), the command line (it names the --out folder) and every wall
    time (``seconds`` of each fit, of MCMC, of the extraction)."""
    if isinstance(doc, dict):
        return {k: without_run_details(v) for k, v in doc.items()
                if k not in ("created_utc", "command", "seconds")}
    if isinstance(doc, list):
        return [without_run_details(v) for v in doc]
    return doc


def leftovers(root: Path) -> list[Path]:
    """Temporary files of the atomic writers and marker folders of the batch."""
    return [p for p in root.rglob(".*") if p.name.endswith(".tmp") or
            p.name.startswith(".mfid-batch.")]


# ----------------------------------------------------------------- same outputs as mfid fit

def _check_same_as_separate_fits(folders: Path, tmp_path: Path, tyres: tuple[str, ...],
                                 runs: dict[str, list[str]]) -> None:
    """Fit ``tyres`` with separate `mfid fit` processes, then with one `mfid batch` per entry
    of ``runs`` (its engine options), and compare the outputs (see the callers)."""
    ref = tmp_path / "ref"
    procs = [subprocess.Popen([str(MFID), "fit", str(folders / name), "--out", str(ref),
                               "--no-report", *ONLY], env=ENV, stdout=subprocess.DEVNULL,
                              stderr=subprocess.PIPE, text=True) for name in tyres]
    for p in procs:
        assert p.wait(timeout=900) == 0, p.stderr.read()
    for name, extra in runs.items():
        out = tmp_path / name
        res = mfid("batch", *[folders / t for t in tyres], "--out", out, "--no-report", *ONLY,
                   *extra, cwd=tmp_path)
        assert res.returncode == 0, res.stdout + res.stderr
        assert f"batch: {len(tyres)} folders: {len(tyres)} ok" in res.stdout
    for name in runs:
        for tyre in tyres:
            a, b = ref / tyre, tmp_path / name / tyre
            doc_a = json.loads((a / "fit.json").read_text())
            doc_b = json.loads((b / "fit.json").read_text())
            assert without_run_details(doc_b) == without_run_details(doc_a), (name, tyre)
            assert doc_b["provenance"]["command"] == doc_a["provenance"]["command"].replace(
                str(ref), str(tmp_path / name))  # the mfid fit command of that folder
            for file in (f"{tyre}.tir", "measured_vs_model.csv"):
                assert (b / file).read_bytes() == (a / file).read_bytes(), (name, file)
            ex_a = json.loads((a / "extraction.json").read_text())
            ex_b = json.loads((b / "extraction.json").read_text())
            assert without_run_details(ex_b) == without_run_details(ex_a)
        assert not leftovers(tmp_path / name)


def test_pool_batch_matches_separate_fits(folders, tmp_path):
    """Two folders on the process pool (the default suite's share of acceptance 1): fit.json
    (less time stamp, command, wall times), the .tir, measured_vs_model.csv and
    extraction.json (less its wall time) equal those of separate `mfid fit` runs."""
    _check_same_as_separate_fits(folders, tmp_path, IDS[:2], {"pool": ["--workers", "2"]})


# ----------------------------------------------------------------- worker killed, bad input

def _bad_copy(src: Path, dst: Path) -> str:
    """A copy of ``src`` whose tyre id is ``dst.name`` and whose first Flatplank file has a
    malformed number on its 4th line; returns that file's name."""
    shutil.copytree(src, dst)
    toml = dst / "tyre.toml"
    toml.write_text(toml.read_text().replace(f'id = "{src.name}"', f'id = "{dst.name}"', 1))
    first = sorted((dst / "flatplank").iterdir())[0]
    lines = first.read_text().splitlines()
    cells = lines[3].split(",")
    cells[1] = "abc"
    lines[3] = ",".join(cells)
    first.write_text("\n".join(lines) + "\n")
    return first.name


# the dask engine's retry is the scheduler's own; its batch is checked against separate fits
# in the default run, this slower kill-and-retry case in tests/trials/test_batch_trials.py
@pytest.mark.parametrize("engine", [pytest.param([], id="pool")])
def test_killed_worker_costs_a_retry_and_bad_input_is_reported(folders, tmp_path, engine):
    """SIGKILL one worker mid-task: that task runs again, every good folder ends with all its
    outputs and no temporary file; a folder with a malformed number is one line on stderr,
    a missing folder another, and the exit code is 2. Two good folders on two workers: the
    killed task and the one beside it are both in flight."""
    good = IDS[:2]
    bad_file = _bad_copy(folders / "t1", tmp_path / "bad")
    out, reports = tmp_path / "fits", tmp_path / "reports"
    (out / "t2").mkdir(parents=True)
    stale = out / "t2" / ".fit.json.abcd1234.tmp"  # as a killed writer leaves it
    stale.write_text("{partial")
    args = [str(MFID), "batch", *[str(folders / n) for n in good], str(tmp_path / "bad"),
            str(tmp_path / "absent"), "--out", str(out), "--reports", str(reports),
            "--workers", "2", *ONLY, *engine]
    proc = subprocess.Popen(args, cwd=tmp_path, env=ENV, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    killed = None
    deadline = time.monotonic() + 600
    while killed is None and time.monotonic() < deadline and proc.poll() is None:
        for marker in out.glob(".mfid-batch.*/*.pid"):
            text = marker.read_text().split()
            if len(text) == 2:
                time.sleep(0.3)  # into the fit
                killed = int(text[1])
                os.kill(killed, signal.SIGKILL)
                break
        time.sleep(0.05)
    stdout, stderr = proc.communicate(timeout=900)
    assert killed is not None, stdout + stderr
    assert proc.returncode == 2, stdout + stderr
    assert f"(pid {killed}) was killed by SIGKILL; running it again (retry 1 of 2)" in stderr \
        or "its worker died (KilledWorker); running it again (retry 1 of 2)" in stderr, stderr
    errors = [ln for ln in stderr.splitlines() if ln.startswith("error: ")]
    assert len(errors) == 2, stderr
    assert f"bad: bad input: {tmp_path / 'bad' / 'flatplank' / bad_file}:4: " in errors[0]
    assert "not a number" in errors[0]
    assert errors[1] == f"error: {tmp_path / 'absent'}: bad input: {tmp_path / 'absent'}: " \
                        "no such file or directory"
    assert "batch: 4 folders: 2 ok, 2 bad input" in stdout
    for tyre in good:
        for name in (f"{tyre}.tir", "fit.json", "measured_vs_model.csv", "extraction.json"):
            assert (out / tyre / name).is_file(), (tyre, name)
        assert (reports / f"{tyre}.pdf").is_file()
        json.loads((out / tyre / "fit.json").read_text())  # complete
    assert not (out / "bad").exists() and not (reports / "bad.pdf").exists()
    assert not stale.exists() and not leftovers(tmp_path)
    summary = (out / "batch_summary.csv").read_text().splitlines()
    assert summary[0] == ("tyre,folder,task,relation,form,error_total_pct,n_points,status,"
                          "in_tir,key_coefficients,message")
    assert sum(ln.startswith("t1,") for ln in summary) == 4  # CFz x2, CFx x2
    assert any(ln.startswith(f"bad,{tmp_path / 'bad'},bad input,,,,0,bad input,False,,")
               for ln in summary)
    assert (reports / "batch_summary.pdf").is_file()


# ----------------------------------------------------------------- idempotent

def _mtimes(root: Path) -> dict[Path, int]:
    return {p: p.stat().st_mtime_ns for p in root.rglob("*") if p.is_file()}


def test_second_batch_does_nothing_and_a_changed_input_refits_that_folder(folders, tmp_path):
    """run_batch twice: the second skips every folder and rewrites nothing; touching a file
    without changing it still skips; changing one input file refits only that folder, and so
    does a change whose file time is older than fit.json; new settings refit all. The workers
    run one BLAS thread. The folders sit under a name with a space and a non-ASCII letter."""
    src = tmp_path / "Messungen Reifen ü"
    shutil.copytree(folders, src)
    names = [src / n for n in IDS[:2]]
    out, reports = tmp_path / "fits", tmp_path / "reports"
    settings = FitSettings(only=("CFx", "CFz"))
    kw = dict(out_root=out, reports=reports, settings=settings, workers=2)
    first = run_batch(names, **kw)
    assert [o.status for o in first.outcomes] == ["ok"] * 2 and first.exit_code == 0
    assert {o.blas_threads for o in first.outcomes} == {1}
    assert all(o.attempts == 1 for o in first.outcomes)
    before = _mtimes(tmp_path)
    second = run_batch(names, **kw)
    assert [o.status for o in second.outcomes] == ["up to date"] * 2, second.outcomes
    assert second.engine == "" and second.exit_code == 0
    assert _mtimes(tmp_path) == before  # nothing written, the summary included

    future = time.time() + 5
    os.utime(src / "t1" / "tyre.toml", (future, future))  # newer, same content
    assert [o.status for o in run_batch(names, **kw).outcomes] == ["up to date"] * 2

    run_file = sorted((src / "t2" / "flatplank").iterdir())[-1]
    lines = run_file.read_text().splitlines()
    lines[2] = lines[2].replace(",", ",1", 1)  # one number changed
    run_file.write_text("\n".join(lines) + "\n")
    third = run_batch(names, **kw)
    assert [o.status for o in third.outcomes] == ["up to date", "ok"]
    assert _mtimes(out / "t1") == {p: t for p, t in before.items() if out / "t1" in p.parents}

    # the up-to-date t1: new settings, a missing report, a changed file older than fit.json
    manifest = manifest_of(src / "t1")[1]
    fresh = freshness(src / "t1", manifest, out / "t1", reports / "t1.pdf",
                      FitSettings(only=("CFx", "CFz"), seed=1))
    assert fresh == Freshness(False, "settings changed")
    (reports / "t1.pdf").unlink()
    assert freshness(src / "t1", manifest, out / "t1", reports / "t1.pdf", settings) == \
        Freshness(False, "no report")
    assert freshness(src / "t1", manifest, out / "t1", None, settings).up_to_date

    # a changed file older than fit.json (a copy that kept its source's time: cp -p, rsync -a)
    run_file = sorted((src / "t1" / "flatplank").iterdir())[-1]
    lines = run_file.read_text().splitlines()
    lines[2] = lines[2].replace(",", ",1", 1)
    run_file.write_text("\n".join(lines) + "\n")
    old = (out / "t1" / "fit.json").stat().st_mtime - 3600
    os.utime(run_file, (old, old))
    assert freshness(src / "t1", manifest, out / "t1", None, settings) == \
        Freshness(False, f"flatplank/{run_file.name} changed")


def test_summary_pdf_compares_the_tyres(folders, tmp_path):
    """batch_summary.pdf: the overview, every fit's status, then sensitivities, stiffnesses
    and cornering pages for the group of tyres; the CSV has one row per fit, with the status
    fit.json gives it. (On a Dask LocalCluster, whose worker runs one BLAS thread: one worker
    process, which fits both tyres; the summary does not depend on how many ran them.)"""
    run = run_batch([folders / "t1", folders / "t2"], out_root=tmp_path / "fits",
                    reports=tmp_path / "reports", settings=FitSettings(only=("CFx", "CFz")),
                    workers=1, scheduler="local")
    assert run.engine == "dask LocalCluster (1 workers)"
    assert [(o.status, o.blas_threads) for o in run.outcomes] == [("ok", 1), ("ok", 1)]
    assert run.summary_pdf == tmp_path / "reports" / "batch_summary.pdf"
    reader = PdfReader(run.summary_pdf)
    text = [page.extract_text() for page in reader.pages]
    assert len(text) == 5
    assert "Batch summary: 2 tyres" in text[0]
    assert "Fits of every tyre (1/1)" in text[1]
    assert "Pressure sensitivities of the stiffnesses" in text[2] and "PFZ1" in text[2]
    assert "PCFX3" in text[2] and "PCFY3" in text[2]  # the pressure terms, not the load terms
    assert "Stiffnesses vs pressure" in text[3]
    assert "Cornering stiffness and relaxation length vs pressure" in text[4]
    assert "not fitted for these tyres" in text[4]  # no MF stage: no cornering stiffness
    table = pd.read_csv(run.summary_csv)
    assert list(table["tyre"]) == ["t1"] * 4 + ["t2"] * 4
    assert set(table["relation"]) == {"CFx", "CFz"}
    for tyre in ("t1", "t2"):
        doc = json.loads((tmp_path / "fits" / tyre / "fit.json").read_text())
        truth = [f["identification"] if f["converged"] else "failed" for f in doc["fits"]]
        assert list(table[table["tyre"] == tyre]["status"]) == truth


# ----------------------------------------------------------------- usage errors

@pytest.mark.parametrize("args, message", [
    (["--fittyp", "63"], "error: --fittyp: FITTYP must be 61 or 62, not 63"),
    (["--workers", "0"], "error: --workers: must be at least 1, not 0"),
    (["--retries", "-1"], "error: --retries: must be 0 or more, not -1"),
    (["--scheduler", "nowhere"], "error: --scheduler: expected 'local' or a Dask scheduler "
                                 "address such as tcp://HOST:8786, not 'nowhere'"),
])
def test_bad_options_are_one_line_exit_2(folders, tmp_path, args, message):
    result = CliRunner().invoke(app, ["batch", str(folders / "t1"), "--out",
                                      str(tmp_path / "fits"), *args])
    assert result.exit_code == 2, result.output
    assert result.stderr.strip() == message
    assert not (tmp_path / "fits").exists()


def test_base_dependencies_do_not_name_dask():
    """`pip install .` pulls only [project] dependencies: none is Dask (or its distributed
    scheduler, or dask-jobqueue); they come with the `dask` extra alone."""
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    names = {re.split(r"[\s\[<>=!~;]", dep, maxsplit=1)[0].lower()
             for dep in project["dependencies"]}
    assert names and not names & {"dask", "distributed", "dask-jobqueue"}, names
    extra = " ".join(project["optional-dependencies"]["dask"])
    assert "dask[distributed]" in extra and "dask-jobqueue" in extra


def test_scheduler_without_dask_names_the_extra(folders, tmp_path):
    """With dask.distributed not importable, --scheduler is a one-line error naming the extra
    (and the default process pool needs no Dask)."""
    blocker = tmp_path / "sitecustomize.py"
    blocker.write_text(
        "import sys\n"
        "class _NoDask:\n"
        "    def find_spec(self, name, path=None, target=None):\n"
        "        if name.split('.')[0] in ('dask', 'distributed'):\n"
        "            raise ImportError(f'no module named {name!r} (blocked by the test)')\n"
        "sys.meta_path.insert(0, _NoDask())\n")
    env = {**ENV, "PYTHONPATH": str(tmp_path)}
    res = subprocess.run([str(MFID), "batch", str(folders / "t1"), "--scheduler", "local",
                          "--out", str(tmp_path / "fits")], env=env, capture_output=True,
                         text=True, timeout=300)
    assert res.returncode == 2
    assert res.stderr.strip() == ("error: --scheduler: Dask is not installed: pip install "
                                  "'mfid[dask]' (or leave out --scheduler to use the process "
                                  "pool)")
    assert not (tmp_path / "fits").exists()


def test_interrupt_stops_the_workers_and_leaves_no_partial_file(folders, tmp_path):
    """SIGINT to `mfid batch` while fits run: exit 130, the workers are stopped, and there is
    no temporary file or marker folder; a folder either has all its outputs or none."""
    out = tmp_path / "fits"
    proc = subprocess.Popen([str(MFID), "batch", *[str(folders / n) for n in IDS], "--out",
                             str(out), "--no-report", "--workers", "2", *ONLY],
                            cwd=tmp_path, env=ENV, stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 600
    while not list(out.glob(".mfid-batch.*/*.pid")) and time.monotonic() < deadline:
        time.sleep(0.05)
    time.sleep(0.5)
    proc.send_signal(signal.SIGINT)
    _, stderr = proc.communicate(timeout=300)
    assert proc.returncode == 130, stderr
    assert stderr.strip().splitlines()[-1].startswith("interrupted: the running fits were "
                                                      "stopped")
    assert not leftovers(tmp_path)
    for tyre in IDS:
        made = [(out / tyre / n).is_file() for n in (f"{tyre}.tir", "fit.json",
                                                     "measured_vs_model.csv")]
        assert all(made) or not any(made), tyre


def test_log_lines_count_tasks_that_end_in_the_same_tick():
    """Off a terminal each ended task is a line with the counts so far; two tasks that end
    between two progress updates are 1/2 and 2/2, not 1/2 twice."""
    console = Console(file=io.StringIO(), width=200, force_terminal=False)
    events = RichBatchEvents(console)
    events.start("process pool", 2, [])
    events.progress(0, 2, 0, 2, None)
    events.ended(TaskOutcome("a", "ta", "ok", seconds=1.0, attempts=1))
    events.ended(TaskOutcome("b", "tb", "failed", "fit did not converge: CFx", 1.0, 1))
    lines = console.file.getvalue().splitlines()
    assert lines[0] == "batch: 2 to fit on process pool, 0 up to date, 0 bad input"
    assert lines[1].endswith("] 1/2 done, 0 failed: ta: ok (1.0 s)")
    assert lines[2].endswith("] 2/2 done, 1 failed: tb: failed (1.0 s): fit did not converge: "
                             "CFx")
