"""Where the tasks of ``mfid batch`` run: the standard library's process pool (default) or Dask.

Both engines offer the same three calls to the batch loop: ``submit(task)``, ``collect(timeout)``
(the tasks that ended, each with its :class:`TaskOutcome` or a :class:`WorkerDied`) and
``close(cancel)``. The batch loop resubmits a task whose worker died and charges the death to
the task's ``--retries`` only when that task's own worker died.

The process pool (:class:`PoolEngine`) is ``concurrent.futures.ProcessPoolExecutor`` on
forkserver workers that preload the fit stack. When one worker dies (killed, out of memory) the
executor marks the pool broken, fails every unfinished future and terminates the other workers
with SIGTERM. The engine then reads which process ran which task (the marker file each task
writes when it starts) and each process's exit code: the task whose worker died by anything but
that SIGTERM is charged; tasks whose worker the pool stopped, or that had not started, are
resubmitted free; a new pool replaces the broken one.
"""
from __future__ import annotations

import signal
from collections.abc import Iterable
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from multiprocessing.context import ForkServerContext, ForkServerProcess
from pathlib import Path
from typing import ClassVar, Protocol

from identify.workflows.batch.task import FAILED, FitTask, TaskOutcome, fit_task, worker_init

__all__ = ["Engine", "PoolEngine", "WorkerDied", "describe_exit", "marker_pid"]


@dataclass(frozen=True)
class WorkerDied:
    """A task's attempt ended because a worker process died.

    Attributes
    ----------
    charged : bool    the task's own worker died: it counts as one of the task's retries
    detail : str      what happened, for the log (``worker pid 123 was killed by SIGKILL``)
    started : bool    the task had started (else it was queued and is resubmitted free)
    """

    charged: bool
    detail: str
    started: bool = True


Ended = tuple[FitTask, TaskOutcome | WorkerDied]


class Engine(Protocol):
    """What the batch loop needs from an engine."""

    name: str

    def submit(self, task: FitTask) -> None: ...

    def collect(self, timeout: float) -> list[Ended]: ...

    def close(self, cancel: bool = False) -> None: ...


def describe_exit(code: int | None) -> str:
    """A process's exit code in words: ``was killed by SIGKILL``, ``exited with code 3``."""
    if code is None:
        return "stopped"
    if code < 0:
        try:
            return f"was killed by {signal.Signals(-code).name}"
        except ValueError:
            return f"was killed by signal {-code}"
    return f"exited with code {code}"


def marker_pid(task: FitTask) -> int | None:
    """The process id a task's marker file names (``host pid``), or None when the task had
    not started."""
    if not task.marker:
        return None
    try:
        return int(Path(task.marker).read_text().split()[-1])
    except (OSError, ValueError, IndexError):
        return None


def failed_outcome(task: FitTask, exc: BaseException) -> TaskOutcome:
    """The outcome of a task whose call raised in the engine itself (not in the fit)."""
    return TaskOutcome(task.folder, task.tyre_id, FAILED,
                       f"unexpected {type(exc).__name__}: {exc}", attempts=1)


_FREE_BREAKS = 3
"""Pool breakages in a row that charge no task (workers dying before a task starts, e.g. at
start-up) after which every task of the next breakage is charged, so that the batch ends."""


class _TrackedProcess(ForkServerProcess):
    """A forkserver pool worker that stays findable by pid after the pool let it go, so that
    its exit code can be read once the pool broke."""

    started: ClassVar[dict[int, _TrackedProcess]] = {}

    def start(self) -> None:
        super().start()
        _TrackedProcess.started[self.pid] = self


def _forget_ended() -> None:
    for pid in [p for p, proc in _TrackedProcess.started.items() if proc.exitcode is not None]:
        del _TrackedProcess.started[pid]


class _TrackedContext(ForkServerContext):
    Process = _TrackedProcess


class PoolEngine:
    """``workers`` forkserver processes of the standard library's process pool."""

    name = "process pool"

    def __init__(self, workers: int):
        self.workers = int(workers)
        self._context = _TrackedContext()
        # the fit stack (~1.5 s to import) is imported once, in the fork server
        self._context.set_forkserver_preload(["identify.workflows.batch.task"])
        self._pool = self._new_pool()
        self._futures: dict[Future, FitTask] = {}
        self._free_breaks = 0  # pool breakages in a row that charged no task

    def _new_pool(self) -> ProcessPoolExecutor:
        return ProcessPoolExecutor(self.workers, mp_context=self._context,
                                   initializer=worker_init)

    def submit(self, task: FitTask) -> None:
        self._futures[self._pool.submit(fit_task, task)] = task

    def collect(self, timeout: float) -> list[Ended]:
        if not self._futures:
            return []
        done, _ = wait(list(self._futures), timeout=timeout, return_when=FIRST_COMPLETED)
        ended: list[Ended] = []
        broken: list[FitTask] = []
        for fut in done:
            self._settle(fut, ended, broken)
        if broken:
            # the executor failed every unfinished future at once; wait for all of them and for
            # its workers to be joined, so that every exit code is known
            for fut in wait(list(self._futures)).done:
                self._settle(fut, ended, broken)
            self._pool.shutdown(wait=True)
            ended += self._attribute(broken)
            self._pool = self._new_pool()
        return ended

    def _settle(self, fut: Future, ended: list[Ended], broken: list[FitTask]) -> None:
        task = self._futures.pop(fut)
        try:
            ended.append((task, fut.result()))
        except BrokenProcessPool:
            broken.append(task)
        except Exception as exc:  # noqa: BLE001 - e.g. a task that cannot be pickled
            ended.append((task, failed_outcome(task, exc)))

    def _attribute(self, broken: Iterable[FitTask]) -> list[Ended]:
        """Which of the broken pool's tasks lost their own worker (charged) and which were
        stopped by the pool or had not started (free)."""
        pids = {task: marker_pid(task) for task in broken}
        codes = {task: self._exit_code(pid) for task, pid in pids.items() if pid is not None}
        own = {t for t, c in codes.items() if c is not None and c != -signal.SIGTERM}
        if not own:  # every worker ended by SIGTERM (e.g. sent by a user): cannot tell
            own = set(codes)
        self._free_breaks = 0 if own else self._free_breaks + 1
        if self._free_breaks > _FREE_BREAKS:  # workers die before any task starts
            own = set(pids)
        out: list[Ended] = []
        for task, pid in pids.items():
            if task in own:
                how = describe_exit(codes.get(task)) if pid is not None else "died"
                died = WorkerDied(True, f"its worker (pid {pid}) {how}", pid is not None)
            elif pid is not None:
                died = WorkerDied(False, f"its worker (pid {pid}) was stopped when another "
                                         "worker died")
            else:
                died = WorkerDied(False, "not started when a worker died", started=False)
            out.append((task, died))
        _forget_ended()
        return out

    @staticmethod
    def _exit_code(pid: int) -> int | None:
        proc = _TrackedProcess.started.get(pid)
        return None if proc is None else proc.exitcode

    def close(self, cancel: bool = False) -> None:
        """Shut the pool down; with ``cancel``, drop queued tasks and stop running ones."""
        if cancel:
            for fut in self._futures:
                fut.cancel()
            for proc in list(_TrackedProcess.started.values()):
                if proc.exitcode is None:
                    proc.terminate()
        self._pool.shutdown(wait=True, cancel_futures=cancel)
        self._futures.clear()
        _forget_ended()
