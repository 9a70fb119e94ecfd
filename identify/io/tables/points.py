"""Operating-point tables for ``mfid eval`` (CSV: Fz, kappa, alpha, gamma, Vx, p [, phit, omega]).

Every problem is reported as one line naming the file, the line and the column.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from identify.core.errors import InputError
from identify.core.plausible import first_error
from identify.io.common import decode_problem, file_problem, row_lines

REQUIRED = ("Fz", "kappa", "alpha", "gamma", "Vx", "p")
#: Column -> quantity of identify.core.plausible (p = 0 means the .tir's INFLPRES; a
#: negative Fz is clipped by the model, so only the upper load bound applies).
_PLAUSIBLE = (("p", "pressure"), ("Vx", "speed"), ("alpha", "angle"), ("gamma", "angle"))
OPTIONAL = ("phit", "omega")


def read_points(path: str | Path) -> pd.DataFrame:
    """Read operating points [SI units, radians] from a CSV file with a header line.

    Returns
    -------
    DataFrame
        The file's columns, the model inputs as float64; other columns are kept as they are.

    Raises
    ------
    InputError
        Unreadable file, empty file, missing column, a cell that is not a number, NaN or inf.
        Line numbers count the header as line 1.
    """
    path = Path(path)
    why = file_problem(path, "CSV file")
    if why:  # a FIFO would block the reader forever, /dev/zero never ends
        raise InputError(path, f"cannot read file: {why}")
    try:
        frame = pd.read_csv(path, dtype=str, keep_default_na=False, skipinitialspace=True)
    except FileNotFoundError:
        raise InputError(path, "cannot read file: no such file") from None
    except IsADirectoryError:
        raise InputError(path, "cannot read file: is a directory") from None
    except pd.errors.EmptyDataError:
        raise InputError(path, "empty file: expected a header line "
                               f"with columns {', '.join(REQUIRED)}") from None
    except UnicodeDecodeError:
        raw = path.read_bytes()  # pandas' offset is within a chunk: find the byte again
        try:
            raw.decode("utf-8-sig")
        except UnicodeDecodeError as exc:
            line, message = decode_problem(raw, exc)
            raise InputError(path, message, line=line) from None
        raise InputError(path, "not UTF-8 text") from None
    except (pd.errors.ParserError, OSError, ValueError, OverflowError, MemoryError) as exc:
        raise InputError(path, f"cannot read file: {str(exc).strip().splitlines()[0]}"
                         if str(exc).strip() else "cannot read file") from None
    frame.columns = [str(c).strip() for c in frame.columns]
    seen: set[str] = set()
    with path.open(encoding="utf-8-sig", errors="replace") as fh:  # pandas renames "p" "p.1"
        header = [c.strip() for c in fh.readline().split(",")]
    for name in header:
        if name in seen:
            raise InputError(path, "duplicate column", line=1, key=name)
        seen.add(name)
    missing = [c for c in REQUIRED if c not in frame.columns]
    if missing:
        raise InputError(path, f"missing column(s) {', '.join(missing)} "
                               f"(found: {', '.join(frame.columns)})", line=1)
    if frame.empty:
        raise InputError(path, "no operating points below the header", line=1)
    out = frame.copy()
    for col in REQUIRED + tuple(c for c in OPTIONAL if c in frame.columns):
        text = frame[col].str.strip()
        values = pd.to_numeric(text, errors="coerce").to_numpy(float)
        bad = np.flatnonzero(~np.isfinite(values))
        if bad.size:
            row = int(bad[0])
            cell = text.iloc[row]
            what = "empty cell" if cell == "" else (
                f"{cell} is not allowed" if cell.lower().lstrip("+-") in
                ("nan", "inf", "infinity") else f"not a number: '{cell}'")
            raise InputError(path, what, line=row_lines(path, len(frame)) + row, key=col)
        out[col] = values
    for col, quantity in _PLAUSIBLE:  # after the numbers are read: the error bands in SI
        found = first_error(quantity, out[col].to_numpy(), what=col,
                            allow_zero=(col == "p"))
        if found is not None:
            raise InputError(path, found[1].message,
                             line=row_lines(path, len(frame)) + found[0], key=col)
    return out
