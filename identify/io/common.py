"""Shared pieces of the measurement loaders: problems, numeric CSV tables, sanity checks.

Numeric CSV files may be gzip-compressed (recognised from the content, whatever the name): long
Flatplank and trailer logs are often kept that way, and the bundled sample folder is.

Every loader reports what is wrong through a :class:`Problems` collector. In strict mode (what
``load_*`` functions use) the first problem is raised as :class:`~identify.core.errors.InputError`;
otherwise (``mfid check``) every problem is collected, so one pass lists them all.
"""
from __future__ import annotations

import csv
import gzip
import hashlib
import os
import stat
import warnings
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from identify.core.errors import InputError
from identify.core.serial import Serial
from identify.io.csv_rows import RowError, RowLines, row_starts, walk_rows, walk_suspects

__all__ = ["BOOLEAN_CELLS", "CR_ONLY", "cr_only", "Problem", "Problems", "TOLERANCE",
           "read_numeric_csv", "split_header_name",
           "check_increasing", "check_declared", "sha256_file", "starts_with", "is_gzip",
           "open_text", "file_problem", "decode_problem", "read_utf8", "row_lines"]

#: The first two bytes of every gzip stream (RFC 1952).
GZIP_MAGIC = b"\x1f\x8b"

#: Rows per block of the fast CSV parse (the block is the only transient copy of the data).
BLOCK_ROWS = 1 << 18

#: The cells pandas' C parser reads as booleans, 1.0 and 0.0, in a column of only such cells
#: (``True`` in every cell of a camber channel would be 1 rad). Read as missing instead, so
#: that the row walk names them as cells that are not numbers.
BOOLEAN_CELLS = ("True", "TRUE", "true", "False", "FALSE", "false")

#: Relative distance between a measured median and the manifest's declared value that is flagged.
TOLERANCE = 0.15


@dataclass(frozen=True)
class Problem(Serial):
    """One thing wrong with a measurement input; ``str()`` is ``file:line: key: message``."""

    file: str | None
    message: str
    line: int | None = None
    key: str | None = None

    def __str__(self) -> str:
        return str(self.to_error())

    def to_error(self) -> InputError:
        """The same problem as an exception."""
        return InputError(self.file, self.message, line=self.line, key=self.key)

    #: written after the fields (``to_dict``): ``text`` is the printed line
    serial_derived = {"text": str}
    serial_order = ("file", "line", "key", "message")


class Problems:
    """Collects problems; in strict mode the first one is raised as InputError.

    Parameters
    ----------
    strict : bool
        Raise on the first problem instead of collecting.
    limit : int
        At most this many problems of one ``kind`` per file are listed; the rest are counted
        and summarised in one line by :meth:`finish` (a file with a million NaNs stays readable).
    """

    def __init__(self, *, strict: bool = False, limit: int = 10) -> None:
        self.strict = strict
        self.limit = limit
        self.total = 0
        self._items: list[Problem] = []
        self._counts: dict[tuple[str | None, str], int] = {}

    @classmethod
    def or_strict(cls, problems: Problems | None) -> Problems:
        """The caller's collector, or a strict one when it gave none (every reader's default)."""
        return cls(strict=True) if problems is None else problems

    def add(self, file: str | Path | None, message: str, *, line: int | None = None,
            key: str | None = None, kind: str | None = None) -> None:
        """Record (or, when strict, raise) one problem."""
        problem = Problem(None if file is None else str(file), message, line, key)
        if self.strict:
            raise problem.to_error()
        self.total += 1
        if kind is not None:
            count = self._counts.get((problem.file, kind), 0) + 1
            self._counts[(problem.file, kind)] = count
            if count > self.limit:
                return
        self._items.append(problem)

    def finish(self) -> list[Problem]:
        """The problems in the order found, plus one summary line per truncated kind."""
        out = list(self._items)
        for (file, kind), count in self._counts.items():
            if count > self.limit:
                out.append(Problem(file, f"{count - self.limit} more {kind} problems not listed"))
        return out


def file_problem(path: str | Path, what: str = "file") -> str | None:
    """Why ``path`` cannot be read as a data file (None when it is a regular file).

    Only regular files are opened: a FIFO would block a reader forever, a device
    (``/dev/null``, ``/dev/zero``) is empty or endless. Symbolic links are followed; a link
    loop or a dangling link is named as such.
    """
    try:
        mode = os.stat(path).st_mode
    except FileNotFoundError:
        return ("dangling symbolic link" if os.path.islink(path) else "no such file or "
                "directory")
    except (OSError, ValueError) as exc:  # ELOOP, ENAMETOOLONG, EACCES, an embedded NUL
        return f"cannot read {what}: {getattr(exc, 'strerror', None) or exc}"
    if stat.S_ISDIR(mode):
        return f"is a directory, expected a {what}"
    if stat.S_ISFIFO(mode):
        return f"is a named pipe (FIFO), expected a regular {what}"
    if stat.S_ISCHR(mode) or stat.S_ISBLK(mode):
        return f"is a device, expected a regular {what}"
    if not stat.S_ISREG(mode):
        return f"is not a regular {what}"
    return None


#: The message for a text file whose lines end in CR alone (classic Mac OS text).
CR_ONLY = ("its lines end in CR alone (classic Mac OS text): save it with LF or CRLF line "
           "ends")


def cr_only(text: str | bytes) -> bool:
    """True when ``text`` has carriage returns between its lines and no line feed at all."""
    cr, lf = ("\r", "\n") if isinstance(text, str) else (b"\r", b"\n")
    return lf not in text and cr in text.rstrip(cr)


def decode_problem(data: bytes, exc: UnicodeDecodeError) -> tuple[int, str]:
    """The 1-based line and a one-line message for a UTF-8 decoding error in ``data``."""
    line = data.count(b"\n", 0, exc.start) + 1
    byte = data[exc.start:exc.start + 1]
    shown = f"0x{byte[0]:02X}" if byte else "end of data"
    return line, f"not UTF-8 text: byte {shown} cannot be decoded"


def read_utf8(path: Path, problems: Problems, *, missing: str = "file not found") -> str | None:
    """The whole text of ``path`` (UTF-8, a byte-order mark dropped), or None after adding
    the problem to ``problems``: ``missing`` for a file that is not there, the line and byte
    that is not UTF-8, or why the file cannot be read."""
    raw = b""
    try:
        raw = path.read_bytes()
        return raw.decode("utf-8-sig")
    except FileNotFoundError:
        problems.add(path, missing)
    except UnicodeDecodeError as exc:
        line, message = decode_problem(raw, exc)
        problems.add(path, message, line=line)
    except OSError as exc:
        problems.add(path, f"cannot read file: {getattr(exc, 'strerror', None) or exc}")
    return None


def split_header_name(text: str) -> tuple[str, str | None]:
    """``"SLIPANGL [deg]"`` or ``"SLIPANGL (deg)"`` -> ``("SLIPANGL", "deg")``; a plain name
    has unit None. Both bracket styles are common in loggers' exports."""
    text = text.strip()
    for opening, closing in (("[", "]"), ("(", ")")):
        if text.endswith(closing) and opening in text:
            name, unit = text[:-1].split(opening, 1)
            if name.strip():  # "(deg)" alone is a name, not a unit without one
                return name.strip(), unit.strip() or None
    return text, None


def starts_with(path: str | Path, magic: bytes) -> bool:
    """True when the file's first bytes are ``magic`` (False when it cannot be read or is
    not a regular file: opening a FIFO blocks)."""
    if file_problem(path) is not None:
        return False
    try:
        with open(path, "rb") as fh:
            return fh.read(len(magic)) == magic
    except OSError:
        return False


def is_gzip(path: str | Path) -> bool:
    """True when the file is gzip data (starts with the gzip magic bytes)."""
    return starts_with(path, GZIP_MAGIC)


def open_text(path: str | Path, **kwargs: Any):
    """Open a text file for reading, decompressing it on the fly when it is gzip data.

    Raises OSError for anything but a regular file (a FIFO would block the reader)."""
    _refuse(path)
    if is_gzip(path):
        return gzip.open(path, "rt", **kwargs)
    return open(path, **kwargs)  # noqa: SIM115 - the caller's context manager closes it


def _refuse(path: str | Path) -> None:
    """Raise the OSError (FileNotFoundError, IsADirectoryError) of a path that is not a
    regular file."""
    why = file_problem(path)
    if why is not None:
        raise (FileNotFoundError if why.startswith("no such") else IsADirectoryError
               if why.startswith("is a directory") else OSError)(why)


def _open_binary(path: Path):
    _refuse(path)
    if is_gzip(path):
        return gzip.open(path, "rb")
    return open(path, "rb")  # noqa: SIM115 - the caller's context manager closes it


def _header(path: Path, problems: Problems) -> list[str] | None:
    try:
        with _open_binary(path) as fh:  # bytes: a bad byte further down is not line 1's
            first = fh.readline().decode("utf-8-sig")
    except FileNotFoundError:
        problems.add(path, "file not found")
        return None
    except IsADirectoryError:
        problems.add(path, "is a directory, expected a CSV file")
        return None
    except UnicodeDecodeError:
        problems.add(path, "not a UTF-8 text file", line=1)
        return None
    except (OSError, EOFError) as exc:  # gzip.BadGzipFile is an OSError
        problems.add(path, f"cannot read file: {getattr(exc, 'strerror', None) or exc}")
        return None
    if "\x00" in first:
        problems.add(path, "binary data (NUL bytes), not a CSV text file", line=1)
        return None
    if cr_only(first):  # the csv module's own text would ask for "universal-newline mode"
        problems.add(path, CR_ONLY, line=1)
        return None
    if first.strip() == "":
        problems.add(path, "empty file: expected a header line with the column names"
                     if first == "" else "blank first line: expected the header line", line=1)
        return None
    try:
        cells = next(csv.reader([first]))
    except csv.Error as exc:  # a header cell over the csv module's field limit
        problems.add(path, f"cannot parse the header: {exc}", line=1)
        return None
    sep = next((name for c, name in ((";", "semicolons"), ("\t", "tabs")) if c in first), None)
    if len(cells) == 1 and sep:  # else only "ragged row" on line 2: a European export
        problems.add(path, f"the header is one column with {sep} in it: expected values "
                           "separated by commas, with a decimal point", line=1)
        return None
    return cells


def read_numeric_csv(path: str | Path, problems: Problems, *, required: Iterable[str] = (),
                     what: str = "channel", allow_nan: bool = False
                     ) -> tuple[pd.DataFrame, dict[str, str], int | RowLines] | None:
    """Read a CSV of numbers with a header line (``NAME`` or ``NAME [unit]`` per column).

    Fast path: pandas' C parser straight into float64, in blocks (:func:`_parse_floats`).
    Only when that fails, or a value is NaN/inf, is the file walked row by row to name each
    bad line (header = line 1). With
    ``allow_nan`` NaN, inf and empty cells are read as NaN (trailer data: the loader cleans
    them and warns).

    Returns
    -------
    (DataFrame, dict, int or RowLines) or None
        The columns as float64 under their names, the units given in the header, and where
        the rows are (:func:`row_lines`: ``lines + i`` is the line of row ``i``); None when a
        problem was found (in non-strict mode).
    """
    path = Path(path)
    start = problems.total
    cells = _header(path, problems)
    if cells is None:
        return None
    names, header_units = [], {}
    for i, cell in enumerate(cells, 1):
        name, unit = split_header_name(cell)
        if name == "":
            problems.add(path, f"empty column name (column {i})", line=1)
        elif name in names:
            problems.add(path, "duplicate column", line=1, key=name)
        if unit is not None:
            header_units[name] = unit
        names.append(name)
    for name in required:
        if name not in names:
            problems.add(path, f"missing required {what} (found: {', '.join(names)})",
                         line=1, key=name)
    frame = None
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", pd.errors.ParserWarning)
            frame, lines = _parse_floats(path)
    except _PARSE_ERRORS:
        frame = None
    # column by column: frame.to_numpy() would copy the whole table (520 MB at 5e6 x 13)
    finite = frame is not None and all(bool(np.isfinite(frame[c].to_numpy()).all())
                                       for c in frame.columns)
    if frame is not None and frame.shape[1] == len(names) and (finite or allow_nan):
        if len(frame) == 0:
            problems.add(path, "no data rows below the header", line=1)
            return None
        if not finite:  # NaN cells, or short rows pandas filled with NaN: walk to tell
            suspect = np.zeros(len(frame), dtype=bool)  # rows with a value not finite
            for c in frame.columns:  # inf -> NaN in place, one column at a time
                x = frame[c].to_numpy()
                bad = ~np.isfinite(x)
                if bad.any():
                    suspect |= bad
                    frame[c] = np.where(bad, np.nan, x)
            _diagnose(path, len(names), names, problems, allow_nan, suspect)
        frame.columns = names
        return ((frame, header_units, row_lines(path, len(frame), lines))
                if problems.total == start else None)
    _diagnose(path, len(names), names, problems, allow_nan)
    if problems.total == start:  # pandas refused something the row walk accepts
        problems.add(path, "cannot parse the file as a numeric CSV table")
    return None


def row_lines(path: str | Path, rows: int, lines: int | None = None) -> int | RowLines:
    """Where the ``rows`` data rows of the CSV ``path`` (as pandas reads it) are: 2 (the line
    of the first row; row ``i`` on line ``2 + i``) when its lines are the header and the rows
    one to one, else a :class:`~identify.io.csv_rows.RowLines` (a blank line, which pandas
    skips, would put every later message on the wrong line).

    ``lines`` is :func:`_count_lines` of the file when the caller has it (else one pass over
    the bytes); only a file with blank lines between its rows is walked with the csv module.
    """
    path = Path(path)
    if (_count_lines(path) if lines is None else lines) == rows + 1:
        return 2
    with open_text(path, encoding="utf-8-sig", newline="", errors="replace") as fh:
        try:
            starts = row_starts(fh)
        except RowError:  # pandas parsed the file: cannot happen
            return 2
    return RowLines(starts) if starts.size == rows else 2


def _count_lines(path: Path) -> int:
    """Lines of the (decompressed) file up to its last line that is not blank: more than its
    number of rows (the header is one), and one more exactly when no blank line or quoted
    cell over two lines lies between them."""
    breaks = trailing = 0  # line breaks; those after the last byte other than CR/LF
    with _open_binary(path) as fh:
        for block in iter(lambda: fh.read(1 << 22), b""):
            breaks += block.count(b"\n")
            text = len(block.rstrip(b"\r\n"))
            trailing = block.count(b"\n", text) + (trailing if text == 0 else 0)
    return breaks - trailing + 1


#: What pandas raises for a file its C parser cannot read as float64 columns.
_PARSE_ERRORS = (ValueError, pd.errors.ParserError, pd.errors.ParserWarning, UnicodeDecodeError,
                 OSError, EOFError)


def _parse_floats(path: Path) -> tuple[pd.DataFrame, int]:
    """The whole CSV as float64 columns: pandas' C parser, :data:`BLOCK_ROWS` rows at a time,
    each block copied into one preallocated array per column (a file of one block at most,
    such as a Flatplank run, is read in one call).

    One ``pd.read_csv`` of the whole file holds its parsed blocks and their concatenation at
    the same time (1.8 GB for a 5e6 x 13 table of 0.52 GB); here the only transient memory is
    one block. The arrays are sized by the file's line count (rows <= lines: a quoted cell may
    span lines); pages past the last row are never touched, so they take no memory.

    ``skipinitialspace`` reads a cell such as ``" nan"`` or a quoted cell after a space.
    Returns the table and the line count (:func:`_count_lines`).
    """
    capacity = _count_lines(path)
    options = dict(header=0, dtype=np.float64, index_col=False, skipinitialspace=True,
                   encoding="utf-8-sig", na_values=BOOLEAN_CELLS,
                   compression="gzip" if is_gzip(path) else None)
    if capacity <= BLOCK_ROWS:  # one block: read it as it is (no copy, no reader per block)
        return pd.read_csv(path, **options), capacity
    columns: list[np.ndarray] = []
    names: list[str] = []
    rows = 0
    with pd.read_csv(path, **options, chunksize=BLOCK_ROWS) as reader:
        for block in reader:
            if not names:
                names = [str(c) for c in block.columns]
                columns = [np.empty(capacity) for _ in names]
            m = len(block)
            if rows + m > capacity:  # cannot happen: rows <= lines
                raise ValueError("more rows than lines")
            for j, column in enumerate(columns):  # a column of a block is contiguous
                column[rows:rows + m] = block.iloc[:, j].to_numpy(dtype=np.float64)
            rows += m
    return pd.DataFrame({name: column[:rows] for name, column in zip(names, columns)},
                        copy=False), capacity


def _diagnose(path: Path, width: int, names: list[str], problems: Problems,
              allow_nan: bool = False, suspect: np.ndarray | None = None) -> None:
    """Report ragged rows, empty, non-numeric and non-finite cells with their lines.

    With ``suspect`` (per row of what the fast path parsed: a value not finite) only those
    rows are looked at when the file's lines allow it
    (:func:`identify.io.csv_rows.walk_suspects`), else every row is walked with the csv
    module."""
    def add(line: int, key: str | None, message: str, kind: str) -> None:
        problems.add(path, message, line=line, key=key, kind=kind)

    try:
        if suspect is not None:
            with _open_binary(path) as fh:
                if walk_suspects(fh, names, allow_nan, np.flatnonzero(suspect).tolist(),
                                 suspect.size, add):
                    return
        with open_text(path, encoding="utf-8-sig", newline="", errors="replace") as fh:
            rows = walk_rows(fh, names[:width], allow_nan, add)
        if rows == 0:
            problems.add(path, "no data rows below the header", line=1)
    except (OSError, EOFError) as exc:  # truncated or corrupt gzip data
        problems.add(path, f"corrupt compressed data: {exc}")
    except RowError as exc:
        problems.add(path, exc.message, line=exc.line)


def check_increasing(problems: Problems, file: str | Path, name: str, t: np.ndarray,
                     first_line: int | RowLines | None) -> None:
    """Report a time channel that does not strictly increase (first bad sample and count)."""
    bad = np.flatnonzero(np.diff(t) <= 0)
    if bad.size == 0:
        return
    i = int(bad[0]) + 1
    where = {"line": first_line + i} if first_line is not None else {}
    at = "" if first_line is not None else f" at sample {i}"
    problems.add(file, f"time is not increasing{at}: {float(t[i])!r} after "
                       f"{float(t[i - 1])!r} ({bad.size} such sample(s))", key=name, **where)


def check_declared(problems: Problems, file: str | Path, key: str, values: np.ndarray,
                   declared: float | None, what: str, unit: str, *,
                   median: float | None = None) -> None:
    """Report a channel whose median is more than :data:`TOLERANCE` from the declared value
    (``median``: the median of ``values``, when the caller has it)."""
    if declared is None or values.size == 0:
        return
    median = float(np.median(values)) if median is None else median
    if abs(median - declared) > TOLERANCE * abs(declared):
        problems.add(file, f"median {what} {median:.6g} {unit} is more than "
                           f"{TOLERANCE:.0%} from the declared {declared:.6g} {unit}", key=key)


def sha256_file(path: str | Path) -> str:
    """SHA-256 hex digest of a file's bytes."""
    digest = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()
