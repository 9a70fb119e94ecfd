"""The Dask engine of ``mfid batch`` (the optional extra ``mfid[dask]``).

``--scheduler local`` starts a ``distributed.LocalCluster`` of ``--workers`` worker processes
with one thread each; ``--scheduler tcp://HOST:PORT`` connects to a running scheduler (for
example one that dask-jobqueue started on SLURM, PBS or LSF, docs/batch.md), whose workers
must have the same mfid installed and see the same file system.

A worker that dies (killed, out of memory: its nanny restarts it) fails the task that ran on
it with ``KilledWorker``, which the batch loop resubmits while ``--retries`` allow. The local
scheduler gives up on a task at its first worker death (``allowed_failures=0``) so that
``--retries`` is the only count. Dask may have queued more tasks on the worker that died than
the one it ran: those fail with ``KilledWorker`` too, but wrote no marker file (the task writes
it when it starts), so they are resubmitted without being charged. A remote scheduler applies
its own ``distributed.scheduler.allowed-failures`` (default 3) before the batch sees a death.
"""
from __future__ import annotations

import logging
import uuid

from distributed import Client, Future, KilledWorker, LocalCluster, wait

from identify.core.errors import InputError
from identify.workflows.batch.engines import Ended, WorkerDied, failed_outcome, marker_pid
from identify.workflows.batch.task import FitTask, fit_task

__all__ = ["DaskEngine"]

CONNECT_TIMEOUT_S = 30
"""How long to wait for a remote scheduler [s]."""


class DaskEngine:
    """Tasks on a Dask cluster: a local one (``scheduler="local"``) or a running scheduler."""

    name = "dask"

    def __init__(self, scheduler: str, workers: int):
        self._cluster = None
        if scheduler == "local":
            self._cluster = LocalCluster(
                n_workers=int(workers), threads_per_worker=1, processes=True,
                dashboard_address=None, silence_logs=logging.CRITICAL,
                scheduler_kwargs={"allowed_failures": 0})
            self._client = Client(self._cluster)
            self.name = f"dask LocalCluster ({workers} workers)"
        else:
            try:
                self._client = Client(scheduler, timeout=CONNECT_TIMEOUT_S)
            except (OSError, TimeoutError, ValueError) as exc:
                raise InputError(None, f"cannot connect to the Dask scheduler {scheduler!r}: "
                                       f"{exc}", key="--scheduler") from None
            self.name = f"dask scheduler {scheduler}"
        self._futures: dict[Future, FitTask] = {}

    def submit(self, task: FitTask) -> None:
        key = f"mfid-fit-{task.tyre_id}-{uuid.uuid4().hex[:12]}"
        self._futures[self._client.submit(fit_task, task, key=key, pure=False)] = task

    def collect(self, timeout: float) -> list[Ended]:
        if not self._futures:
            return []
        try:
            done = wait(list(self._futures), timeout=timeout, return_when="FIRST_COMPLETED").done
        except TimeoutError:
            return []
        ended: list[Ended] = []
        for fut in done:
            task = self._futures.pop(fut)
            if fut.status == "finished":
                ended.append((task, fut.result()))
            elif fut.status == "error":
                exc = fut.exception()
                if isinstance(exc, KilledWorker) and marker_pid(task) is None:
                    # queued on the worker that died, not started: resubmitted free
                    ended.append((task, WorkerDied(False, "queued on a worker that died",
                                                   started=False)))
                elif isinstance(exc, KilledWorker):
                    ended.append((task, WorkerDied(True, "its worker died (KilledWorker)")))
                else:
                    ended.append((task, failed_outcome(task, exc)))
            else:  # cancelled or lost, e.g. when the scheduler restarted
                ended.append((task, WorkerDied(True, f"the task was {fut.status}")))
            fut.release()
        return ended

    def close(self, cancel: bool = False) -> None:
        """Close the client (and the local cluster, stopping its workers); with ``cancel``,
        cancel the unfinished tasks first (a task already running on a remote worker
        finishes there)."""
        if cancel and self._futures:
            self._client.cancel(list(self._futures))
        self._futures.clear()
        self._client.close()
        if self._cluster is not None:
            self._cluster.close()
