"""A measurement folder (``tyre.toml`` + data files) -> one :class:`MeasurementSet`.

:func:`check_folder` lists every problem of a folder (``mfid check``); :func:`load_folder`
raises :class:`~identify.core.errors.InputError` on the first. Both only read: no command ever
writes into a measurement folder. A single characteristics CSV also counts as a folder (no
manifest; the nominal pressure and load come from the options or from the table).
"""
from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np
import pandas as pd

from identify.core.names import inside, safe_name
from identify.core.plausible import judge
from identify.core.serial import Serial, meta
from identify.io.common import (
    Problem,
    Problems,
    file_problem,
    open_text,
    sha256_file,
    split_header_name,
)
from identify.io.flatplank import FLATPLANK_COLUMNS, read_flatplank
from identify.io.hdf5.channel_files import is_hdf5
from identify.io.manifest import MANIFEST_NAME, Manifest, RunSpec, TyreInfo, read_manifest
from identify.io.tables.characteristics import CHARACTERISTICS_COLUMNS, read_characteristics
from identify.io.trailer.files import CHANNELS, TRAILER_COLUMNS, channels_to_tidy, read_channels
from identify.io.trailer.quirks import DataWarning
from identify.io.ttc.files import is_ttc_dat, is_ttc_mat, is_ttc_naming
from identify.io.tydex import is_tydex

__all__ = ["MeasurementSet", "FolderScan", "load_folder", "check_folder", "scan_folder",
           "inspect_folder", "IMPLICIT_TABLE"]

#: A characteristic table at the folder's root that is loaded even when no run names it.
IMPLICIT_TABLE = "characteristics.csv"


@dataclass(frozen=True, eq=False)
class MeasurementSet(Serial):
    """Everything a measurement folder holds, in SI units and ISO-W axes.

    Attributes
    ----------
    path : str
        The folder (or the single CSV file) as given.
    manifest : Manifest
        The parsed ``tyre.toml`` (synthesised for a single CSV).
    trailer, flatplank, characteristics : pandas.DataFrame
        Tidy tables of all runs of each kind (empty with the right columns when none).
    checksums : mapping
        SHA-256 of every input file read, by path relative to the folder.
    warnings : tuple of DataWarning
        The quirks found in the trailer data and cleaned while loading (each with its count);
        a channel dropped as implausible is NaN in :attr:`trailer` and named by a warning of
        kind ``"implausible"``.
    """

    path: str
    manifest: Manifest
    trailer: pd.DataFrame = field(metadata=meta(skip=True))
    flatplank: pd.DataFrame = field(metadata=meta(skip=True))
    characteristics: pd.DataFrame = field(metadata=meta(skip=True))
    checksums: Mapping[str, str] = field(default_factory=dict)
    warnings: tuple[DataWarning, ...] = ()

    def __post_init__(self) -> None:
        object.__setattr__(self, "checksums", MappingProxyType(dict(self.checksums)))
        object.__setattr__(self, "warnings", tuple(self.warnings))

    def __repr__(self) -> str:
        return f"<MeasurementSet {self.summary()}; {len(self.warnings)} warning(s)>"

    def dropped_channels(self) -> dict[str, dict[str, str]]:
        """Run -> {channel: why} for the channels dropped as implausible while loading."""
        out: dict[str, dict[str, str]] = {}
        for w in self.warnings:
            if w.kind == "implausible":
                for channel in w.channels:
                    out.setdefault(w.run, {})[channel] = w.detail
        return out

    def summary(self) -> str:
        """One line: tyre id, runs per kind and samples."""
        kinds = {}
        for run in self.manifest.runs:
            kinds[run.kind] = kinds.get(run.kind, 0) + 1
        parts = ", ".join(f"{n} {k}" for k, n in kinds.items())
        return (f"{self.manifest.tyre.id}: {len(self.manifest.runs)} runs ({parts}); "
                f"{len(self.trailer)} trailer samples, {len(self.flatplank)} flatplank samples, "
                f"{len(self.characteristics)} characteristic values")

    #: ``to_dict`` is a summary: the fields but the tables, then their row counts
    serial_derived = {"rows": lambda self: {"trailer": len(self.trailer),
                                            "flatplank": len(self.flatplank),
                                            "characteristics": len(self.characteristics)}}
    serial_order = ("path", "manifest", "rows")


@dataclass(frozen=True, eq=False)
class FolderScan:
    """What one pass over a folder found: the set (None if anything is wrong), the problems
    (errors: the data cannot be used) and the warnings (usable data, cleaned, with counts)."""

    found: MeasurementSet | None
    problems: tuple[Problem, ...]
    warnings: tuple[DataWarning, ...]


def load_folder(path: str | Path, *, nominal_pressure_Pa: float | None = None,
                nominal_load_N: float | None = None) -> MeasurementSet:
    """Load a measurement folder (or a single characteristics CSV).

    Parameters
    ----------
    path : str or Path
        The folder (with ``tyre.toml``), its ``tyre.toml``, or a characteristics CSV.
    nominal_pressure_Pa, nominal_load_N : float, optional
        Nominal pressure [Pa] and load [N] for a single CSV (default: the median of the
        table's distinct pressures and loads). Ignored for a folder with a manifest.

    Raises
    ------
    InputError
        On the first problem found.
    """
    return _scan(Path(path), Problems(strict=True), nominal_pressure_Pa, nominal_load_N, [])


def check_folder(path: str | Path, *, nominal_pressure_Pa: float | None = None,
                 nominal_load_N: float | None = None) -> list[Problem]:
    """Every problem of a measurement folder, one :class:`Problem` each (empty when clean)."""
    return scan_folder(path, nominal_pressure_Pa=nominal_pressure_Pa,
                       nominal_load_N=nominal_load_N)[1]


def scan_folder(path: str | Path, *, nominal_pressure_Pa: float | None = None,
                nominal_load_N: float | None = None
                ) -> tuple[MeasurementSet | None, list[Problem]]:
    """Check and load in one pass: the set (None if anything is wrong) and every problem."""
    scan = inspect_folder(path, nominal_pressure_Pa=nominal_pressure_Pa,
                          nominal_load_N=nominal_load_N)
    return scan.found, list(scan.problems)


def inspect_folder(path: str | Path, *, nominal_pressure_Pa: float | None = None,
                   nominal_load_N: float | None = None) -> FolderScan:
    """Check and load in one pass: the set, every problem and every warning."""
    problems, warnings = Problems(), []
    found = _scan(Path(path), problems, nominal_pressure_Pa, nominal_load_N, warnings)
    listed = problems.finish()
    return FolderScan(None if listed else found, tuple(listed), tuple(warnings))


def _trailer_file(path: Path) -> bool:
    """True when a single file is trailer data (not a characteristic table)."""
    if is_ttc_mat(path) or is_hdf5(path) or is_tydex(path) or path.suffix.lower() == ".dat":
        return True
    if is_ttc_dat(path):
        return True
    try:
        with open_text(path, encoding="utf-8-sig", errors="replace") as fh:
            first = fh.readline()
    except (OSError, EOFError):
        return False
    names = {split_header_name(cell)[0] for cell in first.split(",")}
    return is_ttc_naming(names) or len(names & set(CHANNELS)) >= 5


def _scan(path: Path, problems: Problems, pressure: float | None,
          load: float | None, warnings: list) -> MeasurementSet | None:
    start = problems.total
    if path.is_dir() or path.name == MANIFEST_NAME:
        toml = path / MANIFEST_NAME if path.is_dir() else path
        why = file_problem(toml)
        if why and why != "no such file or directory":
            problems.add(toml, why)
            return None
        manifest = read_manifest(toml, problems, partial=True, warnings=warnings)
        if manifest is None:
            return None
        folder = toml.parent
        checksums = {MANIFEST_NAME: sha256_file(toml)}
    elif path.is_file() and _trailer_file(path):
        problems.add(path, f"a single trailer data file, not a measurement folder: import it "
                           f"first with `mfid import {path} --out FOLDER`, then fit FOLDER")
        return None
    elif path.is_file():
        manifest, folder, checksums = None, path.parent, {}
    else:
        problems.add(path, file_problem(path, "folder or CSV file") or "no such file or directory")
        return None
    runs = list(manifest.runs) if manifest else [RunSpec(path.stem, path.name, "characteristics")]
    notes = []
    implicit = folder / IMPLICIT_TABLE
    if manifest and file_problem(implicit) is None and not any(
            inside(folder, r.file)[0] == inside(folder, IMPLICIT_TABLE)[0] for r in runs):
        run_id = "characteristics" if all(r.id != "characteristics" for r in runs) \
            else IMPLICIT_TABLE
        runs.append(RunSpec(run_id, IMPLICIT_TABLE, "characteristics"))
        notes.append(f"{IMPLICIT_TABLE} is not listed in {MANIFEST_NAME}; loaded as run "
                     f"'{run_id}'")
    tables: dict[str, list[pd.DataFrame]] = {"trailer": [], "flatplank": [],
                                             "characteristics": []}
    where = manifest.path if manifest else str(path)
    for i, run in enumerate(runs):
        file, why = inside(folder, run.file)
        if file is None:
            problems.add(where, why, key=f"runs[{i}].file")
            continue
        file = folder / run.file  # inside the folder: named as the manifest names it
        why = file_problem(file)
        if why:
            problems.add(where, f"file not found: {file}" if why.startswith("no such")
                         else f"{why}: {file}", key=f"runs[{i}].file")
            continue
        checksums[Path(run.file).as_posix()] = sha256_file(file)
        tables[run.kind] += _load_run(run, file, manifest, problems, where, i, warnings)
    if problems.total > start:
        return None
    frames = {kind: _concat(tables[kind], columns) for kind, columns in (
        ("trailer", TRAILER_COLUMNS), ("flatplank", FLATPLANK_COLUMNS),
        ("characteristics", CHARACTERISTICS_COLUMNS))}
    if manifest is None:
        manifest, more = _single_csv_manifest(path, frames["characteristics"], pressure, load)
        notes += more
        for key, quantity, value, option in (
                ("nominal pressure", "pressure", manifest.tyre.nominal_pressure_Pa,
                 "--nominal-pressure"),
                ("nominal load", "load", manifest.tyre.nominal_load_N, "--nominal-load")):
            found = judge(quantity, value, what=key)
            if math.isnan(value):
                problems.add(path, f"no {key} given and none in the table (every "
                                   f"{quantity} is 0 or missing): give {option}")
            elif quantity == "load" and value <= 0:
                problems.add(path, f"{key} must be > 0 N, got {value:.6g}", key=option)
            elif found is not None and found.is_error:
                problems.add(path, found.message, key=option)
            elif found is not None:
                warnings.append(DataWarning(str(path), "", "plausible", (option,), 1, 1,
                                            found.message, "kept"))
        if problems.total > start:
            return None
    manifest = Manifest(manifest.path, manifest.tyre, manifest.rig, tuple(runs), manifest.extra,
                        manifest.notes + tuple(notes))
    return MeasurementSet(str(path), manifest, frames["trailer"], frames["flatplank"],
                          frames["characteristics"], checksums, tuple(warnings))


def _load_run(run: RunSpec, file: Path, manifest: Manifest | None, problems: Problems,
              where: str, i: int, warnings: list) -> list[pd.DataFrame]:
    conditions = dict(run.conditions)
    if run.kind == "trailer":
        channels = read_channels(file, run=run.id, units=run.units, problems=problems) or []
        frames = [channels_to_tidy(ch, axes=run.axes, conditions=conditions, problems=problems,
                                   warnings=warnings) for ch in channels]
    elif run.kind == "flatplank":
        if manifest is None or manifest.rig is None:
            return []  # the manifest check has reported the missing [rig]
        frames = [read_flatplank(file, a=manifest.rig.hub_a_m, b=manifest.rig.hub_b_m,
                                 run=run.id, test=run.test, units=run.units,
                                 conditions=conditions, problems=problems)]
    else:
        if run.units:
            problems.add(where, "units do not apply to a characteristic table (each row names "
                                "its unit)", key=f"runs[{i}].units")
        frames = [read_characteristics(file, run=run.id, problems=problems,
                                       warnings=warnings)]
    return [f for f in frames if f is not None]


def _concat(frames: list[pd.DataFrame], columns: tuple[str, ...]) -> pd.DataFrame:
    if not frames:
        return pd.DataFrame({c: pd.Series(dtype=object if c in ("run", "test", "quantity",
                                                                "unit", "mode") else float)
                             for c in columns})
    return pd.concat(frames, ignore_index=True)


def _single_csv_manifest(path: Path, table: pd.DataFrame, pressure: float | None,
                         load: float | None) -> tuple[Manifest, list[str]]:
    notes = []
    if pressure is None:
        pressure = float(np.median(np.unique(table["p_Pa"]))) if len(table) else math.nan
        notes.append(f"nominal pressure not given: took {pressure:.6g} Pa, the median of the "
                     "table's pressures")
    if load is None:
        loads = np.unique(table["Fz_N"][table["Fz_N"] > 0])
        load = float(np.median(loads)) if loads.size else math.nan
        notes.append(f"nominal load not given: took {load:.6g} N, the median of the table's "
                     "loads")
    tyre = TyreInfo(safe_name(path.stem) or "tyre", float(pressure), float(load), math.nan)
    return Manifest(str(path), tyre, None, (), {}, ("no manifest: a single characteristic "
                                                    "table; unloaded radius unknown",)), notes
