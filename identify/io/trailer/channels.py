"""Trailer channels as stored -> :class:`Channels` in SI: the channel table, the readers' dispatch.

The channel table (:data:`CHANNELS`: TYDEX name -> tidy column, dimension, long name,
required), the names the loaders accept for each channel, and :func:`read_channels`, which
recognises a trailer file's format from its content (TYDEX, HDF5, TTC .mat/.dat, CSV) and
converts every channel to SI. :mod:`identify.io.trailer.files` turns the result into the tidy table.
"""
from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np

from identify.core.serial import Serial, meta
from identify.core.units import (
    SI_UNITS,
    UNITS,
    normalize_unit,
    same_unit,
    to_si,
    unit_problem,
)
from identify.io.common import Problems, file_problem, read_numeric_csv
from identify.io.csv_rows import RowLines
from identify.io.hdf5.channel_files import RawRun, is_hdf5, read_hdf5
from identify.io.ttc.files import (
    READER_NOTES,
    TTC_TO_TYDEX,
    UNITS_SOURCE,
    assumed_units,
    is_ttc_dat,
    is_ttc_mat,
    is_ttc_naming,
    read_ttc,
)
from identify.io.tydex import TydexFile, is_tydex, read_tydex

__all__ = ["ALIASES", "CHANNELS", "C_NAMES", "OPTIONAL_COLUMNS", "TRAILER_COLUMNS", "Channels",
           "canonical", "read_channels"]

#: TYDEX name -> (tidy column, dimension, long name, required).
CHANNELS: dict[str, tuple[str, str, str, bool]] = {
    "RUNTIME": ("t", "time", "running time", True),
    "LONGVEL": ("Vx", "speed", "longitudinal velocity", True),
    "WHROTSPD": ("omega", "angular_velocity", "wheel rotational speed", True),
    "SLIPANGL": ("alpha", "angle", "slip angle", True),
    "LONGSLIP": ("kappa", "ratio", "longitudinal slip", True),
    "INCLANGL": ("gamma", "angle", "inclination angle", True),
    "INFLPRES": ("p", "pressure", "inflation pressure", True),
    "FX": ("Fx", "force", "longitudinal force", True),
    "FYW": ("Fy", "force", "lateral force", True),
    "FZW": ("Fz", "force", "vertical force", True),
    "MXW": ("Mx", "moment", "overturning moment", True),
    "MYW": ("My", "moment", "rolling resistance moment", False),
    "MZW": ("Mz", "moment", "self-aligning moment", True),
    "RLOADED": ("rl", "length", "loaded radius", False),
    "REFFECT": ("re", "length", "effective rolling radius", False),
    "TTREADI": ("T_tread_in", "temperature", "tread temperature inner", False),
    "TTREADC": ("T_tread_centre", "temperature", "tread temperature centre", False),
    "TTREADO": ("T_tread_out", "temperature", "tread temperature outer", False),
    "TROAD": ("T_road", "temperature", "road surface temperature", False),
    "TAMBIENT": ("T_ambient", "temperature", "ambient temperature", False),
}
#: Other names of the same channels (C-axis names for TYDEX-C files).
ALIASES: dict[str, tuple[str, ...]] = {
    "FX": ("FXW", "FXC"), "FYW": ("FYC",), "FZW": ("FZC",), "MXW": ("MXC",),
    "MYW": ("MYC",), "MZW": ("MZC",), "RLOADED": ("LOADRADI",)}
C_NAMES = frozenset({"FXC", "FYC", "FZC", "MXC", "MYC", "MZC"})
_CANONICAL = {alias: name for name, aliases in ALIASES.items() for alias in aliases}
#: Columns of the tidy trailer table.
TRAILER_COLUMNS = ("run", "t", "Vx", "omega", "alpha", "kappa", "gamma", "p",
                   "Fx", "Fy", "Fz", "Mx", "My", "Mz")
#: Columns appended to the tidy table when the file has the channel: radii [m], temperatures [K].
OPTIONAL_COLUMNS = ("rl", "re", "T_tread_in", "T_tread_centre", "T_tread_out", "T_road",
                    "T_ambient")


def canonical(name: str, ttc: bool = False) -> str | None:
    """The TYDEX name of a channel (a TTC name when ``ttc``), or None for other channels."""
    if ttc:
        return TTC_TO_TYDEX.get(name)
    return name if name in CHANNELS else _CANONICAL.get(name)


@dataclass(frozen=True, eq=False)
class Channels(Serial):
    """The channels of one run [SI where the unit is known], before the axis conversion.

    ``first_line`` is the line of the first sample in a text file (None for HDF5;
    ``first_line + i`` is the line of sample ``i``, a :class:`RowLines` when the file has
    blank lines); ``axes`` is
    the axis system the file itself declares (HDF5 group attribute ``axes``; SAE for TTC
    files), if any; ``attrs`` holds what else the file says about itself (a TTC file's
    ``source``, ``testid``, ``tireid``; its ``format``); ``file_units`` the unit each channel
    had before the conversion (from the manifest or the file; absent: none was given).
    """

    run: str
    data: Mapping[str, np.ndarray] = field(metadata=meta(skip=True))
    units: Mapping[str, str]
    file: str
    long_names: Mapping[str, str] = field(default_factory=dict, metadata=meta(skip=True))
    first_line: int | RowLines | None = field(default=None, metadata=meta(skip=True))
    axes: str | None = None
    attrs: Mapping[str, str] = field(default_factory=dict)
    file_units: Mapping[str, str] = field(default_factory=dict, metadata=meta(skip=True))

    def __post_init__(self) -> None:
        for name in ("data", "units", "long_names", "attrs", "file_units"):
            object.__setattr__(self, name, MappingProxyType(dict(getattr(self, name))))

    @property
    def ttc(self) -> bool:
        """True when the channels have the Tire Test Consortium's names (ET, FZ, ...)."""
        return str(self.attrs.get("format", "")).startswith("ttc") or is_ttc_naming(self.data)

    @property
    def samples(self) -> int:
        """Samples of the run (of its first channel)."""
        return len(next(iter(self.data.values()))) if self.data else 0

    #: ``to_dict`` is a summary (run, file, units, axes, attrs), then the number of samples
    serial_derived = {"samples": lambda self: self.samples}
    serial_order = ("run", "file", "axes", "samples")


def read_channels(path: str | Path, *, run: str | None = None,
                  units: Mapping[str, str] | None = None,
                  problems: Problems | None = None) -> list[Channels] | None:
    """Read the runs of a trailer file (any format) with every channel converted to SI.

    Parameters
    ----------
    path : str or Path
        CSV, HDF5 or TYDEX file (detected from the content).
    run : str, optional
        Run id: selects an HDF5 group; names the run of a CSV/TYDEX file (default: the TYDEX
        header's MEASID, else the file stem).
    units : mapping, optional
        Channel -> unit (from the manifest); overrides nothing the file declares differently
        (a conflict is a problem).
    problems : Problems, optional
        Collector; strict by default.
    """
    problems = Problems.or_strict(problems)
    path = Path(path)
    start = problems.total
    why = file_problem(path)
    if why is not None:
        problems.add(path, "file not found" if why.startswith("no such") else why)
        return None
    if is_tydex(path):
        tdx = read_tydex(path, problems, allow_nan=True)
        measid = next((e.value for e in tdx.header if e.key == "MEASID"), "") if tdx else ""
        raws = None if tdx is None else [(_from_tydex(tdx, run or measid or path.stem,
                                                      problems), tdx.data_line)]
    elif is_hdf5(path):
        found = read_hdf5(path, problems, run=run, allow_nan=True)
        raws = None if found is None else [(raw, None) for raw in found]
    elif is_ttc_mat(path) or is_ttc_dat(path):
        raw = read_ttc(path, problems, run=run)
        raws = None if raw is None else [(raw, 4 if raw.attrs.get("format") == "ttc-dat"
                                          else None)]
    else:
        table = read_numeric_csv(path, problems, allow_nan=True)
        raws = None if table is None else [(_csv_run(run or path.stem, *table[:2]),
                                            table[2])]
    if raws is None:
        return None
    out = [_to_si(path, raw, line, dict(units or {}), problems) for raw, line in raws]
    return None if problems.total > start else out


def _csv_run(name: str, table, header_units: Mapping[str, str]) -> RawRun:
    """The run of a CSV file. A CSV with the TTC channel names and no unit in its header (a
    TTC session exported by a team script) is read as a TTC file without its channel struct:
    the TTC convention, or the unit the magnitudes show, each said in a warning
    (:func:`identify.io.ttc.files.assumed_units`); a unit the user gives replaces it."""
    data = {k: table[k].to_numpy() for k in table.columns}
    if header_units or not is_ttc_naming(data):
        return RawRun(name, data, header_units)
    units, notes = assumed_units({k: np.asarray(v, float) for k, v in data.items()},
                                 "no units in the CSV header")
    return RawRun(name, data, units, attrs={UNITS_SOURCE: "convention",
                                            READER_NOTES: "\n".join(notes)})


def _from_tydex(tdx: TydexFile, run: str, problems: Problems) -> RawRun:
    data = {c.name: tdx.data[:, i] for i, c in enumerate(tdx.channels)}
    units = {c.name: c.unit for c in tdx.channels}
    names = {c.name: c.description for c in tdx.channels}
    for entry in tdx.constants:  # a constant stands in for a channel that is not measured
        if canonical(entry.key) and entry.key not in data:
            try:
                value = float(entry.value)
            except ValueError:
                continue
            if not np.isfinite(value):  # a constant stands for every sample: no NaN allowed
                problems.add(tdx.path, f"constant {entry.value!r} is not a finite number",
                             key=entry.key)
                continue
            data[entry.key] = np.full(tdx.data.shape[0], value)
            units[entry.key], names[entry.key] = entry.unit, entry.description
    return RawRun(run, data, units, names)


def _to_si(path: Path, raw: RawRun, first_line: int | RowLines | None, manifest: dict[str, str],
           problems: Problems) -> Channels:
    ttc = str(raw.attrs.get("format", "")).startswith("ttc") or is_ttc_naming(raw.data)
    known = set(raw.data) | {canonical(n, ttc) for n in raw.data}
    for key in manifest:
        if key not in known:
            problems.add(path, "the manifest gives a unit for a channel that is not in the file",
                         key=key)
    data, units, given = {}, {}, {}
    for name, values in raw.data.items():
        canon = canonical(name, ttc)
        dim = CHANNELS[canon][1] if canon else None
        declared = manifest.get(name) or (manifest.get(canon) if canon else None)
        in_file = raw.units.get(name) or None
        if raw.attrs.get(UNITS_SOURCE) == "convention" and declared:
            in_file = None  # an assumed unit yields to the one the user gives
        if declared and in_file and not same_unit(declared, in_file):
            problems.add(path, f"unit conflict: the manifest says '{declared}', the file says "
                               f"'{in_file}'", key=name)
        unit = declared or in_file
        if unit:
            given[name] = unit
        if unit is None and dim and str(raw.attrs.get("format", "")).startswith("ttc"):
            problems.add(path, "no unit for this channel in the file (give it with --units)",
                         key=name)
            continue
        if unit is None:
            data[name], units[name] = values, SI_UNITS[dim] if dim else ""
            continue
        why = unit_problem(unit, dim)
        if why is not None:
            if dim is None:  # a channel mfid does not use keeps its values and unit
                data[name], units[name] = values, unit
            else:
                problems.add(path, why, key=name)
            continue
        with np.errstate(over="ignore", invalid="ignore"):
            data[name] = to_si(values, unit, dimension=dim)
        _overflow(path, name, values, data[name], unit, first_line, problems)
        units[name] = SI_UNITS[UNITS[normalize_unit(unit)][2]]
    long_names = {n: raw.long_names.get(n) or (CHANNELS[canonical(n, ttc)][2]
                                               if canonical(n, ttc) else n) for n in data}
    return Channels(raw.name, data, units, str(path), long_names, first_line,
                    raw.attrs.get("axes") or None,
                    {k: str(v) for k, v in raw.attrs.items() if k != "axes"}, given)


def _overflow(path: Path, name: str, raw: np.ndarray, si: np.ndarray, unit: str,
              first_line: int | RowLines | None, problems: Problems) -> None:
    """A value finite as read but not in SI (``1e308 kPa``): the check after the conversion."""
    lost = np.flatnonzero(np.isfinite(raw) & ~np.isfinite(si))
    if lost.size:
        i = int(lost[0])
        where = {"line": first_line + i} if first_line is not None else {}
        at = "" if where else f" (sample {i})"
        problems.add(path, f"{float(raw[i])!r} {unit}{at} is not finite in SI: the unit "
                           f"conversion overflows ({lost.size} sample(s))", key=name, **where)
