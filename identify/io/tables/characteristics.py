"""Characteristic tables (CSV) -> tidy SI tables.

Schema (docs/measurement-folder.md): ``quantity, pi_bar, Fz_N, value, unit`` and optional
``Vx_mps, gamma_deg, mode``; one row per quantity, pressure and load (and speed, camber or
mode). Values are converted to the SI unit of their quantity; ``pi_bar`` is kept and ``p_Pa``
added. The files are small, so every row is checked and each bad cell is reported with its line.
"""
from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import pandas as pd

from identify.core.plausible import judge
from identify.core.quantities import CHARACTERISTICS_COLUMNS, MODES, QUANTITIES
from identify.core.units import SI_UNITS, to_si, unit_problem
from identify.io.common import Problems, read_utf8
from identify.io.data_warning import DataWarning

__all__ = ["QUANTITIES", "MODES", "CHARACTERISTICS_COLUMNS", "read_characteristics"]

_REQUIRED = ("quantity", "pi_bar", "Fz_N", "value", "unit")
_OPTIONAL = ("Vx_mps", "gamma_deg", "mode")


def _number(problems: Problems, path: Path, line: int, key: str, text: str, *,
            optional: bool = False, check: str | None = None) -> float | None:
    text = text.strip()
    if text == "" and optional:
        return math.nan
    try:
        value = float(text)
    except ValueError:
        problems.add(path, "empty cell" if text == "" else f"not a number: '{text}'",
                     line=line, key=key, kind="bad-cell")
        return None
    if not math.isfinite(value):
        problems.add(path, f"{text} is not allowed (NaN/inf)", line=line, key=key,
                     kind="bad-cell")
        return None
    if (check == "pos" and value <= 0) or (check == "nonneg" and value < 0):
        problems.add(path, f"must be {'positive' if check == 'pos' else '>= 0'}, got {text}",
                     line=line, key=key, kind="bad-cell")
        return None
    return value


def read_characteristics(path: str | Path, *, run: str | None = None,
                         problems: Problems | None = None,
                         warnings: list | None = None) -> pd.DataFrame | None:
    """Read a characteristic table into :data:`CHARACTERISTICS_COLUMNS` (SI values).

    Parameters
    ----------
    path : str or Path
        CSV with a header line (line 1).
    run : str, optional
        Run id written into the ``run`` column (default: the file stem).
    problems : Problems, optional
        Collector; strict by default.
    warnings : list, optional
        Receives a DataWarning (kind ``"plausible"``) per value in a warning band
        (:mod:`identify.core.plausible`, checked in SI).

    Returns
    -------
    pandas.DataFrame or None
        None when problems were found (non-strict collector).
    """
    problems = Problems.or_strict(problems)
    path = Path(path)
    start = problems.total
    text = read_utf8(path, problems)
    if text is None:
        return None
    try:
        reader = csv.reader(io.StringIO(text, newline=""))
        rows, lines, previous = [], [], 0
        for row in reader:
            rows.append(row)
            lines.append(previous + 1)  # a quoted cell may span lines: where the row starts
            previous = reader.line_num
    except csv.Error as exc:  # a field over the csv module's limit, a NUL byte
        problems.add(path, f"cannot parse CSV: {str(exc).splitlines()[0]}",
                     line=reader.line_num or None)
        return None
    if not rows or not any(c.strip() for c in rows[0]):
        problems.add(path, "empty file: expected a header line "
                           f"({', '.join(_REQUIRED)})", line=1)
        return None
    header = [c.strip() for c in rows[0]]
    for name in header:
        if name not in _REQUIRED + _OPTIONAL:
            problems.add(path, f"unknown column (expected: {', '.join(_REQUIRED + _OPTIONAL)})",
                         line=1, key=name)
    for name in _REQUIRED:
        if name not in header:
            problems.add(path, "missing required column", line=1, key=name)
    if problems.total > start:
        return None
    records = []
    for line, row in zip(lines[1:], rows[1:], strict=True):
        if not any(c.strip() for c in row):
            continue
        if len(row) != len(header):
            problems.add(path, f"ragged row: {len(row)} fields, the header has {len(header)}",
                         line=line, kind="ragged-row")
            continue
        record = _row(problems, path, line, dict(zip(header, row, strict=False)), warnings)
        if record is not None:
            records.append(record)
    if not records and problems.total == start:
        problems.add(path, "no data rows below the header", line=1)
    if problems.total > start:
        return None
    out = pd.DataFrame.from_records(records, columns=CHARACTERISTICS_COLUMNS[1:])
    out.insert(0, "run", run or path.stem)
    return out


def _row(problems: Problems, path: Path, line: int, cells: dict[str, str],
         warnings: list | None = None) -> dict | None:
    start = problems.total
    quantity = cells["quantity"].strip()
    dim = QUANTITIES.get(quantity)
    if dim is None:
        problems.add(path, f"unknown quantity '{quantity}' (expected one of: "
                           f"{', '.join(QUANTITIES)})", line=line, key="quantity")
    pi_bar = _number(problems, path, line, "pi_bar", cells["pi_bar"], check="pos")
    fz = _number(problems, path, line, "Fz_N", cells["Fz_N"], check="nonneg")
    value = _number(problems, path, line, "value", cells["value"])
    vx = _number(problems, path, line, "Vx_mps", cells.get("Vx_mps", ""), optional=True)
    gamma = _number(problems, path, line, "gamma_deg", cells.get("gamma_deg", ""), optional=True)
    mode = cells.get("mode", "").strip()
    if mode and mode not in MODES:
        problems.add(path, f"unknown mode '{mode}' (expected one of: {', '.join(MODES)})",
                     line=line, key="mode")
    unit = cells["unit"].strip()
    why = unit_problem(unit, dim) if dim else None
    if why:
        problems.add(path, f"{why} for {quantity}", line=line, key="unit")
    if problems.total > start:
        return None
    si = to_si(value, unit, dimension=dim)
    # plausibility in SI, after the unit conversion: 1e308 N/mm is inf in N/m
    for key, band, x in (("pi_bar", "pressure", pi_bar * 1e5), ("Fz_N", "load", fz),
                         ("value", "magnitude", si), ("Vx_mps", "speed", vx),
                         ("gamma_deg", "angle", math.radians(gamma))):
        if key in ("Vx_mps", "gamma_deg") and math.isnan(x):
            continue  # an optional cell left empty
        found = judge(band, x, what=f"{quantity} [{SI_UNITS[dim]}]" if key == "value"
                      else f"{key} in SI")
        if found is None:
            continue
        if found.is_error:
            problems.add(path, found.message, line=line, key=key)
        elif warnings is not None:
            warnings.append(DataWarning(str(path), path.stem, "plausible", (key,), 1, 1,
                                        found.message, "kept", line))
    if problems.total > start:
        return None
    return {"quantity": quantity, "pi_bar": pi_bar, "p_Pa": pi_bar * 1e5, "Fz_N": fz,
            "value": si, "unit": SI_UNITS[dim],
            "Vx_mps": vx, "gamma_deg": gamma, "mode": mode}
