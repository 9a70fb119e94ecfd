"""One task of ``mfid batch``: the ordinary fit of one measurement folder, run on a worker.

:func:`fit_task` is what a worker process (the standard library's process pool or a Dask worker)
runs: ``fit_folder`` and ``write_report`` exactly as ``mfid fit`` calls them, with one BLAS
thread, returning a :class:`TaskOutcome` instead of raising, so that one folder's bad input
never stops the others. Both types are small frozen dataclasses that pickle by reference
(a remote worker needs the same mfid installed).

Every output goes through the atomic writers (temporary name, then rename). A worker killed
in the middle of a write (SIGKILL, out of memory) cannot clean up after itself, so
:func:`remove_partial` deletes such temporary files of one tyre: the task calls it before it
starts, and the batch calls it after a worker died.
"""
from __future__ import annotations

import os
import socket
import time
import warnings
from dataclasses import dataclass
from pathlib import Path

from threadpoolctl import threadpool_info, threadpool_limits

from identify.core.errors import MfidError
from identify.fit.run import FitSettings
from identify.report.pdf import write_report
from identify.workflows.fit import fit_folder

__all__ = ["BAD_INPUT", "FAILED", "LOST", "OK", "UP_TO_DATE", "FitTask", "TaskOutcome",
           "fit_task", "remove_partial", "worker_init"]

OK = "ok"
"""Every fit converged and every output was written."""
FAILED = "failed"
"""A fit did not converge (outputs written, marked as failed) or an unexpected error."""
BAD_INPUT = "bad input"
"""The folder is malformed (the one-line InputError), or its outputs could not be written."""
LOST = "lost"
"""The worker running the task died (killed, out of memory) more often than --retries allows."""
UP_TO_DATE = "up to date"
"""Not refitted: the outputs are newer than the inputs and were made with the same settings."""

_BLAS_ENV = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


@dataclass(frozen=True)
class FitTask:
    """What a worker needs to fit one folder.

    Attributes
    ----------
    folder : str               the measurement folder (with tyre.toml)
    tyre_id : str              its tyre id (the name of its fit directory and report)
    out_root : str             root of the fit directories (``--out``)
    reports : str or None      folder of the PDF reports; None: no report (``--no-report``)
    settings : FitSettings
    command : str              the equivalent ``mfid fit`` command, recorded in fit.json
    marker : str or None       a file the worker writes ``host pid`` to when it starts the
                               task, so that the batch knows which tasks run where
    """

    folder: str
    tyre_id: str
    out_root: str
    reports: str | None
    settings: FitSettings
    command: str
    marker: str | None = None

    @property
    def fit_dir(self) -> Path:
        return Path(self.out_root) / self.tyre_id

    @property
    def report_path(self) -> Path | None:
        return None if self.reports is None else Path(self.reports) / f"{self.tyre_id}.pdf"


@dataclass(frozen=True)
class TaskOutcome:
    """How one folder of the batch ended.

    Attributes
    ----------
    folder : str
    tyre_id : str             empty when the folder's tyre.toml could not be read
    status : str              :data:`OK`, :data:`FAILED`, :data:`BAD_INPUT`, :data:`LOST` or
                              :data:`UP_TO_DATE`
    message : str             one line: the error, the failed fits, or why it was skipped
    seconds : float           wall time of the last attempt [s]
    attempts : int            how many times the task was started (0 when skipped)
    blas_threads : int        the most BLAS/OpenMP threads the worker allowed during the fit
    """

    folder: str
    tyre_id: str
    status: str
    message: str = ""
    seconds: float = 0.0
    attempts: int = 0
    blas_threads: int = 0


def worker_init() -> None:
    """Process-pool initializer: one BLAS/OpenMP thread in this worker (the batch runs one
    fit per core instead), for libraries loaded now and later."""
    for name in _BLAS_ENV:
        os.environ[name] = "1"
    threadpool_limits(limits=1)


def remove_partial(task: FitTask) -> list[Path]:
    """Delete the temporary files an atomic writer left for one task's tyre when its process
    was killed mid-write (``.<name>.XXXX.tmp`` in its fit directory and of its report).

    Returns
    -------
    list of Path
        The files deleted.
    """
    found = []
    if task.fit_dir.is_dir():
        found += [p for p in task.fit_dir.rglob(".*.tmp") if p.is_file()]
    report = task.report_path
    if report is not None and report.parent.is_dir():
        found += [p for p in report.parent.glob(f".{report.name}.*.tmp") if p.is_file()]
    for path in found:
        try:
            path.unlink()
        except FileNotFoundError:
            pass
    return found


def _blas_threads() -> int:
    return max((int(p.get("num_threads") or 0) for p in threadpool_info()), default=0)


def fit_task(task: FitTask) -> TaskOutcome:
    """Fit one folder as ``mfid fit`` does and write its report; never raises an MfidError.

    Returns
    -------
    TaskOutcome
        :data:`OK`; :data:`FAILED` with the failed fits (outputs written) or an unexpected
        error; :data:`BAD_INPUT` with the one-line InputError.
    """
    t0 = time.perf_counter()
    if task.marker:
        try:
            Path(task.marker).write_text(f"{socket.gethostname()} {os.getpid()}\n")
        except OSError:  # the batch that submitted it is gone: the fit is still wanted
            pass
    remove_partial(task)
    threads = 0

    def outcome(status: str, message: str = "") -> TaskOutcome:
        return TaskOutcome(task.folder, task.tyre_id, status, message,
                           time.perf_counter() - t0, 1, threads)

    try:
        with threadpool_limits(limits=1), warnings.catch_warnings():
            threads = _blas_threads()
            # numerical warnings from trial points are expected; failures are reported
            warnings.simplefilter("ignore", RuntimeWarning)
            run = fit_folder(task.folder, out_root=task.out_root, settings=task.settings,
                             command=task.command)
            if task.report_path is not None:
                write_report(run.fit_dir, task.report_path)
    except MfidError as exc:
        return outcome(BAD_INPUT if exc.exit_code == 2 else FAILED, str(exc))
    except Exception as exc:  # noqa: BLE001 - a bug in one fit must not stop the batch
        return outcome(FAILED, f"unexpected {type(exc).__name__}: {exc}")
    if run.failed:
        return outcome(FAILED, "fit did not converge: " + "; ".join(run.failed))
    return outcome(OK)
