"""The Tire Test Consortium's ``.dat`` text files, as real sessions write them.

Line 1 a title, line 2 the channel names, line 3 their units, data from line 4, tab-separated
(comma-separated when line 2 holds no tab; a decimal comma is read too). The title may be
Windows-1252 text; CRLF or CR line ends, a byte-order mark, a trailing separator, blank last
lines and gzip (told by its magic bytes, whatever the name) are read. A file cut inside its
last row (copied while the logger wrote it) drops that row: the ``cut_row`` attributes say
which, and the trailer loader warns. Every other problem is one line naming the file and line.
"""
from __future__ import annotations

import contextlib
import io
import itertools
import re
import warnings
from pathlib import Path

import numpy as np
import pandas as pd

from identify.io.common import BOOLEAN_CELLS, Problems, is_gzip, open_text
from identify.io.ttc.channel_names import ttc_name

__all__ = ["read_dat"]


def _header_lines(path: Path) -> list[str]:
    """The three header lines of a .dat file as text: UTF-8, else Windows-1252 (a title
    written on Windows: ``18\xb0``); raises UnicodeDecodeError for bytes that are not text."""
    with open_text(path, encoding="latin-1", newline="") as fh:  # latin-1: the bytes
        raw = [fh.readline().encode("latin-1") for _ in range(3)]
    raw[0] = raw[0].removeprefix(b"\xef\xbb\xbf")
    out = []
    for line in raw:
        if b"\0" in line:
            raise UnicodeDecodeError("utf-8", line, 0, 1, "a NUL byte")
        try:
            out.append(line.decode("utf-8"))
        except UnicodeDecodeError:
            out.append(line.decode("cp1252", errors="replace"))
    return out


def read_dat(path: Path, problems: Problems):
    """(channels, units, attrs) of a TTC ``.dat`` file as stored, or None after a problem."""
    try:
        head = _header_lines(path)
    except UnicodeDecodeError:
        problems.add(path, "not a text file (a .dat file is tab-separated text)", line=1)
        return None
    except (OSError, EOFError) as exc:
        problems.add(path, f"cannot read file: {getattr(exc, 'strerror', None) or exc}")
        return None
    lines = [h.rstrip("\r\n") for h in head if h]
    # tab-separated; a file saved from a spreadsheet may be comma-separated
    sep = "," if len(lines) > 1 and "\t" not in lines[1] and "," in lines[1] else "\t"
    names = lines[1].split(sep) if len(lines) > 1 else []
    unit_cells = lines[2].split(sep) if len(lines) > 2 else []
    if len(lines) < 3 or _numeric(unit_cells) or len(names) < 2:
        found = (f"line {len(lines)} holds numbers" if lines and _numeric(
            lines[-1].split(sep)) else f"{len(lines)} line(s)")
        if len(lines) > 1 and len(names) < 2:
            found = "line 2 holds no tab- or comma-separated names"
        problems.add(path, "short header: a TTC .dat file has a title line, a line of channel "
                           f"names and a line of units before the data (found {found})",
                     line=min(len(lines) + 1, 3))
        return None
    names = [ttc_name(n) for n in names]
    unit_cells = [u.strip() for u in unit_cells]
    while len(names) > 1 and not names[-1] and len(unit_cells) == len(names) \
            and not unit_cells[-1]:  # a trailing separator on the header lines
        names, unit_cells = names[:-1], unit_cells[:-1]
    if len(unit_cells) != len(names):
        problems.add(path, f"{len(unit_cells)} units for {len(names)} channel names", line=3)
        return None
    twice = sorted({n for n in names if names.count(n) > 1})
    for dup in twice:
        problems.add(path, "channel named twice", line=2, key=dup)
    if twice:  # which column is the channel is unknown; pandas refuses the names anyway
        return None
    attrs = {"format": "ttc-dat", "title": lines[0].strip()}
    try:
        frame = _numbers(path, sep, names)
    except (OSError, EOFError) as exc:  # gzip data cut short or corrupt below the header
        problems.add(path, f"cannot read file: {getattr(exc, 'strerror', None) or exc}")
        return None
    except (ValueError, pd.errors.ParserError) as exc:
        found = _without_cut_row(path, sep, names)  # cut inside a number: "-" of "-1000"
        if found is None:
            problems.add(path, f"data below the header are not {_SEP_NAME[sep]}-separated "
                               f"numbers ({exc})", line=4)
            return None
        frame, line, fields = found
        attrs["cut_row"] = str(line)
        attrs["cut_row_detail"] = (f"the last row stops after {fields} of {len(names)} "
                                   "fields (the file ends inside it)")
    if len(frame) == 0:
        problems.add(path, "no data rows below the header", line=3)
        return None
    # pandas fills a short row with NaN, which leaves its last column NaN, and cuts a first
    # row wider than the names to their width (only a trailing separator may go; a wider
    # row further down is a ParserError above): then the reader counts the fields per row
    if frame.attrs["wider"] or frame[names[-1]].isna().any():
        cut = _ragged(path, len(names), sep, problems)
        if cut is None:
            return None
        if cut and "cut_row" not in attrs:  # the last row cut short (a file copied while
            # written): dropped, warned; unless it was dropped above
            line, fields = cut.split()
            frame = frame.iloc[:-1]
            attrs["cut_row"] = line
            attrs["cut_row_detail"] = (f"the last row stops after {fields} of {len(names)} "
                                       "fields (the file ends inside it)")
    data = {n: frame[n].to_numpy(np.float64) for n in names}
    return data, dict(zip(names, unit_cells)), attrs


def _numbers(source: Path | str, sep: str, names: list[str]) -> pd.DataFrame:
    """The data rows of a file (or of its text) with a decimal point, else (tab-separated) a
    decimal comma (a European locale's export); raises the decimal point's error."""
    try:
        return _table(source, sep, names, ".")
    except (ValueError, pd.errors.ParserError) as exc:
        if sep == "\t":
            with contextlib.suppress(ValueError, pd.errors.ParserError):
                return _table(source, sep, names, ",")
        raise exc


def _without_cut_row(path: Path, sep: str, names: list[str]
                     ) -> tuple[pd.DataFrame, int, int] | None:
    """(data rows, line, fields of the cut row) of a file that ends inside a number of its last
    row (no newline at its end), read without that row; None when the file ends with a
    newline or the rows above are not numbers either."""
    with open_text(path, encoding="latin-1") as fh:  # CR, CRLF, LF: all read as LF
        head, newline, last = fh.read().rpartition("\n")
    lines = head.count("\n") + 2  # the last row's line
    cells = last.split(sep)
    if not last.strip() or lines < 4 or len(cells) > len(names) or not (
            _numeric([c.replace(",", ".") for c in cells[:-1]] + ["0"])
            and _NUMBER_START.fullmatch(cells[-1])):
        return None  # not cut, cut in the header, or not a row a cut leaves (bad data)
    try:
        frame = _numbers(head + newline, sep, names)
    except (ValueError, pd.errors.ParserError):
        return None
    return frame, lines, _fields(last, sep)


def _table(source: Path | str, sep: str, names: list[str], decimal: str) -> pd.DataFrame:
    gz = isinstance(source, Path) and is_gzip(source)  # as open_text tells it (the header)
    text = io.StringIO(source) if isinstance(source, str) else source  # a new one each read
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        frame = pd.read_csv(text, sep=sep, decimal=decimal, skiprows=3, header=None,
                            names=names, dtype=np.float64, index_col=False, engine="c",
                            na_values=BOOLEAN_CELLS,
                            encoding="latin-1", compression="gzip" if gz else None)
    # index_col=False: the fields of a first row wider than the names are dropped, with a
    # ParserWarning ("Length of header or names does not match length of data")
    wider = [w for w in caught if issubclass(w.category, pd.errors.ParserWarning)]
    for w in caught:
        if w not in wider:
            warnings.warn_explicit(w.message, w.category, w.filename, w.lineno)
    frame.attrs["wider"] = bool(wider)
    return frame


_SEP_NAME = {"\t": "tab", ",": "comma"}
#: The start of a number where a cut may end a file: "-", "12.", "1e-" (decimal comma too).
_NUMBER_START = re.compile(r"\s*[+-]?\d*(?:[.,]\d*)?(?:[eE][+-]?\d*)?")


def _ragged(path: Path, width: int, sep: str, problems: Problems) -> str | None:
    """Report the rows whose number of fields is not ``width``: None if there is one; "" if
    there is none; ``"<line> <fields>"`` when the only one is the last row, with fewer fields
    (a file cut short: that row is dropped with a warning)."""
    # line by line, not held; CR, CRLF and LF all end a line, as for pandas' reader
    with open_text(path, encoding="latin-1") as fh:
        counts = np.fromiter((_fields(line.removesuffix("\n"), sep) if line.strip() else 0
                              for line in itertools.islice(fh, 3, None)), dtype=int)
    filled = np.flatnonzero(counts)  # a blank line (0 fields) is not a row
    counts[counts == 0] = width
    bad = np.flatnonzero(counts != width)
    if bad.size == 1 and filled.size and bad[0] == filled[-1] and counts[bad[0]] < width:
        return f"{int(bad[0]) + 4} {int(counts[bad[0]])}"
    for i in bad[:10]:
        problems.add(path, f"ragged row: {counts[i]} fields, the header has {width}",
                     line=int(i) + 4, kind="ragged-row")
    for _ in bad[10:]:
        problems.add(path, "ragged row", kind="ragged-row")
    return None if bad.size else ""


def _fields(line: str, sep: str) -> int:
    """The fields of a data line (its end read as LF, see open_text's callers), a trailing
    separator not counted (pandas drops it)."""
    return line.removesuffix(sep).count(sep) + 1


def _numeric(cells) -> bool:
    try:
        [float(c) for c in cells if c.strip()]
    except ValueError:
        return False
    return any(c.strip() for c in cells)
