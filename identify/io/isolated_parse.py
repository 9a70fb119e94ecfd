"""Run a parse of untrusted bytes in a new interpreter and say only how it ended.

A C library that trusts a file (HDF5, scipy.io's MAT reader) can loop for good or crash the
process on a corrupt file, and a Python timer or ``except`` cannot stop either. The readers
therefore parse such files once in a child first. The child is a new interpreter, never a
``fork`` of the caller: the caller may be multithreaded (JAX, BLAS, a notebook), and a forked
copy of a multithreaded process can deadlock on a lock another thread held. It runs in its own
session, so a Ctrl-C at the terminal reaches mfid, which then stops it.
"""
from __future__ import annotations

import signal
import subprocess
import sys

__all__ = ["TIMEOUT", "child_fate"]

TIMEOUT = "timeout"
"""What :func:`child_fate` returns for a child that did not finish in time."""


def child_fate(args: list[str], data: bytes | None, timeout: float) -> str | None:
    """How ``python -P *args`` ended when fed ``data`` on stdin.

    Parameters
    ----------
    args : list of str
        Arguments after the interpreter (a script path, or ``-c`` and code).
    data : bytes, optional
        What the child reads on stdin (None: nothing).
    timeout : float
        Longest wait [s].

    Returns
    -------
    str or None
        None when the child exited by itself, whatever its exit code (an exception is left to
        the caller's own parse, which reports it), or when no child could be started;
        :data:`TIMEOUT` when it did not finish in ``timeout``; else the name of the signal
        that killed it (``"SIGSEGV"``).
    """
    try:  # -P: a script's folder (identify/io) is not put on the child's sys.path
        child = subprocess.Popen([sys.executable, "-P", *args],
                                 stdin=subprocess.DEVNULL if data is None else subprocess.PIPE,
                                 stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                 start_new_session=True)
    except OSError:
        return None
    try:
        child.communicate(data, timeout=timeout)
    except subprocess.TimeoutExpired:
        return TIMEOUT
    except OSError:  # the child died before it read all of the bytes (a broken pipe)
        child.wait()
    finally:
        if child.poll() is None:
            child.kill()
            child.wait()
    if child.returncode >= 0:
        return None
    try:
        return signal.Signals(-child.returncode).name
    except ValueError:
        return f"signal {-child.returncode}"
