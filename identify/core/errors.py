"""User-facing error types.

Every error a user can cause (a bad file, a missing channel, a wrong unit) is raised as a
:class:`InputError`, whose ``str()`` is the one line the CLI prints: ``file:line: key: what``.
The CLI maps :class:`InputError` to exit code 2 and :class:`FitError` to exit code 1.
"""
from __future__ import annotations

from pathlib import Path

__all__ = ["MfidError", "InputError", "FitError", "one_line"]


class MfidError(Exception):
    """Base class of the errors that the CLI reports as one line, without a traceback."""

    exit_code = 2


class InputError(MfidError):
    """Bad user input: a file, row/line or key/channel, and what is wrong with it.

    Parameters
    ----------
    file : str or Path or None
        The file that holds the problem (None when it is not about a file).
    message : str
        What is wrong, in a few words (``"malformed number '1.2.3'"``).
    line : int or None
        1-based line (or row) number in the file.
    key : str or None
        The key, column or channel concerned.
    """

    exit_code = 2

    def __init__(self, file: str | Path | None, message: str, *, line: int | None = None,
                 key: str | None = None) -> None:
        self.file = None if file is None else str(file)
        self.message = message
        self.line = line
        self.key = key
        super().__init__(self.__str__())

    def __str__(self) -> str:
        where = one_line(self.file or "")
        if self.line is not None:
            where = f"{where}:{self.line}"
        parts = [p for p in (where, one_line(self.key or "", 80), one_line(self.message)) if p]
        return ": ".join(parts)


def one_line(text: str, limit: int = 400) -> str:
    """``text`` as one printable line: line breaks and control characters escaped, cut to
    ``limit`` characters (a 100,000-character CSV cell, a file name with a newline in it)."""
    if text.isprintable() and len(text) <= limit:
        return text
    out = "".join(c if c.isprintable() else repr(c)[1:-1] for c in text)
    return out if len(out) <= limit else out[:limit - 3] + "..."


class FitError(MfidError):
    """A fit that could not produce a trustworthy result (no convergence, infeasible)."""

    exit_code = 1
