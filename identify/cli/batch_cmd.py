"""``mfid batch``: fit many measurement folders on a process pool (default) or Dask.

Exit codes: 0 every folder fitted (or up to date) and every fit converged; 1 some fit failed
(did not converge) or a task was lost (its worker died more often than ``--retries``), and no
folder had bad input; 2 some folder had bad input (or a usage error); 130 interrupted.
"""
from __future__ import annotations

import time
from pathlib import Path

import typer
from rich.console import Console
from rich.progress import (
    BarColumn,
    MofNCompleteColumn,
    Progress,
    SpinnerColumn,
    TextColumn,
    TimeElapsedColumn,
)

from identify.cli import fit_options as shared
from identify.cli.app import app, err_console, fail, out_console
from identify.cli.entry import Interrupted
from identify.cli.fit_cmd import fit_command_line
from identify.core.errors import MfidError
from identify.workflows.batch.run import run_batch
from identify.workflows.batch.task import BAD_INPUT, FAILED, LOST, OK, UP_TO_DATE

_GOOD = (OK, UP_TO_DATE)


def _clock(eta_s: float | None) -> str:
    if eta_s is None:
        return "eta -"
    finish = time.strftime("%H:%M:%S", time.localtime(time.time() + eta_s))
    return f"eta {eta_s:,.0f} s (finish ~{finish})"


class RichBatchEvents:
    """The batch's progress on the terminal (a live bar; a line per ended task above it) or,
    elsewhere (a pipe, a job log), one line per ended task with the counts and the estimate."""

    def __init__(self, console: Console = out_console):
        self.console = console
        self.live = console.is_terminal
        self.t0 = time.perf_counter()
        self._progress: Progress | None = None
        self._task = None
        self._counts = (0, 0, 0, 0, None)

    def start(self, engine, total, skipped) -> None:
        fresh = sum(o.status in (UP_TO_DATE, FAILED) for o in skipped)
        bad = sum(o.status == BAD_INPUT for o in skipped)
        self._counts = (0, 0, 0, total, None)  # a task may end before the first progress()
        self.console.print(f"batch: {total} to fit on {engine or '-'}, {fresh} up to date, "
                           f"{bad} bad input", markup=False, highlight=False)
        if self.live and total:
            self._progress = Progress(
                SpinnerColumn(), TextColumn("fits"), BarColumn(), MofNCompleteColumn(),
                TextColumn("{task.fields[state]}", markup=False), TimeElapsedColumn(),
                console=self.console, transient=False)
            self._progress.start()
            self._task = self._progress.add_task("fits", total=total, state="starting")

    def progress(self, done, running, failed, total, eta_s) -> None:
        self._counts = (done, running, failed, total, eta_s)
        if self._progress is not None:
            self._progress.update(self._task, completed=done,
                                  state=f"{running} running, {failed} failed, {_clock(eta_s)}")

    def ended(self, outcome) -> None:
        done, running, failed, total, eta_s = self._counts
        done += 1
        failed += outcome.status not in _GOOD
        # tasks that end in the same tick each count (progress() follows after all of them)
        self._counts = (done, running, failed, total, eta_s)
        text = f"{outcome.tyre_id}: {outcome.status} ({outcome.seconds:.1f} s"
        text += f", {outcome.attempts} attempts)" if outcome.attempts > 1 else ")"
        if outcome.message and outcome.status not in _GOOD:
            text += f": {outcome.message}"
        if self._progress is None:
            text = (f"[{time.perf_counter() - self.t0:7.1f} s] {done}/{total} done, "
                    f"{failed} failed: {text}")
        self.console.print(text, markup=False, highlight=False)

    def note(self, text: str) -> None:
        err_console.print(f"note: {text}", markup=False, highlight=False)

    def close(self) -> None:
        if self._progress is not None:
            self._progress.stop()
            self._progress = None


def _report_end(run) -> None:
    counts = ", ".join(f"{run.count(s)} {s}" for s in (OK, FAILED, BAD_INPUT, LOST, UP_TO_DATE)
                       if run.count(s))
    out_console.print(f"batch: {len(run.outcomes)} folders: {counts} ({run.seconds:.1f} s"
                      f"{', ' + run.engine if run.engine else ''})", markup=False,
                      highlight=False)
    out_console.print("outputs:", markup=False)
    for path in (run.summary_csv, run.summary_pdf):
        if path is not None and path.exists():
            out_console.print(f"  {path}", markup=False, highlight=False)
    for o in run.outcomes:
        if o.status not in _GOOD:
            err_console.print(f"error: {o.folder}: {o.status}: {o.message}", markup=False,
                              highlight=False)


@app.command("batch")
def batch_command(
    folders: list[Path] = typer.Argument(..., help="Measurement folders (each with "
                                                   "tyre.toml); one task per folder."),
    out: Path = typer.Option(Path("fits"), "--out",
                             help="Root of the fit directories: writes OUT/<tyre id>/ and "
                                  "OUT/batch_summary.csv."),
    reports: Path = typer.Option(Path("reports"), "--reports",
                                 help="Folder of the PDF reports: REPORTS/<tyre id>.pdf and "
                                      "REPORTS/batch_summary.pdf (the tyres compared)."),
    workers: int | None = typer.Option(None, "--workers", metavar="N",
                                       help="Worker processes (default: the cores). Ignored "
                                            "with --scheduler tcp://...: its workers run."),
    scheduler: str | None = typer.Option(
        None, "--scheduler", metavar="ADDRESS",
        help="Run on Dask (needs pip install 'mfid\\[dask]'): 'local' starts a LocalCluster of "
             "--workers workers; tcp://HOST:PORT connects to a running scheduler. Default: the "
             "standard library's process pool."),
    retries: int = typer.Option(2, "--retries", metavar="K",
                                help="Times a task runs again after its worker died (killed, "
                                     "out of memory)."),
    force: bool = typer.Option(False, "--force", help="Refit folders whose outputs are up to "
                                                      "date."),
    mcmc: shared.McmcOption = False,
    mcmc_ar1: shared.McmcAr1Option = False,
    mcmc_max_steps: shared.McmcMaxStepsOption = None,
    mcmc_budget: shared.McmcBudgetOption = None,
    seed: shared.SeedOption = 0,
    only: shared.OnlyOption = [],  # noqa: B006 - typer's list default, never mutated
    fittyp: shared.FittypOption = 61,
    form: shared.FormOption = [],  # noqa: B006
    hold: shared.HoldOption = [],  # noqa: B006
    bin_alpha: shared.BinAlphaOption = None,
    bin_kappa: shared.BinKappaOption = None,
    no_bin: shared.NoBinOption = False,
    no_segment: shared.NoSegmentOption = False,
    no_revolution_average: shared.NoRevolutionAverageOption = False,
    pressure_holdout: shared.PressureHoldoutOption = True,
    no_report: bool = typer.Option(False, "--no-report", help="No PDF (per tyre or summary)."),
) -> None:
    """Fit many measurement folders, each as `mfid fit` would, in parallel.

    A folder whose outputs are newer than its inputs and were made with the same settings is
    skipped (unless --force). At the end: OUT/batch_summary.csv and REPORTS/batch_summary.pdf.
    Exit 0 all ok; 1 some fit failed or a task was lost; 2 some folder had bad input.
    """
    def command(folder: str) -> str:
        """The `mfid fit` command of one folder, recorded in its fit.json."""
        return fit_command_line(folder, out, reports, mcmc, seed, only, None, None, no_report,
                                fittyp, mcmc_ar1=mcmc_ar1, mcmc_max_steps=mcmc_max_steps,
                                mcmc_budget=mcmc_budget, forms=form, hold=hold,
                                bin_alpha=bin_alpha, bin_kappa=bin_kappa, no_bin=no_bin,
                                no_segment=no_segment,
                                no_revolution_average=no_revolution_average)

    events = RichBatchEvents()
    try:
        settings = shared.fit_settings(
            seed=seed, mcmc=mcmc, mcmc_ar1=mcmc_ar1, mcmc_max_steps=mcmc_max_steps, only=only,
            fittyp=fittyp, form=form, hold=hold, mcmc_budget=mcmc_budget, bin_alpha=bin_alpha,
            bin_kappa=bin_kappa, no_bin=no_bin, no_segment=no_segment,
            no_revolution_average=no_revolution_average, pressure_holdout=pressure_holdout)
        run = run_batch([str(f) for f in folders], out_root=out,
                        reports=None if no_report else reports, settings=settings,
                        workers=workers, scheduler=scheduler, retries=retries, force=force,
                        command=command, events=events)
    except (KeyboardInterrupt, Interrupted) as exc:  # Ctrl-C, SIGTERM (identify.cli.entry)
        events.close()
        err_console.print("interrupted: the running fits were stopped and their temporary "
                          "files removed; finished folders keep their outputs", markup=False)
        raise typer.Exit(128 + getattr(exc, "signum", 2)) from None
    except MfidError as exc:
        events.close()
        fail(exc)
    events.close()
    _report_end(run)
    raise typer.Exit(run.exit_code)
