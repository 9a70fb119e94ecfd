"""The ``mfid`` console script: signal handlers first, then the command line.

SIGINT (Ctrl-C) or SIGTERM at any moment, even while the libraries are still being imported,
ends the command with one line on stderr and exit 128 + the signal number (130 for SIGINT,
143 for SIGTERM), never a traceback. The handler raises :class:`Interrupted`, a
``BaseException`` that is not a ``KeyboardInterrupt`` (click and typer would turn that into a
silent exit), so that every ``with``/``finally`` on the way out still runs: the atomic writers
remove their temporary files (identify.core.atomic) and no partial output is left.
"""
from __future__ import annotations

import os
import signal
import sys

__all__ = ["BLAS_THREADS", "Interrupted", "MESSAGE", "main"]

#: Environment variables that set the BLAS libraries' thread counts.
BLAS_THREADS = ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")

MESSAGE = ("interrupted: no partial output was left (files are written to a temporary name and "
           "renamed)")


class Interrupted(BaseException):
    """Raised by the SIGINT/SIGTERM handler; ``signum`` is the signal."""

    def __init__(self, signum: int) -> None:
        super().__init__(signum)
        self.signum = signum


def _raise(signum: int, frame) -> None:
    raise Interrupted(signum)


def _quit(signum: int) -> None:
    for sig in (signal.SIGINT, signal.SIGTERM):  # a second Ctrl-C must not interrupt this
        signal.signal(sig, signal.SIG_IGN)
    try:
        sys.stderr.flush()
    except (OSError, ValueError):
        pass
    os.write(2, f"\n{MESSAGE}\n".encode())
    sys.exit(128 + signum)  # the with/finally blocks have run; atexit handlers still run


def main() -> None:
    """Console-script entry point: install the handlers, import the app, run it."""
    signal.signal(signal.SIGINT, _raise)
    signal.signal(signal.SIGTERM, _raise)
    # one BLAS thread unless the user says otherwise, set before numpy loads its BLAS: mfid's
    # linear algebra is on small dense matrices, where a second thread gains nothing and, on a
    # machine busy with other work, makes every decomposition wait for a free core
    for name in BLAS_THREADS:
        os.environ.setdefault(name, "1")
    try:
        # Deferred import, after the handlers: importing identify.cli.app (typer, rich and
        # the commands) takes a noticeable fraction of a second, and a Ctrl-C in that time
        # must quit as any other does, not print a KeyboardInterrupt traceback.
        from identify.cli.app import app

        app()
    except Interrupted as exc:
        _quit(exc.signum)
    except SystemExit:
        for sig in (signal.SIGINT, signal.SIGTERM):  # done: a late signal changes nothing
            signal.signal(sig, signal.SIG_IGN)
        raise


if __name__ == "__main__":  # pragma: no cover
    main()
