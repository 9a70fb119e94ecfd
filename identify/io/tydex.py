"""TYDEX (.tdx) measurement files: reader and writer.

Layout (docs/measurement-folder.md): sections ``**HEADER``, ``**COMMENTS``, ``**CONSTANTS``,
``**MEASURCHANNELS``, ``**MEASURDATA``, ``**END``; a line starting with ``!`` is a comment.
Entry lines are fixed width: key (10 characters), description (30), unit (10), then the
value(s). A channel line carries, after its unit, a conversion factor and two offsets
(default 1, 0, 0); this reader applies them as ``value = (raw + offset1) * factor + offset2``
(in the channel's unit).
Data rows are whitespace-separated numbers, one row per line, one column per channel.

The format is detected by its first significant line (``**HEADER``), not by the extension.
The writer prints every number with ``repr`` (shortest round-trip form), so a write/read round
trip returns exactly the same float64 values.
"""
from __future__ import annotations

import io
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from identify.core.atomic import atomic_write_text
from identify.core.serial import Serial, meta
from identify.io.common import BOOLEAN_CELLS, CR_ONLY, Problems, cr_only, file_problem

__all__ = ["TydexEntry", "TydexChannel", "TydexFile", "is_tydex", "read_tydex", "write_tydex"]

_SECTIONS = ("**HEADER", "**COMMENTS", "**CONSTANTS", "**MEASURCHANNELS", "**MEASURDATA",
             "**END")


@dataclass(frozen=True)
class TydexEntry:
    """A ``**HEADER`` or ``**CONSTANTS`` line: key, description, unit, value (text)."""

    key: str
    description: str = ""
    unit: str = ""
    value: str = ""


@dataclass(frozen=True)
class TydexChannel:
    """A ``**MEASURCHANNELS`` line (factor and offsets as read; data already has them applied)."""

    name: str
    description: str = ""
    unit: str = ""
    factor: float = 1.0
    offset1: float = 0.0
    offset2: float = 0.0


@dataclass(frozen=True, eq=False)
class TydexFile(Serial):
    """A TYDEX file: entries, comments, channels and the data [channel units].

    ``data`` has one column per channel (factor and offsets applied); ``data_line`` is the
    line number of the first data row (for messages).
    """

    header: tuple[TydexEntry, ...] = ()
    comments: tuple[str, ...] = ()
    constants: tuple[TydexEntry, ...] = ()
    channels: tuple[TydexChannel, ...] = ()
    data: np.ndarray = field(default_factory=lambda: np.zeros((0, 0)),
                             metadata=meta(skip=True))
    path: str = ""
    data_line: int | None = field(default=None, metadata=meta(skip=True))

    def column(self, name: str) -> np.ndarray:
        """The values of channel ``name``."""
        return self.data[:, [c.name for c in self.channels].index(name)]

    #: ``to_dict`` is a summary: entries, comments and channels, then the number of rows
    serial_derived = {"rows": lambda self: int(self.data.shape[0])}
    serial_order = ("path",)


def is_tydex(path: str | Path) -> bool:
    """True when the first line that is neither blank nor a ``!`` comment is ``**HEADER``."""
    if file_problem(path) is not None:  # a FIFO would block
        return False
    try:
        with open(path, encoding="utf-8-sig", errors="replace") as fh:
            for _, line in zip(range(200), fh, strict=False):
                text = line.strip()
                if text and not text.startswith("!"):
                    return text.upper().startswith("**HEADER")
    except OSError:
        return False
    return False


def _entry(line: str) -> tuple[str, str, str, str]:
    line = line.expandtabs(8).rstrip()
    return line[:10].strip(), line[10:40].strip(), line[40:50].strip(), line[50:].strip()


def read_tydex(path: str | Path, problems: Problems | None = None, *,
               allow_nan: bool = False) -> TydexFile | None:
    """Read a .tdx file.

    Parameters
    ----------
    path : str or Path
        The file.
    problems : Problems, optional
        Collector; by default strict (the first problem raises InputError).
    allow_nan : bool
        Read NaN/inf data values as NaN instead of reporting them (trailer data: the loader
        cleans them and warns).

    Returns
    -------
    TydexFile or None
        None when problems were found (non-strict collector).
    """
    problems = Problems.or_strict(problems)
    path = Path(path)
    start = problems.total
    try:
        why = file_problem(path)
        if why is not None:
            raise OSError(why)
        raw = path.read_bytes()
    except OSError as exc:
        problems.add(path, f"cannot read file: {exc.strerror or exc}")
        return None
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError:
        text = raw.decode("latin-1")
    if cr_only(text):
        problems.add(path, CR_ONLY, line=1)
        return None
    marker = text.find("**MEASURDATA")
    marker = text.upper().find("**MEASURDATA") if marker < 0 else marker
    head = text if marker < 0 else text[:marker]
    lines = head.splitlines()
    sections: dict[str, list] = {s: [] for s in _SECTIONS}
    section = None
    for number, line in enumerate(lines, 1):
        stripped = line.strip()
        if not stripped or stripped.startswith("!"):
            continue
        if stripped.startswith("**"):
            section = stripped.split()[0].upper()
            if section not in _SECTIONS:
                problems.add(path, f"unknown section '{stripped}'", line=number)
            elif section == "**HEADER" and number != _first_significant(lines):
                problems.add(path, "**HEADER must be the first section", line=number)
            continue
        if section is None:
            problems.add(path, "text before the **HEADER line", line=number)
            section = "**HEADER"
        if section in _SECTIONS:
            sections[section].append((number, line))
    if not any(line.strip().upper().startswith("**HEADER") for line in lines):
        problems.add(path, "not a TYDEX file: no **HEADER line")
        return None
    header = tuple(TydexEntry(*_entry(line)) for _, line in sections["**HEADER"])
    constants = tuple(TydexEntry(*_entry(line)) for _, line in sections["**CONSTANTS"])
    comments = tuple(line.rstrip() for _, line in sections["**COMMENTS"])
    channels = []
    for number, line in sections["**MEASURCHANNELS"]:
        channel = _channel(path, number, line, problems)
        if channel is not None:
            channels.append(channel)
    if not sections["**MEASURCHANNELS"]:
        problems.add(path, "no **MEASURCHANNELS section (or it is empty)")
    names = [c.name for c in channels]
    for name in {n for n in names if names.count(n) > 1}:
        problems.add(path, "channel defined twice", key=name)
    if marker < 0:
        problems.add(path, "no **MEASURDATA section")
        return None
    data_line = head.count("\n") + 2
    body = text[marker:].split("\n", 1)[1] if "\n" in text[marker:] else ""
    end = body.rfind("**END")
    end = body.upper().rfind("**END") if end < 0 else end
    if end < 0:
        problems.add(path, "no **END line after the data")
    else:
        body = body[:end]
    if problems.total > start:
        return None
    data = _data(path, body, data_line, len(channels), names, problems, allow_nan)
    if data is None:
        return None
    factor = np.array([c.factor for c in channels])
    if (factor != 1).any() or any(c.offset1 or c.offset2 for c in channels):
        raw = data
        with np.errstate(over="ignore", invalid="ignore"):
            data = (data + np.array([c.offset1 for c in channels])) * factor + np.array(
                [c.offset2 for c in channels])
        lost = np.isfinite(raw) & ~np.isfinite(data)  # checked after the factor, not before
        if lost.any():
            row, col = (int(v[0]) for v in np.nonzero(lost))
            problems.add(path, f"{raw[row, col]!r} times factor {channels[col].factor!r} "
                               f"(and offsets) is not finite ({int(lost.sum())} value(s))",
                         line=data_line + row, key=channels[col].name)
            return None
    return TydexFile(header, comments, constants, tuple(channels), data, str(path), data_line)


def _first_significant(lines: list[str]) -> int:
    for number, line in enumerate(lines, 1):
        text = line.strip()
        if text and not text.startswith("!"):
            return number
    return 0


def _channel(path: Path, number: int, line: str, problems: Problems) -> TydexChannel | None:
    name, description, unit, rest = _entry(line)
    if not name or " " in name:
        problems.add(path, "malformed channel line: expected name (10 characters), description "
                           "(30), unit (10), factor, offsets", line=number)
        return None
    try:
        numbers = [float(x) for x in rest.split()]
    except ValueError:
        problems.add(path, f"factor/offsets are not numbers: '{rest}'", line=number, key=name)
        return None
    if len(numbers) > 3 or not np.isfinite(numbers).all() or (numbers and numbers[0] == 0):
        problems.add(path, f"expected a non-zero factor and up to two offsets, got '{rest}'",
                     line=number, key=name)
        return None
    numbers += [1.0, 0.0, 0.0][len(numbers):]
    return TydexChannel(name, description, unit, *numbers)


def _data(path: Path, body: str, first_line: int, width: int, names: list[str],
          problems: Problems, allow_nan: bool = False) -> np.ndarray | None:
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("error", pd.errors.ParserWarning)
            frame = pd.read_csv(io.StringIO(body), sep=r"\s+", header=None, dtype=np.float64,
                                index_col=False, names=list(range(width)), comment="!",
                                na_values=BOOLEAN_CELLS)
        values = frame.to_numpy()
        if np.isfinite(values).all():
            if len(values) == 0:
                problems.add(path, "no data rows in **MEASURDATA", line=first_line - 1)
                return None
            return values
    except (ValueError, pd.errors.ParserError, pd.errors.ParserWarning):
        values = None
    start = problems.total
    if values is not None and allow_nan:  # NaN cells, or short rows filled with NaN: walk
        _walk(path, body, first_line, width, names, problems, allow_nan)
        return np.where(np.isfinite(values), values, np.nan) if problems.total == start else None
    _walk(path, body, first_line, width, names, problems, allow_nan)
    if problems.total == start:
        problems.add(path, "cannot parse the **MEASURDATA section", line=first_line)
    return None


def _walk(path: Path, body: str, first_line: int, width: int, names: list[str],
          problems: Problems, allow_nan: bool) -> None:
    """Report ragged rows and bad cells of the data section, line by line."""
    for number, line in enumerate(body.split("\n"), first_line):
        cells = line.split()
        if not cells or cells[0].startswith("!"):
            continue
        if len(cells) != width:
            problems.add(path, f"ragged row: {len(cells)} values, {width} channels", line=number,
                         kind="ragged-row")
        for name, cell in zip(names, cells, strict=False):
            try:
                bad = not (allow_nan or np.isfinite(float(cell)))
                why = f"{cell} is not allowed (NaN/inf)"
            except ValueError:
                bad, why = True, f"not a number: '{cell}'"
            if bad:
                problems.add(path, why, line=number, key=name, kind="bad-cell")


def _line(key: str, description: str, unit: str, value: str) -> str:
    return f"{key:<10}{description[:29]:<30}{unit[:9]:<10}{value}".rstrip()


def write_tydex(path: str | Path, tdx: TydexFile) -> Path:
    """Write ``tdx`` atomically; channels get factor 1 and offsets 0 (``data`` is physical).

    Numbers are written with ``repr`` so that reading the file back is exact.
    """
    out = ["**HEADER"]
    out += [_line(e.key, e.description, e.unit, e.value) for e in tdx.header]
    out.append("**COMMENTS")
    out += [c for c in tdx.comments if c.strip() and not c.lstrip().startswith(("**", "!"))]
    out.append("**CONSTANTS")
    out += [_line(e.key, e.description, e.unit, e.value) for e in tdx.constants]
    out.append("**MEASURCHANNELS")
    out += [_line(c.name, c.description, c.unit, "1 0 0") for c in tdx.channels]
    out.append("**MEASURDATA")
    rows = np.asarray(tdx.data, dtype=float).tolist()
    out += [" ".join(map(repr, row)) for row in rows]
    out.append("**END")
    return atomic_write_text(path, "\n".join(out) + "\n")
