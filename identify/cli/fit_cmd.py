"""``mfid fit``: check -> load -> extract -> fit -> .tir, fit.json, CSVs -> PDF report.

Exit codes: 0 success; 1 a fit failed (did not converge, the model misses the data grossly,
constraint infeasible: status failed, identify.fit.status): the outputs
are still written, complete and marked as failed (fit.json "failed", a red line on the
report's cover) so that the reason can be inspected, and the reason is printed; 2 a usage error
or bad input (one line on stderr); 130 interrupted (SIGINT), 143 terminated (SIGTERM): every
output, MCMC chains included, is written to a temporary name and renamed, so no partial file
is left.
"""
from __future__ import annotations

import math
import shlex
import signal
import time
import warnings
from contextlib import ExitStack, contextmanager
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

import typer
from rich import box
from rich.console import Console
from rich.progress import (
    BarColumn,
    Progress,
    ProgressColumn,
    SpinnerColumn,
    TextColumn,
    TimeElapsedColumn,
)
from rich.table import Table
from rich.text import Text

from identify.cli import fit_options as shared
from identify.cli.app import _STATE, app, err_console, fail, out_console
from identify.core.errors import FitError, MfidError
from identify.core.workers import default_workers, process_pool, warm_up
from identify.fit.every_sample import EverySample
from identify.fit.mcmc.steps import ChainProgress
from identify.fit.status import POOR_FIT, POORLY_IDENTIFIED
from identify.fit.summary import SUMMARY_TITLE, fmt_pct, notes_lines
from identify.io.fitdir import EXTRACTION_NAME
from identify.io.output_guard import check_fit_outputs, check_folder_output, measurement_inputs
from identify.report.pdf import write_report
from identify.report.tables import mcmc_warnings
from identify.vehicle.spec import read_vehicle
from identify.workflows.fit import fit_folder
from identify.workflows.vehicle import add_vehicle_to_fit

if TYPE_CHECKING:  # pragma: no cover
    from identify.fit.run import FitRun
    from identify.report.pdf import Report


WORKER_MODULES = ("identify.fit.mf.profile", "jax", "identify.report.pdf")
"""What the worker processes import while the stages are fitted (identify.core.workers.warm_up):
the profile intervals' and the report's modules."""


def _clock(seconds: float) -> str:
    if not math.isfinite(seconds):
        return "-:--"
    m, s = divmod(int(round(seconds)), 60)
    return f"{m // 60}:{m % 60:02d}:{s:02d}" if m >= 60 else f"{m}:{s:02d}"


def chain_text(p: ChainProgress) -> str:
    """Steps, largest tau and estimated time left of a running chain; how it ended once
    stopped."""
    tau = "tau -" if not math.isfinite(p.tau) else f"tau {p.tau:.0f}"
    if not p.stop:
        budget = "" if p.budget is None else f", budget {_clock(p.budget)}"
        return (f"{p.steps}/{p.target} steps (50 tau; cap {p.max_steps}), {tau}, "
                f"~{_clock(p.eta)} left{budget}")
    why = {"converged": "past 50 tau", "max_steps": "STOPPED at the step cap, < 50 tau",
           "budget": "STOPPED at the time budget, < 50 tau"}[p.stop]
    return f"{p.steps} steps, {tau}: {why} ({_clock(p.elapsed)})"


class _ChainBar(ProgressColumn):
    """A bar for MCMC chain tasks; nothing for the stage lines."""

    def __init__(self):
        super().__init__()
        self.bar = BarColumn(bar_width=24)

    def render(self, task) -> Text:
        return self.bar.render(task) if task.fields.get("chain") else Text("")


class StageProgress:
    """The ``progress`` callbacks of the fit pipeline, shown with rich.

    On a terminal every stage is a line with a spinner while it runs and its elapsed time once
    done, an MCMC chain a bar with its steps, autocorrelation time and estimated time left;
    elsewhere (a pipe, make's log) each stage is printed as one line when it starts and each
    chain one line when it stops.
    """

    def __init__(self, console=out_console):
        self.console = console
        self.live = console.is_terminal
        self.t0 = time.perf_counter()
        self._progress = None
        self._task = None

    def __enter__(self) -> StageProgress:
        if self.live:
            self._progress = Progress(SpinnerColumn(finished_text="[green]done"),
                                      TextColumn("{task.description}", markup=False),
                                      _ChainBar(), TextColumn("{task.fields[info]}",
                                                              markup=False),
                                      TimeElapsedColumn(), console=self.console,
                                      transient=False)
            self._progress.start()
        return self

    def __call__(self, text: str) -> None:
        if self._progress is not None:
            self._finish()
            self._task = self._progress.add_task(text, total=1, info="", chain=False)
        else:
            self._line(text)

    def _line(self, text: str) -> None:
        self.console.print(f"[{time.perf_counter() - self.t0:6.1f} s] {text}", markup=False,
                           highlight=False)

    def chain(self, name: str, p: ChainProgress) -> None:
        """The ``chain_progress`` callback: the current stage line becomes the chain's bar."""
        if self._progress is not None and self._task is not None:
            total = p.steps if p.stop else max(p.target, 1)  # stopped: a finished task
            self._progress.update(self._task, total=total, completed=p.steps,
                                  info=chain_text(p), chain=True)
        elif p.stop:
            self._line(f"mcmc {name}: {chain_text(p)}")

    def _finish(self) -> None:
        if self._progress is not None and self._task is not None:
            task = next(t for t in self._progress.tasks if t.id == self._task)
            self._progress.update(self._task, completed=task.total)

    def __exit__(self, exc_type, exc, tb) -> None:
        if self._progress is not None:
            if exc_type is None:
                self._finish()
            self._progress.stop()


class Terminated(KeyboardInterrupt):
    """SIGTERM, raised in the main thread so that it unwinds like Ctrl-C: every temporary
    output (chains included) is removed on the way out."""


@contextmanager
def _sigterm_interrupts():
    """Turn SIGTERM into :class:`Terminated` while the block runs (main thread only)."""
    def handler(signum, frame):
        raise Terminated()

    try:
        previous = signal.signal(signal.SIGTERM, handler)
    except ValueError:  # not the main thread: leave SIGTERM alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def summary_table(run: FitRun) -> Table:
    """Relation, form, total thesis error, key coefficients: one row per fit (the rows of
    ``FitRun.report()``)."""

    table = Table(title=SUMMARY_TITLE, title_justify="left", box=box.SIMPLE_HEAD,
                  pad_edge=False)
    for name, just in (("relation", "left"), ("form", "left"), ("total error %", "right"),
                       ("points", "right"), ("status", "left"), (".tir", "center")):
        table.add_column(name, justify=just, no_wrap=True)
    table.add_column("key coefficients", overflow="fold")
    colour = {"FAILED": "[red]FAILED[/red]", POOR_FIT: f"[red]{POOR_FIT}[/red]",
              POORLY_IDENTIFIED: f"[yellow]{POORLY_IDENTIFIED}[/yellow]"}
    for r in run.summary_rows():
        table.add_row(r.relation, r.form, fmt_pct(r.error_total_pct), str(r.n_points),
                      colour.get(r.status_cell, r.status_cell), r.tir_cell, r.key_coefficients)
    return table


def fit_command_line(folder, out, reports, mcmc, seed, only, nominal_pressure, nominal_load,
                     no_report, fittyp, mcmc_ar1=False, mcmc_max_steps=None,
                     mcmc_budget=None, forms=(), hold=(), bin_alpha=None, bin_kappa=None,
                     no_bin=False, no_segment=False, no_revolution_average=False,
                     pressure_holdout=True) -> str:
    args = ["mfid", "fit", str(folder)]
    if str(out) != "fits":
        args += ["--out", str(out)]
    if str(reports) != "reports":
        args += ["--reports", str(reports)]
    if mcmc:
        args.append("--mcmc")
    if mcmc_ar1:
        args.append("--mcmc-ar1")
    if mcmc_max_steps is not None:
        args += ["--mcmc-max-steps", str(mcmc_max_steps)]
    if mcmc_budget is not None:
        args += ["--mcmc-budget", f"{mcmc_budget:g}"]
    if seed:
        args += ["--seed", str(seed)]
    for o in only:
        args += ["--only", o]
    if nominal_pressure is not None:
        args += ["--nominal-pressure", f"{nominal_pressure:g}"]
    if nominal_load is not None:
        args += ["--nominal-load", f"{nominal_load:g}"]
    if fittyp != 61:
        args += ["--fittyp", str(fittyp)]
    for f in forms:
        args += ["--form", f]
    for h in hold:
        args += ["--hold", h]
    if no_segment:
        args.append("--no-segment")
    if no_bin:
        args.append("--no-bin")
    if no_revolution_average:
        args.append("--no-revolution-average")
    if not pressure_holdout:
        args.append("--no-pressure-holdout")
    if bin_alpha is not None:
        args += ["--bin-alpha", f"{bin_alpha:g}"]
    if bin_kappa is not None:
        args += ["--bin-kappa", f"{bin_kappa:g}"]
    if no_report:
        args.append("--no-report")
    return shlex.join(args)


@app.command("fit")
def fit_command(
    folder: Path = typer.Argument(..., help="Measurement folder (with tyre.toml), its "
                                            "tyre.toml, or a single characteristics CSV."),
    out: Path = typer.Option(Path("fits"), "--out",
                             help="Root of the fit directories: writes OUT/<tyre id>/."),
    reports: Path = typer.Option(Path("reports"), "--reports",
                                 help="Folder of the PDF reports: writes REPORTS/<tyre id>.pdf."),
    mcmc: shared.McmcOption = False,
    mcmc_ar1: shared.McmcAr1Option = False,
    mcmc_max_steps: shared.McmcMaxStepsOption = None,
    mcmc_budget: shared.McmcBudgetOption = None,
    seed: shared.SeedOption = 0,
    only: shared.OnlyOption = [],  # noqa: B006 - typer's list default, never mutated
    nominal_pressure: float | None = typer.Option(
        None, "--nominal-pressure", metavar="PA",
        help="Nominal pressure [Pa] of a single characteristics CSV."),
    nominal_load: float | None = typer.Option(
        None, "--nominal-load", metavar="N", help="Nominal load [N] of a single "
                                                  "characteristics CSV."),
    fittyp: shared.FittypOption = 61,
    form: shared.FormOption = [],  # noqa: B006
    hold: shared.HoldOption = [],  # noqa: B006
    bin_alpha: shared.BinAlphaOption = None,
    bin_kappa: shared.BinKappaOption = None,
    no_bin: shared.NoBinOption = False,
    no_segment: shared.NoSegmentOption = False,
    no_revolution_average: shared.NoRevolutionAverageOption = False,
    pressure_holdout: shared.PressureHoldoutOption = True,
    no_report: bool = typer.Option(False, "--no-report", help="Skip the PDF report."),
    workers: int | None = typer.Option(
        None, "--workers", min=1, metavar="N", envvar="MFID_WORKERS",
        help="Processes for the parts of the fit that do not depend on each other (the MF "
             "stages' profile intervals, the report's pages); the results are the same. "
             "Default: this process plus the cores other work leaves idle (the cores less "
             "the load average), at most 2, divided by OMP_NUM_THREADS (or "
             "OPENBLAS_NUM_THREADS, MKL_NUM_THREADS) when set; 1: all in one process. "
             "Environment: MFID_WORKERS."),
    vehicle: str | None = typer.Option(
        None, "--vehicle", metavar="FILE.toml",
        help="Also put the fitted tyre on a car: a vehicle file (docs/vehicle.md) or "
             "'default' (the default sedan); writes OUT/<id>/vehicle/ and adds the vehicle "
             "pages to the report."),
) -> None:
    """Fit a measurement folder: write OUT/<id>/<id>.tir, fit.json, measured_vs_model.csv
    (and extraction.json) and the PDF report REPORTS/<id>.pdf.

    Exit 0 on success; 1 when a fit failed (outputs are still written, marked as failed);
    2 on bad input.
    """
    command = fit_command_line(folder, out, reports, mcmc, seed, only, nominal_pressure,
                               nominal_load, no_report, fittyp, mcmc_ar1, mcmc_max_steps,
                               mcmc_budget, form, hold, bin_alpha, bin_kappa, no_bin,
                               no_segment, no_revolution_average, pressure_holdout)
    if vehicle is not None:
        command += " " + shlex.join(["--vehicle", vehicle])
    try:
        vehicle_spec = None if vehicle is None else read_vehicle(vehicle)
        # the settings as mfid batch makes them (the options are shared and checked there),
        # plus mfid fit's own
        settings = shared.fit_settings(
            seed=seed, mcmc=mcmc, mcmc_ar1=mcmc_ar1, mcmc_max_steps=mcmc_max_steps, only=only,
            fittyp=fittyp, form=form, hold=hold, mcmc_budget=mcmc_budget, bin_alpha=bin_alpha,
            bin_kappa=bin_kappa, no_bin=no_bin, no_segment=no_segment,
            no_revolution_average=no_revolution_average, pressure_holdout=pressure_holdout)
        # the outputs before any work: never inside the measurement folder, never of the
        # wrong kind (a --reports that is a file); those named by the tyre id once it is read
        inputs = measurement_inputs(folder)
        check_folder_output(out, inputs, key="--out")
        if not no_report:
            check_folder_output(reports, inputs, key="--reports")
        n_workers = default_workers() if workers is None else workers
        with warnings.catch_warnings(), _sigterm_interrupts(), StageProgress() as progress, \
                ExitStack() as stack:
            pool = None
            if n_workers > 1:
                pool = stack.enter_context(process_pool(n_workers))
                # interrupted: the jobs not started are dropped, not run before the exit
                stack.callback(pool.shutdown, wait=False, cancel_futures=True)
                # one worker now, while the stages fit on the other core; the profile
                # intervals start the others when they need them
                warm_up(pool, 1, WORKER_MODULES)
            if not _STATE.get("debug"):
                # numerical warnings from trial points are expected; failures are reported
                warnings.simplefilter("ignore", RuntimeWarning)
            # a fit that fails is listed in run.failed: its outputs are written, marked as
            # failed, and reported before the exit code says so
            run = fit_folder(folder, out_root=out, settings=settings, progress=progress,
                             nominal_pressure_Pa=nominal_pressure,
                             nominal_load_N=nominal_load, command=command,
                             chain_progress=progress.chain,
                             check_outputs=partial(check_fit_outputs, out,
                                                   None if no_report else reports,
                                                   inputs=inputs),
                             pool=pool)
            if vehicle_spec is not None:
                progress("vehicle: handling and ride of the fitted tyre")
                add_vehicle_to_fit(run.fit_dir, run.tir_path, vehicle_spec)
            report = None
            if not no_report:
                progress("report: PDF")
                report = write_report(run.fit_dir, reports / f"{run.fit_dir.name}.pdf",
                                      progress=progress, pool=pool)
    except KeyboardInterrupt as exc:
        what = "terminated" if isinstance(exc, Terminated) else "interrupted"
        err_console.print(f"{what}: no partial output was left (files are written to a "
                          "temporary name and renamed)", markup=False)
        raise typer.Exit(143 if isinstance(exc, Terminated) else 130) from None
    except MfidError as exc:
        fail(exc)
    _print_outputs(run, report)
    if run.failed:
        failure = FitError("fit failed: " + "; ".join(run.failed))
        if _STATE.get("debug"):
            raise failure
        err_console.print(f"error: {failure}", markup=False)
        raise typer.Exit(failure.exit_code)


def data_lines(run: FitRun) -> list[str]:
    """What the data could not support: each skipped MF stage with why, and the loading
    warnings counted (the report's data-quality pages list them one by one)."""
    lines = []
    if run.skipped:
        lines.append("MF stages skipped (their coefficients keep their default values):")
        lines += [f"  {stage}: {why}" for stage, why in run.skipped.items()]
    every = EverySample.from_dict(run.every_sample)
    if every is not None and every.summary_line():
        lines.append(every.summary_line())
        lines += [f"  {note}" for note in every.notes]
    found = (run.data_quality or {}).get("warnings") or []
    if found:
        kinds: dict[str, int] = {}
        for w in found:
            kinds[w["kind"]] = kinds.get(w["kind"], 0) + int(w["count"])
        lines.append(f"data quality: {len(found)} loading warning(s), fitted all the same "
                     "(counts: " + ", ".join(f"{k} {n}" for k, n in kinds.items())
                     + "); listed on the report's data-quality pages and in fit.json")
    return lines


def _print_outputs(run: FitRun, report: Report | None) -> None:

    if out_console.is_terminal:
        out_console.print(summary_table(run))
    else:  # a log or pipe gets the whole table rather than rich's default 80 columns
        Console(highlight=False, width=160).print(summary_table(run))
    for line in notes_lines(run.form_choices, run.results):
        out_console.print(line, markup=False, highlight=False)
    for line in mcmc_warnings(run):
        err_console.print(f"warning: {line}", markup=False, highlight=False)
    for line in data_lines(run):
        out_console.print(line, markup=False, highlight=False)
    fit_dir = run.fit_dir
    out_console.print("outputs:", markup=False)
    for path in (run.tir_path, run.json_path, run.csv_path, fit_dir / EXTRACTION_NAME,
                 fit_dir / "mcmc"):
        if path.exists():
            out_console.print(f"  {path}", markup=False, highlight=False)
    if report is not None:
        out_console.print(f"  {report.path} ({report.n_pages} pages)", markup=False,
                          highlight=False)
