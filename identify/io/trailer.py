"""Trailer channel files (CSV, HDF5, TYDEX) -> tidy tables in SI units and ISO-W axes.

Channels carry TYDEX names (docs/measurement-folder.md): RUNTIME, LONGVEL, WHROTSPD, SLIPANGL,
LONGSLIP, INCLANGL, INFLPRES, FX, FYW, FZW, MXW, MZW, optionally MYW and RLOADED (loaded radius,
needed for TYDEX-C data unless the run declares ``loaded_radius_m``). Wheel-centre channels may
be named FXC .. MZC. Units come from the manifest, else from the file (CSV header
``NAME [unit]``, HDF5 ``units`` attribute, TYDEX unit column), else SI.

The format is detected from the content: ``**HEADER`` -> TYDEX, the HDF5 signature -> HDF5,
anything else -> CSV. :func:`read_trailer` works without a manifest for quick use.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd

from identify.core.errors import InputError
from identify.io.axes import AXES, to_iso_w
from identify.io.common import Problems, check_declared, check_increasing, read_numeric_csv
from identify.io.hdf5 import RawRun, is_hdf5, read_hdf5, write_hdf5
from identify.io.tydex import TydexChannel, TydexEntry, TydexFile, is_tydex, read_tydex
from identify.io.tydex import write_tydex
from identify.core.units import SI_UNITS, UNITS, normalize_unit, same_unit, to_si, unit_problem
from identify.io.atomic import atomic_write_text

__all__ = ["CHANNELS", "ALIASES", "TRAILER_COLUMNS", "Channels", "read_channels",
           "channels_to_tidy", "read_trailer", "write_channels"]

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
}
#: Other names of the same channels (C-axis names for TYDEX-C files).
ALIASES: dict[str, tuple[str, ...]] = {
    "FX": ("FXW", "FXC"), "FYW": ("FYC",), "FZW": ("FZC",), "MXW": ("MXC",),
    "MYW": ("MYC",), "MZW": ("MZC",), "RLOADED": ("LOADRADI",)}
_C_NAMES = frozenset({"FXC", "FYC", "FZC", "MXC", "MYC", "MZC"})
_CANONICAL = {alias: name for name, aliases in ALIASES.items() for alias in aliases}
#: Columns of the tidy trailer table.
TRAILER_COLUMNS = ("run", "t", "Vx", "omega", "alpha", "kappa", "gamma", "p",
                   "Fx", "Fy", "Fz", "Mx", "My", "Mz")


def _canonical(name: str) -> str | None:
    return name if name in CHANNELS else _CANONICAL.get(name)


@dataclass(frozen=True, eq=False)
class Channels:
    """The channels of one run [SI where the unit is known], before the axis conversion.

    ``first_line`` is the line of the first sample in a text file (None for HDF5); ``axes`` is
    the axis system the file itself declares (HDF5 group attribute ``axes``), if any.
    """

    run: str
    data: Mapping[str, np.ndarray]
    units: Mapping[str, str]
    file: str
    long_names: Mapping[str, str] = field(default_factory=dict)
    first_line: int | None = None
    axes: str | None = None

    def __post_init__(self) -> None:
        for name in ("data", "units", "long_names"):
            object.__setattr__(self, name, MappingProxyType(dict(getattr(self, name))))

    def to_dict(self) -> dict[str, Any]:
        """A JSON-safe summary (channel names, units, number of samples)."""
        n = len(next(iter(self.data.values()))) if self.data else 0
        return {"run": self.run, "file": self.file, "axes": self.axes, "samples": n,
                "units": dict(self.units)}


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
    problems = problems if problems is not None else Problems(strict=True)
    path = Path(path)
    start = problems.total
    if not path.is_file():
        problems.add(path, "is a directory, expected a file" if path.is_dir() else "file not found")
        return None
    if is_tydex(path):
        tdx = read_tydex(path, problems)
        measid = next((e.value for e in tdx.header if e.key == "MEASID"), "") if tdx else ""
        raws = None if tdx is None else [(_from_tydex(tdx, run or measid or path.stem),
                                          tdx.data_line)]
    elif is_hdf5(path):
        found = read_hdf5(path, problems, run=run)
        raws = None if found is None else [(raw, None) for raw in found]
    else:
        table = read_numeric_csv(path, problems)
        raws = None if table is None else [(RawRun(run or path.stem, {
            k: table[0][k].to_numpy() for k in table[0].columns}, table[1]), 2)]
    if raws is None:
        return None
    out = [_to_si(path, raw, line, dict(units or {}), problems) for raw, line in raws]
    return None if problems.total > start else out


def _from_tydex(tdx: TydexFile, run: str) -> RawRun:
    data = {c.name: tdx.data[:, i] for i, c in enumerate(tdx.channels)}
    units = {c.name: c.unit for c in tdx.channels}
    names = {c.name: c.description for c in tdx.channels}
    for entry in tdx.constants:  # a constant stands in for a channel that is not measured
        if _canonical(entry.key) and entry.key not in data:
            try:
                value = float(entry.value)
            except ValueError:
                continue
            data[entry.key] = np.full(tdx.data.shape[0], value)
            units[entry.key], names[entry.key] = entry.unit, entry.description
    return RawRun(run, data, units, names)


def _to_si(path: Path, raw: RawRun, first_line: int | None, manifest: dict[str, str],
           problems: Problems) -> Channels:
    known = set(raw.data) | {_canonical(n) for n in raw.data}
    for key in manifest:
        if key not in known:
            problems.add(path, "the manifest gives a unit for a channel that is not in the file",
                         key=key)
    data, units = {}, {}
    for name, values in raw.data.items():
        canon = _canonical(name)
        dim = CHANNELS[canon][1] if canon else None
        declared = manifest.get(name) or (manifest.get(canon) if canon else None)
        in_file = raw.units.get(name) or None
        if declared and in_file and not same_unit(declared, in_file):
            problems.add(path, f"unit conflict: the manifest says '{declared}', the file says "
                               f"'{in_file}'", key=name)
        unit = declared or in_file
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
        data[name] = to_si(values, unit, dimension=dim)
        units[name] = SI_UNITS[UNITS[normalize_unit(unit)][2]]
    long_names = {n: raw.long_names.get(n) or (CHANNELS[_canonical(n)][2] if _canonical(n)
                                               else n) for n in data}
    return Channels(raw.name, data, units, str(path), long_names, first_line,
                    raw.attrs.get("axes") or None)


def channels_to_tidy(ch: Channels, *, axes: str | None = None,
                     conditions: Mapping[str, float] | None = None,
                     problems: Problems | None = None) -> pd.DataFrame | None:
    """The tidy table (:data:`TRAILER_COLUMNS`, SI, ISO-W) of one run.

    Parameters
    ----------
    ch : Channels
        The run's channels in SI.
    axes : {"ISO-W", "SAE", "TYDEX-C"}, optional
        The data's axis system; default: what the file declares, else TYDEX-C when C-axis
        channels (FYC ...) are present, else ISO-W.
    conditions : mapping, optional
        Declared ``pressure_Pa`` and ``load_N`` (medians further than 15 % are problems) and
        ``loaded_radius_m`` (for TYDEX-C without an RLOADED channel).
    problems : Problems, optional
        Collector; strict by default.
    """
    problems = problems if problems is not None else Problems(strict=True)
    conditions = conditions or {}
    start = problems.total
    c_names = sorted(n for n in ch.data if n in _C_NAMES)
    if axes is None:
        axes = ch.axes or ("TYDEX-C" if c_names else "ISO-W")
    elif ch.axes and ch.axes != axes:
        problems.add(ch.file, f"the file declares axes '{ch.axes}', the manifest '{axes}'",
                     key=ch.run)
    if axes not in AXES:
        problems.add(ch.file, f"unknown axis system '{axes}' (expected one of: "
                              f"{', '.join(AXES)})", key=ch.run)
        return None
    if c_names and axes != "TYDEX-C":
        problems.add(ch.file, f"a wheel-centre (C-axis) channel, but the run's axes are "
                              f"'{axes}' (use TYDEX-C)", key=c_names[0])
    cols: dict[str, np.ndarray] = {}
    for canon, (col, _, _, required) in CHANNELS.items():
        names = sorted((canon,) + ALIASES.get(canon, ()),
                       key=lambda n: (n not in _C_NAMES) if axes == "TYDEX-C" else 0)
        found = next((n for n in names if n in ch.data), None)
        if found is not None:
            cols[col] = ch.data[found]
        elif required or (axes == "TYDEX-C" and canon == "MYW"):
            problems.add(ch.file, "missing required channel" + (
                " (TYDEX-C data need My to compute Mz at the contact point)"
                if canon == "MYW" else ""), key=canon)
    rl = cols.pop("rl", None)
    if axes == "TYDEX-C":
        rl = rl if rl is not None else conditions.get("loaded_radius_m")
        if rl is None:
            problems.add(ch.file, "TYDEX-C data need the loaded radius: an RLOADED channel "
                                  "or conditions.loaded_radius_m", key="RLOADED")
    if problems.total > start:
        return None
    check_increasing(problems, ch.file, "RUNTIME", cols["t"], ch.first_line)
    n = cols["t"].size
    frame = pd.DataFrame({c: cols.get(c, np.full(n, np.nan)) for c in TRAILER_COLUMNS[1:]},
                         copy=False)  # no 2-D consolidation: one block per channel is faster
    frame.insert(0, "run", ch.run)
    frame = to_iso_w(frame, axes, loaded_radius=rl)
    check_declared(problems, ch.file, "INFLPRES", frame["p"].to_numpy(),
                   conditions.get("pressure_Pa"), "pressure", "Pa")
    fz = frame["Fz"].to_numpy()
    check_declared(problems, ch.file, "FZW", fz, conditions.get("load_N"), "load Fz", "N")
    if "load_N" not in conditions and np.median(fz) < 0:
        problems.add(ch.file, f"median Fz is negative ({np.median(fz):.6g} N): in ISO-W Fz is "
                              "positive up (are the axes right?)", key="FZW")
    return frame if problems.total == start else None


def read_trailer(path: str | Path, *, run: str | None = None, axes: str | None = None,
                 units: Mapping[str, str] | None = None,
                 conditions: Mapping[str, float] | None = None) -> pd.DataFrame:
    """Read a trailer file into one tidy table (all its runs), raising on the first problem.

    See :func:`read_channels` and :func:`channels_to_tidy` for the arguments.
    """
    runs = read_channels(path, run=run, units=units)
    frames = [channels_to_tidy(ch, axes=axes, conditions=conditions) for ch in runs]
    return frames[0] if len(frames) == 1 else pd.concat(frames, ignore_index=True)


def write_channels(runs: Sequence[Channels], path: str | Path) -> Path:
    """Write runs to ``path``; the format follows the extension (.csv, .h5/.hdf5, .tdx).

    CSV and TYDEX hold one run. Values are written exactly (shortest round-trip form); units
    are the channels' units (SI after :func:`read_channels`).
    """
    path = Path(path)
    ext = path.suffix.lower()
    if ext in (".h5", ".hdf5"):
        return write_hdf5(path, [RawRun(c.run, c.data, c.units, c.long_names,
                                        {"axes": c.axes} if c.axes else {}) for c in runs])
    if ext not in (".csv", ".tdx"):
        raise InputError(path, "unknown output format: expected .csv, .h5, .hdf5 or .tdx")
    if len(runs) != 1:
        raise InputError(path, f"a {ext} file holds one run, got {len(runs)} "
                               f"({', '.join(c.run for c in runs)}): choose one with --run")
    ch = runs[0]
    names = list(ch.data)
    rows = np.column_stack([ch.data[n] for n in names]).tolist() if names else []
    if ext == ".tdx":
        channels = tuple(TydexChannel(n, ch.long_names.get(n, n), ch.units.get(n, ""))
                         for n in names)
        header = (TydexEntry("MEASID", "Measurement ID", "", ch.run),)
        return write_tydex(path, TydexFile(header, (f"written by mfid from {ch.file}",), (),
                                           channels, np.asarray(rows, dtype=float)))
    head = [n if ch.units.get(n, "") in ("", SI_UNITS.get(
        CHANNELS[_canonical(n)][1] if _canonical(n) else "", "")) else f"{n} [{ch.units[n]}]"
            for n in names]
    text = "\n".join([",".join(head)] + [",".join(map(repr, row)) for row in rows]) + "\n"
    return atomic_write_text(path, text)
