"""Row-by-row checks of a numeric CSV: the line and column of every bad cell.

:func:`identify.io.common.read_numeric_csv` parses with pandas' C parser, which says only that
a file is not a table of numbers, or gives NaN for an empty cell, a short row and a token such
as ``NA``. The checks here name the line (a quoted cell may span lines: a row counts from the
line it starts on) and the column of each problem. :func:`walk_rows` reads every row with the
csv module; :func:`walk_suspects` looks only at the rows the parse left with a non-finite
value, from the raw lines, which is exact when the file has no quotes, NUL bytes or lone
carriage returns and its non-blank lines are the parsed rows one to one (an order of magnitude
faster than parsing every row again), and otherwise says it cannot be used.

Each problem is reported through ``add(line, column, message, kind)`` (column None for a whole
row).
"""
from __future__ import annotations

import csv
from collections.abc import Callable, Iterable
from typing import BinaryIO, TextIO

import numpy as np

from identify.core.errors import one_line

__all__ = ["RowError", "RowLines", "row_starts", "walk_rows", "walk_suspects"]

Add = Callable[[int, "str | None", str, str], None]
#: Problems a suspect walk holds back before it gives up (the full walk then lists them).
MAX_HELD = 10_000


class RowError(Exception):
    """A row the csv module cannot parse (a field over its limit, a NUL byte)."""

    def __init__(self, message: str, line: int) -> None:
        super().__init__(message)
        self.message, self.line = message, line


class RowLines:
    """The line of each data row of a CSV whose rows are not its lines one to one (a blank
    line, a quoted cell over two lines): ``lines + row`` is the line of data row ``row``
    (0-based), as ``first_line + row`` is for a plain file, so the callers that name a line
    take either."""

    def __init__(self, starts: np.ndarray) -> None:
        self.starts = starts

    def __add__(self, row: int) -> int:
        return int(self.starts[row])

    def __repr__(self) -> str:
        return f"RowLines({self.starts.size} rows)"


def row_starts(fh: TextIO) -> np.ndarray:
    """The first line of every data row of the text ``fh`` (opened with ``newline=""``,
    header first), counted as :func:`walk_rows` counts them: a blank line is no row."""
    reader = csv.reader(fh)
    rows = _rows(reader)
    next(rows, None)
    return np.fromiter((line for line, row in rows if not _blank(row)), dtype=np.int64)


def _blank(row: list[str]) -> bool:
    """A line pandas skips: empty, or only spaces and tabs (no comma, no quote)."""
    return not row or (len(row) == 1 and not row[0].strip(" \t"))


def _rows(reader):
    """(first line of the row, row) of a csv reader; a multi-line quoted cell counts from
    the line it starts on."""
    end = reader.line_num
    while True:
        try:
            row = next(reader)
        except StopIteration:
            return
        except csv.Error as exc:
            raise RowError(f"cannot parse CSV: {exc}", end + 1) from None
        start, end = end + 1, reader.line_num
        yield start, row


def _cell(text: str) -> str:
    """A cell for a message: escaped and cut (a quoted cell may hold line breaks)."""
    return one_line(text, 60)


def _check_row(line: int, row: list[str], names: list[str], allow_nan: bool,
               add: Add) -> None:
    width = len(names)
    if len(row) != width:
        add(line, None, f"ragged row: {len(row)} fields, the header has {width}", "ragged-row")
    for name, cell in zip(names, row, strict=False):
        text = cell.strip()
        if allow_nan and text == "":
            continue
        try:
            value = float(text)
        except ValueError:
            why = ("empty cell" if text == "" else "not UTF-8 text: a byte cannot be decoded"
                   if "\ufffd" in text else f"not a number: '{_cell(text)}'")
            add(line, name, why, "bad-cell")
            continue
        if not (allow_nan or np.isfinite(value)):
            add(line, name, f"{_cell(text)} is not allowed (NaN/inf)", "bad-cell")


def walk_rows(fh: TextIO, names: list[str], allow_nan: bool, add: Add) -> int:
    """Check every row of the text ``fh`` (opened with ``newline=""``, header first); return
    the number of data rows. Raises :class:`RowError` for a row the csv module refuses."""
    rows = 0
    reader = csv.reader(fh)
    next(_rows(reader), None)
    for line, row in _rows(reader):
        if not _blank(row):
            rows += 1
            _check_row(line, row, names, allow_nan, add)
    return rows


def walk_suspects(fh: BinaryIO, names: list[str], allow_nan: bool, suspects: Iterable[int],
                  n_rows: int, add: Add) -> bool:
    """Check only the data rows ``suspects`` (0-based, increasing) of the binary ``fh``.

    Returns False, having reported nothing, when the lines cannot stand for the rows (a
    quote, a NUL byte or a lone carriage return anywhere, a number of non-blank lines other
    than ``n_rows``, more than :data:`MAX_HELD` problems): then :func:`walk_rows` is needed.
    Raises :class:`RowError` where the csv module refuses a suspect row (as the full walk
    does, after the problems of the rows above it).
    """
    held: list[tuple[int, str | None, str, str]] = []
    wanted = iter(suspects)
    target = next(wanted, None)
    index = -1
    for number, raw in enumerate(fh, 1):
        if b'"' in raw or b"\x00" in raw:
            return False
        text = raw.rstrip(b"\n").removesuffix(b"\r")
        if b"\r" in text:
            return False
        if number == 1 or not text.strip(b" \t"):
            continue  # the header; a blank line (or one of spaces and tabs) is no row
        index += 1
        if index == target:
            try:  # the csv module on the line: its own errors (the field limit) as well
                row = next(csv.reader([text.decode("utf-8", "replace")]))
            except csv.Error as exc:
                for found in held:
                    add(*found)
                raise RowError(f"cannot parse CSV: {exc}", number) from None
            _check_row(number, row, names, allow_nan, lambda *a: held.append(a))
            if len(held) > MAX_HELD:
                return False
            target = next(wanted, None)
    if index + 1 != n_rows:
        return False
    for found in held:
        add(*found)
    return True
