"""Worker processes for the independent parts of one fit (the profile intervals of the MF
stages, the report's pages).

One ``mfid fit`` is mostly a chain of stages, each reading the one before; what does not chain
(each stage's profile intervals once every stage is fitted; the report's pages after the fits')
can use a second core. The workers are fresh interpreters (``spawn``: the parent holds JAX's
threads, which a forked child must not inherit), with one BLAS thread each, as the fit itself
(identify.workflows.fit): the same numbers as in the parent, whichever process computes them.

How many: ``--workers N`` of ``mfid fit``; by default :func:`default_workers` (none on a machine
whose cores are busy). A batch of fits
(``mfid batch``, ``make -j``) already runs one fit per core and gives each fit one worker (the
serial path, no extra process).
"""
from __future__ import annotations

import importlib
import os
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor
from multiprocessing import get_context

__all__ = ["MAX_WORKERS", "THREAD_ENV", "default_workers", "process_pool", "warm_up"]

MAX_WORKERS = 2
"""Processes one fit uses by default at most: its independent parts are few and short (a
stage's profile intervals, two halves of the report), so a third process would mostly wait."""

THREAD_ENV = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")
"""Thread-count variables: a process already told to use several threads per process leaves
fewer cores for workers (:func:`default_workers`)."""


def _cores() -> int:
    """The cores this process may run on (its CPU affinity where the system tells it)."""
    try:
        return len(os.sched_getaffinity(0))
    except (AttributeError, OSError):  # pragma: no cover - not Linux
        return os.cpu_count() or 1


def _threads_per_process() -> int:
    """The largest thread count the environment asks of each process (THREAD_ENV; 1 when
    none is set or readable)."""
    counts = []
    for name in THREAD_ENV:
        try:
            counts.append(int(os.environ.get(name, "1")))
        except ValueError:
            continue
    return max([1] + counts)


def _busy() -> float:
    """Runnable processes on the machine, averaged over the last minute (0 where the system
    does not tell)."""
    try:
        return float(os.getloadavg()[0])
    except (AttributeError, OSError):  # pragma: no cover - not Unix
        return 0.0


def default_workers() -> int:
    """Processes for one fit: this one, plus the cores that other work leaves idle (the cores
    available less the load average, rounded), divided by the threads each process is told to
    use (THREAD_ENV); at most MAX_WORKERS, at least 1. One core, OMP_NUM_THREADS=2 on two
    cores, or a machine whose cores are all busy: 1 (everything in this process; a worker
    there only takes time from the others and pays its start)."""
    idle = max(0, int(_cores() - _busy() + 0.5))
    return max(1, min(MAX_WORKERS, min(_cores(), 1 + idle) // _threads_per_process()))


def _one_thread() -> None:
    """Worker initializer: one BLAS thread, as the fit in the parent."""
    from threadpoolctl import threadpool_limits

    threadpool_limits(limits=1, user_api="blas")


def process_pool(workers: int) -> ProcessPoolExecutor:
    """A pool of ``workers`` fresh interpreters (spawn) with one BLAS thread each."""
    return ProcessPoolExecutor(max_workers=max(1, int(workers)), mp_context=get_context("spawn"),
                               initializer=_one_thread)


def _import(modules: Sequence[str]) -> None:
    for name in modules:
        try:
            importlib.import_module(name)
        except ImportError:  # an optional extra (jax) that is not installed
            continue


def warm_up(pool: ProcessPoolExecutor, workers: int, modules: Sequence[str]) -> None:
    """Start ``workers`` processes of ``pool`` now and have each import ``modules``: a fresh
    interpreter takes seconds to import the fit stack, which it then does while the parent
    fits the stages, not when the first job arrives."""
    for _ in range(max(1, int(workers))):
        pool.submit(_import, tuple(modules))
