"""``mfid batch``: fit many measurement folders, one task per folder, on a process pool or Dask.

Each task is the ordinary fit of one folder (:func:`identify.workflows.batch.task.fit_task`:
the outputs of ``mfid fit``, written atomically). A folder whose outputs are up to date
(:mod:`identify.workflows.batch.plan`) is skipped unless ``force``. Tasks run on
:class:`~identify.workflows.batch.engines.PoolEngine` (the standard library's process pool, the
default) or, with a ``scheduler``, on Dask (:mod:`identify.workflows.batch.dask_cluster`, the
optional
extra ``mfid[dask]``). A worker that dies costs its task one of ``retries``; a task that fails
(bad input, a fit that did not converge) is reported and the others go on. At the end the
summary across tyres is written: ``<out>/batch_summary.csv`` and, with reports,
``<reports>/batch_summary.pdf`` (:mod:`identify.report.batch_summary`). The summary is the
state of every tyre fitted into ``<out>``: a tyre of an earlier batch that this one did not
touch keeps its rows (its fit directory read again), so a batch of a few folders, or one that
fails on bad input, never drops the others.

Folders are told apart by their tyre id (the name of their outputs). The same folder given
twice is fitted once; of distinct folders that share an id the first is fitted and each later
one is refused as bad input, its message naming the folder that keeps the id.

Exit code rule (:attr:`BatchRun.exit_code`): 2 when any folder had bad input; else 1 when any
fit failed or a task was lost (its worker died more often than ``retries`` allow); else 0.
"""
from __future__ import annotations

import dataclasses
import os
import shutil
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from identify.core.atomic import temp_dir
from identify.core.errors import InputError
from identify.fit.run import FitSettings
from identify.io.fitdir import read_fit_dir
from identify.io.output_guard import (
    Inputs,
    check_fit_outputs,
    check_folder_output,
    measurement_inputs,
)
from identify.report.batch_summary import SUMMARY_CSV, BatchEntry, write_batch_summary
from identify.workflows.batch.engines import Engine, PoolEngine, WorkerDied
from identify.workflows.batch.plan import freshness, manifest_of
from identify.workflows.batch.task import (
    BAD_INPUT,
    FAILED,
    LOST,
    OK,
    UP_TO_DATE,
    FitTask,
    TaskOutcome,
    remove_partial,
)

__all__ = ["BatchEvents", "BatchRun", "default_workers", "make_engine", "run_batch"]

DASK_EXTRA = "pip install 'mfid[dask]'"
TICK_S = 0.5
"""How often the progress is refreshed while tasks run [s]."""
_NOT_REFITTED = "up to date, not refitted; "
"""Before the message of a folder whose up-to-date fit failed (left out of the summary)."""


def default_workers() -> int:
    """The cores this process may use."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # pragma: no cover - not Linux
        return os.cpu_count() or 1


class BatchEvents:
    """What the batch tells its caller while it runs (the CLI shows it with rich).

    Every method does nothing here; override the ones to show.
    """

    def start(self, engine: str, total: int, skipped: Sequence[TaskOutcome]) -> None:
        """Tasks are about to run on ``engine``; ``skipped`` were not started (up to date or
        bad input)."""

    def progress(self, done: int, running: int, failed: int, total: int,
                 eta_s: float | None) -> None:
        """``done`` of ``total`` tasks ended (``failed`` of them not ok), ``running`` run now;
        ``eta_s`` [s] until the last ends (None until one has ended)."""

    def ended(self, outcome: TaskOutcome) -> None:
        """A task ended."""

    def note(self, text: str) -> None:
        """Something worth a line: a worker died and its task runs again."""


@dataclass(frozen=True)
class BatchRun:
    """What one ``mfid batch`` did.

    Attributes
    ----------
    outcomes : tuple of TaskOutcome   one per folder, in the order given
    engine : str                      where the tasks ran ("" when none ran)
    summary_csv : Path or None        <out>/batch_summary.csv
    summary_pdf : Path or None        <reports>/batch_summary.pdf (None without reports)
    seconds : float                   wall time [s]
    """

    outcomes: tuple[TaskOutcome, ...]
    engine: str = ""
    summary_csv: Path | None = None
    summary_pdf: Path | None = None
    seconds: float = 0.0

    def count(self, status: str) -> int:
        return sum(o.status == status for o in self.outcomes)

    @property
    def exit_code(self) -> int:
        """2 if any folder had bad input, else 1 if any fit failed or task was lost, else 0."""
        statuses = {o.status for o in self.outcomes}
        if BAD_INPUT in statuses:
            return 2
        if statuses & {FAILED, LOST}:
            return 1
        return 0


def _dask_engine(scheduler: str):
    """The DaskEngine class, checked before any folder is read.

    Raises
    ------
    InputError
        A malformed address, or Dask is not installed (naming the extra to install).
    """
    if scheduler != "local" and "://" not in scheduler:
        raise InputError(None, f"expected 'local' or a Dask scheduler address such as "
                               f"tcp://HOST:8786, not {scheduler!r}", key="--scheduler")
    try:
        # optional dependency (the extra mfid[dask]); importing distributed also takes ~1 s,
        # which the default process pool does not pay
        from identify.workflows.batch.dask_cluster import DaskEngine
    except ImportError:
        raise InputError(None, f"Dask is not installed: {DASK_EXTRA} (or leave out "
                               "--scheduler to use the process pool)",
                         key="--scheduler") from None
    return DaskEngine


def make_engine(scheduler: str | None, workers: int) -> Engine:
    """The process pool (``scheduler`` None) or a Dask engine (``"local"`` or an address).

    Raises
    ------
    InputError
        A malformed address, Dask not installed (naming the extra), or no scheduler there.
    """
    if scheduler is None:
        return PoolEngine(workers)
    return _dask_engine(scheduler)(scheduler, workers)


def _plan(folders: Sequence[str | Path], out_root: Path, reports: Path | None,
          settings: FitSettings, force: bool, command: Callable[[str], str]
          ) -> list[FitTask | TaskOutcome]:
    """One FitTask (to run) or TaskOutcome (bad input, up to date) per folder, in order."""
    planned: list[FitTask | TaskOutcome] = []
    owner: dict[str, tuple[str, Path]] = {}
    for given in folders:
        name = str(given)
        try:
            folder, manifest = manifest_of(given)
        except InputError as exc:
            planned.append(TaskOutcome(name, "", BAD_INPUT, str(exc)))
            continue
        tyre_id = manifest.tyre.id
        if tyre_id in owner:
            first, where = owner[tyre_id]
            if where == folder.resolve():  # the same folder again: fitted once
                continue
            planned.append(TaskOutcome(name, tyre_id, BAD_INPUT, InputError(
                manifest.path, f"tyre id '{tyre_id}' is also the id of {first}, which is "
                               f"fitted: {name} is refused (their outputs would overwrite "
                               "each other; give it another tyre.id)", key="tyre.id").__str__()))
            continue
        try:  # each fit's own outputs: not inside any folder of the batch
            check_fit_outputs(out_root, reports, tyre_id, sum(
                (measurement_inputs(f) for f in folders), Inputs()))
        except InputError as exc:
            planned.append(TaskOutcome(name, tyre_id, BAD_INPUT, str(exc)))
            continue
        owner[tyre_id] = (name, folder.resolve())
        fit_dir = out_root / tyre_id
        report = None if reports is None else reports / f"{tyre_id}.pdf"
        if not force:
            fresh = freshness(folder, manifest, fit_dir, report, settings)
            if fresh.up_to_date and fresh.failed:  # not refitted: it would fail the same way
                planned.append(TaskOutcome(name, tyre_id, FAILED, _NOT_REFITTED
                                           + "fit did not converge: " + "; ".join(fresh.failed)))
                continue
            if fresh.up_to_date:
                planned.append(TaskOutcome(name, tyre_id, UP_TO_DATE, fresh.reason))
                continue
        planned.append(FitTask(name, tyre_id, str(out_root),
                               None if reports is None else str(reports), settings,
                               command(name)))
    return planned


def _eta(t0: float, done: int, total: int) -> float | None:
    if done == 0:
        return None
    return (time.perf_counter() - t0) / done * (total - done)


def _run_tasks(engine: Engine, tasks: list[FitTask], retries: int, marker_dir: Path,
               events: BatchEvents) -> dict[FitTask, TaskOutcome]:
    """Run every task to an outcome, resubmitting those whose worker died."""
    tasks = [dataclasses.replace(t, marker=str(marker_dir / f"{i}.pid"))
             for i, t in enumerate(tasks)]
    starts = dict.fromkeys(tasks, 0)
    deaths = dict.fromkeys(tasks, 0)
    outcomes: dict[FitTask, TaskOutcome] = {}
    t0 = time.perf_counter()

    def submit(task: FitTask) -> None:
        Path(task.marker).unlink(missing_ok=True)
        starts[task] += 1
        engine.submit(task)

    for task in tasks:
        submit(task)
    try:
        while len(outcomes) < len(tasks):
            for task, result in engine.collect(TICK_S):
                if isinstance(result, WorkerDied):
                    remove_partial(task)
                    starts[task] -= not result.started
                    deaths[task] += result.charged
                    if deaths[task] <= retries:
                        again = (f"; running it again (retry {deaths[task]} of {retries})"
                                 if result.charged else "; running it again")
                        events.note(f"{task.tyre_id}: {result.detail}{again}")
                        submit(task)
                        continue
                    result = TaskOutcome(task.folder, task.tyre_id, LOST,
                                         f"its worker died {deaths[task]} times (killed or out "
                                         f"of memory), the last time: {result.detail}")
                outcomes[task] = dataclasses.replace(result, attempts=starts[task])
                events.ended(outcomes[task])
            started = set(os.listdir(marker_dir))
            running = sum(Path(t.marker).name in started for t in tasks if t not in outcomes)
            failed = sum(o.status != OK for o in outcomes.values())
            events.progress(len(outcomes), running, failed, len(tasks),
                            _eta(t0, len(outcomes), len(tasks)))
    except BaseException:
        engine.close(cancel=True)
        for task in tasks:
            if task not in outcomes:
                remove_partial(task)
        raise
    engine.close()
    return {dataclasses.replace(t, marker=None): o for t, o in outcomes.items()}


def _fit_dir(out_root: Path, tyre_id: str):
    try:
        return read_fit_dir(out_root / tyre_id)
    except InputError:
        return None


def _earlier_entries(out_root: Path, current: Sequence[BatchEntry]) -> list[BatchEntry]:
    """The tyres of the batch summary already in ``out_root`` that this batch did not touch
    (neither their tyre id nor their folder is among ``current``), in their order, each with
    its fit directory read again; none when there is no readable summary."""
    try:
        earlier = pd.read_csv(out_root / SUMMARY_CSV, dtype=str, keep_default_na=False)
    except (OSError, ValueError):
        return []
    if not {"tyre", "folder", "task", "message"} <= set(earlier.columns):
        return []
    ids = {e.tyre_id for e in current if e.tyre_id}
    folders = {e.folder for e in current}
    out, seen = [], set()
    for row in earlier.itertuples(index=False):
        key = (row.tyre, row.folder)
        if key in seen or (row.tyre and row.tyre in ids) or row.folder in folders:
            continue
        seen.add(key)
        fd = _fit_dir(out_root, row.tyre) if row.tyre and row.relation else None
        task, message = row.task, "" if fd is not None else row.message
        if fd is None and row.relation:  # its fits are gone: the summary cannot vouch for them
            task = "missing"
            message = f"{out_root / row.tyre}: its fit directory is missing or unreadable"
        out.append(BatchEntry(row.tyre, row.folder, task, message, fd))
    return out


def _entries(outcomes: Sequence[TaskOutcome], out_root: Path) -> list[BatchEntry]:
    entries = []
    for o in outcomes:
        fd = None
        if o.status in (OK, FAILED, UP_TO_DATE) and o.tyre_id:
            try:
                fd = read_fit_dir(out_root / o.tyre_id)
            except InputError:
                fd = None
        # the summary is the state of the tyres, the same whether they were refitted now
        status, message = (OK, "") if o.status == UP_TO_DATE else (o.status, o.message)
        if o.status == FAILED:
            message = message.removeprefix(_NOT_REFITTED)
        entries.append(BatchEntry(o.tyre_id, o.folder, status, message, fd))
    return entries


def run_batch(folders: Sequence[str | Path], *, out_root: str | Path = "fits",
              reports: str | Path | None = "reports", settings: FitSettings = FitSettings(),
              workers: int | None = None, scheduler: str | None = None, retries: int = 2,
              force: bool = False, command: Callable[[str], str] | None = None,
              events: BatchEvents | None = None) -> BatchRun:
    """Fit every folder (one task each) and write the summary across tyres.

    Parameters
    ----------
    folders : sequence of path     measurement folders (each with tyre.toml)
    out_root : path                root of the fit directories (``<out>/<tyre id>/``)
    reports : path or None         folder of the PDF reports; None: no PDF at all
    settings : FitSettings         the settings of every fit
    workers : int, optional        worker processes (default: the cores); with a remote
                                   scheduler its own workers run the tasks
    scheduler : str, optional      None: process pool; "local": a Dask LocalCluster;
                                   "tcp://HOST:PORT": a running Dask scheduler
    retries : int                  how often a task runs again after its worker died
    force : bool                   refit folders whose outputs are up to date
    command : callable, optional   folder -> the ``mfid fit`` command recorded in its fit.json
    events : BatchEvents, optional progress callbacks

    Returns
    -------
    BatchRun
        One outcome per folder; ``exit_code`` applies the rule of the module docstring.

    Raises
    ------
    InputError
        Bad options (``--scheduler``, ``--workers``, ``--retries``), Dask missing, or the
        outputs cannot be written. A bad folder is not raised: it is an outcome.
    """
    t0 = time.perf_counter()
    events = events or BatchEvents()
    workers = default_workers() if workers is None else int(workers)
    if workers < 1:
        raise InputError(None, f"must be at least 1, not {workers}", key="--workers")
    if retries < 0:
        raise InputError(None, f"must be 0 or more, not {retries}", key="--retries")
    if scheduler is not None:
        _dask_engine(scheduler)
    out_root = Path(out_root)
    reports = None if reports is None else Path(reports)
    if scheduler not in (None, "local"):  # remote workers have their own working folder
        folders = [Path(f).absolute() for f in folders]
        out_root = out_root.absolute()
        reports = None if reports is None else reports.absolute()
    command = command or (lambda folder: f"mfid fit {folder}")
    # the summary's folders before any work: never inside a measurement folder
    inputs = sum((measurement_inputs(f) for f in folders), Inputs())
    check_folder_output(out_root, inputs, key="--out")
    if reports is not None:
        check_folder_output(reports, inputs, key="--reports")
    planned = _plan(folders, out_root, reports, settings, force, command)
    tasks = [p for p in planned if isinstance(p, FitTask)]
    engine_name = ""
    done: dict[FitTask, TaskOutcome] = {}
    if tasks:
        engine = make_engine(scheduler, workers)
        engine_name = engine.name
        events.start(engine_name, len(tasks), [p for p in planned if isinstance(p, TaskOutcome)])
        out_root.mkdir(parents=True, exist_ok=True)
        # .mfid-batch.<pid>.<random>.tmp: one left by a batch killed outright is removed here
        marker_dir = temp_dir(out_root / "mfid-batch")
        try:
            done = _run_tasks(engine, tasks, retries, marker_dir, events)
        finally:
            shutil.rmtree(marker_dir, ignore_errors=True)
    else:
        events.start("", 0, planned)
    outcomes = tuple(done[p] if isinstance(p, FitTask) else p for p in planned)
    entries = _entries(outcomes, out_root)
    csv, pdf = write_batch_summary(_earlier_entries(out_root, entries) + entries, out_root,
                                   reports)
    return BatchRun(outcomes, engine_name, csv, pdf, time.perf_counter() - t0)
