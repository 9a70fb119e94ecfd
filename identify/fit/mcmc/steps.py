"""Stepping an emcee chain until it is longer than 50 autocorrelation times, reaches its step
cap or runs out of its time budget, with progress (:class:`ChainProgress`) about once a
second, and SIGINT/SIGTERM held while the walkers evaluate and delivered between steps
(identify.fit.mcmc.chains runs the chains; the CLI's handler removes their temporary files)."""
from __future__ import annotations

import math
import signal
import threading
import time
from collections.abc import Callable
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

__all__ = ["CHUNK", "FIRST_CHECK", "MIN_CHECK", "PROGRESS_EVERY", "STOPS", "TAU_FACTOR",
           "ChainProgress", "run_chain"]

TAU_FACTOR = 50
CHUNK = 500
"""Most steps between two estimates of the autocorrelation time."""
FIRST_CHECK = 250
"""Steps before the first estimate; later ones come when the chain should pass 50 tau by the
last estimate (at least MIN_CHECK, at most CHUNK steps later)."""
MIN_CHECK = 100

@dataclass(frozen=True)
class ChainProgress:
    """Where a chain stands, for a progress bar (``run_mcmc(progress=...)``).

    Attributes
    ----------
    steps : int              steps done
    max_steps : int          the step cap
    tau : float              largest autocorrelation time so far [steps]; NaN before the
                             first estimate (after FIRST_CHECK steps)
    target : int             steps the chain is expected to run: 50 tau (the cap while tau is
                             unknown), at most the cap
    elapsed : float          [s] since the chain started
    budget : float or None   the time budget [s]
    stop : str               "" while running; then "converged", "max_steps" or "budget"
    """

    steps: int
    max_steps: int
    tau: float
    target: int
    elapsed: float
    budget: float | None
    stop: str = ""

    @property
    def eta(self) -> float:
        """Estimated seconds left (NaN before the first step), at most the budget left."""
        if self.stop:
            return 0.0
        if self.steps == 0:
            return math.nan
        left = (max(self.target - self.steps, 0)) * self.elapsed / self.steps
        if self.budget is not None:
            left = min(left, max(self.budget - self.elapsed, 0.0))
        return left


STOPS = ("converged", "max_steps", "budget")
"""Why a chain stopped: longer than 50 tau, the step cap, the time budget."""
PROGRESS_EVERY = 1.0
"""Seconds between progress calls while a chain runs."""


@contextmanager
def _signals_between_steps():
    """Hold SIGINT/SIGTERM while the walkers evaluate, deliver them between steps.

    emcee prints a traceback for any exception raised inside the log-probability (Ctrl-C
    included) before passing it on; a signal that arrives during a step is recorded and, when
    the block ends, handed to the handler that was in place (the CLI's: one line, exit 130 or
    143, temporary chain files removed). Yields the list of pending signals; outside the main
    thread signals cannot be handled and nothing changes.
    """
    if threading.current_thread() is not threading.main_thread():
        yield []
        return
    pending: list[int] = []
    watched = (signal.SIGINT, signal.SIGTERM)
    previous = {s: signal.getsignal(s) for s in watched}

    def hold(signum, frame):
        if previous[signum] is not signal.SIG_IGN:  # an ignored signal must not end the chain
            pending.append(signum)

    for s in watched:
        signal.signal(s, hold)
    try:
        yield pending
    finally:
        for s in watched:
            signal.signal(s, previous[s])
    if pending:
        handler = previous[pending[0]]
        if callable(handler):
            handler(pending[0], None)
        elif pending[0] == signal.SIGINT and handler == signal.SIG_DFL:
            raise KeyboardInterrupt
        else:
            signal.raise_signal(pending[0])


def _converges_at(tau: np.ndarray) -> int | None:
    """Steps at which the chain is longer than 50 x the largest autocorrelation time ``tau``;
    None while tau is unknown (not finite)."""
    if not np.all(np.isfinite(tau)):
        return None
    return int(math.ceil(TAU_FACTOR * float(np.max(tau)))) + 1


def _next_chunk(tau: np.ndarray, steps: int) -> int:
    """Steps to the next estimate of tau: to where the last one says 50 tau is reached, at
    least MIN_CHECK, at most CHUNK (CHUNK while tau is unknown)."""
    at = _converges_at(tau)
    return CHUNK if at is None else min(max(at - steps, MIN_CHECK), CHUNK)


def run_chain(sampler, state, max_steps: int, budget: float | None, progress, t0: float,
              tau_fn: Callable[[], np.ndarray], steps0: int = 0, tau0=None):
    """Run until 50 tau, the cap or the budget (checked every step), estimating tau after
    FIRST_CHECK steps and then where the last estimate says 50 tau is reached (MIN_CHECK to
    CHUNK steps on); return the last state, steps, the autocorrelation times ``tau_fn()`` and
    why it stopped. ``steps0``, ``tau0``: a chain continued from where it stopped."""
    steps, tau, stop = steps0, np.full(1, np.inf) if tau0 is None else tau0, ""
    last = -math.inf
    chunk = _next_chunk(tau, steps) if steps0 and _converges_at(tau) is not None else FIRST_CHECK

    def report(stop_now=""):
        tmax = float(np.max(tau)) if np.all(np.isfinite(tau)) else math.nan
        at = _converges_at(tau)
        target = max_steps if at is None else min(max_steps, at)
        progress(ChainProgress(steps, max_steps, tmax, target, time.perf_counter() - t0,
                               budget, stop_now))

    with _signals_between_steps() as pending:
        while not stop and not pending:
            for new in sampler.sample(state, iterations=min(chunk, max_steps - steps)):
                state = new
                steps += 1
                now = time.perf_counter()
                if pending:
                    break
                if budget is not None and now - t0 >= budget:
                    stop = "budget"
                    break
                if progress is not None and now - last >= PROGRESS_EVERY:
                    last = now
                    report()
            if pending:
                break
            if steps >= 2:
                # a coordinate no walker has moved in yet (a chain stopped after a few steps)
                # has no autocorrelation: NaN, tau unknown, not a RuntimeWarning to the user
                with np.errstate(invalid="ignore", divide="ignore"):
                    tau = tau_fn()
            if np.all(np.isfinite(tau)) and steps > TAU_FACTOR * np.max(tau):
                stop = "converged"
            elif steps >= max_steps and not stop:
                stop = "max_steps"
            chunk = _next_chunk(tau, steps)
    if progress is not None:
        report(stop)
    return state, steps, tau, stop
