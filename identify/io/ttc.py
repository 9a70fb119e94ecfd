"""Tire Test Consortium (TTC) trailer files: MATLAB ``.mat`` (v5/v7 and v7.3) and ``.dat``.

The layout follows the public description of the TTC data (Calspan flat-belt machine, 100 Hz):

- ``.mat`` (MATLAB v5 or v7, read with :func:`scipy.io.loadmat`; v7.3, which is HDF5, with
  :mod:`identify.io.mat73`): one column vector per channel
  (:data:`TTC_CHANNELS`), a struct ``channel`` whose cell arrays ``name`` and ``units`` give
  each channel's unit, and the strings ``source``, ``testid`` and ``tireid``;
- ``.dat``: line 1 a title, line 2 the channel names, line 3 their units, data from line 4,
  tab-separated.

Both come in SI (kph, N, N-m, kPa, cm, deg C) and USCS (mph, lbf, ft-lb, psi, in, deg F)
variants; the units are read from the file and converted by :mod:`identify.core.units`. The
axes are SAE (FZ is negative under load; SA, FY and MZ change sign to ISO-W), so a run read
here declares ``axes = "SAE"``. Of the two slip ratios, SL (based on the effective radius:
SL = 0 gives FX = 0) is kappa; SR (based on the loaded radius) is kept but not used.

Channels keep their TTC names here; :data:`TTC_TO_TYDEX` says which TYDEX channel each one is
for :mod:`identify.io.trailer` (temperatures and radii become optional columns of the tidy
table). Every unusable file gives one problem naming the file (and the channel when there is
one): not a MATLAB v5/v7/v7.3 file, a truncated or corrupt one, a ``.dat`` whose header is short, a
channel without a unit.
"""
from __future__ import annotations

import io
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
import scipy.io

from identify.io.common import Problems, open_text, starts_with
from identify.io.hdf5 import RawRun
from identify.io.mat73 import Mat73Error, is_mat73_header, read_mat73
from identify.io.mat_guard import loadmat_crash, mat_problem

__all__ = [
    "TTC_CHANNELS",
    "TTC_STRINGS",
    "TTC_TO_TYDEX",
    "TtcChannel",
    "is_ttc_dat",
    "is_ttc_mat",
    "is_ttc_naming",
    "read_ttc",
    "ttc_name",
]

MAT_MAGIC = b"MATLAB"
#: The strings a TTC .mat file carries besides the channels.
TTC_STRINGS = ("source", "testid", "tireid")


@dataclass(frozen=True)
class TtcChannel:
    """One TTC channel: its dimension, units (SI and USCS files), meaning, TYDEX counterpart."""

    dimension: str
    si_unit: str
    uscs_unit: str
    long_name: str
    tydex: str | None


#: The TTC channels in file order (the public description's names and units).
TTC_CHANNELS: dict[str, TtcChannel] = {
    "ET": TtcChannel("time", "s", "s", "elapsed time", "RUNTIME"),
    "V": TtcChannel("speed", "kph", "mph", "road speed", "LONGVEL"),
    "N": TtcChannel("angular_velocity", "rpm", "rpm", "wheel rotational speed", "WHROTSPD"),
    "SA": TtcChannel("angle", "deg", "deg", "slip angle", "SLIPANGL"),
    "IA": TtcChannel("angle", "deg", "deg", "inclination angle", "INCLANGL"),
    "RL": TtcChannel("length", "cm", "in", "loaded radius", "RLOADED"),
    "RE": TtcChannel("length", "cm", "in", "effective rolling radius", "REFFECT"),
    "P": TtcChannel("pressure", "kPa", "psi", "inflation pressure", "INFLPRES"),
    "FX": TtcChannel("force", "N", "lbf", "longitudinal force", "FX"),
    "FY": TtcChannel("force", "N", "lbf", "lateral force", "FYW"),
    "FZ": TtcChannel("force", "N", "lbf", "normal force", "FZW"),
    "MX": TtcChannel("moment", "N-m", "ft-lb", "overturning moment", "MXW"),
    "MZ": TtcChannel("moment", "N-m", "ft-lb", "aligning moment", "MZW"),
    "NFX": TtcChannel("ratio", "none", "none", "normalized longitudinal force", None),
    "NFY": TtcChannel("ratio", "none", "none", "normalized lateral force", None),
    "RST": TtcChannel("temperature", "deg C", "deg F", "road surface temperature", "TROAD"),
    "TSTI": TtcChannel("temperature", "deg C", "deg F", "tread temperature inner", "TTREADI"),
    "TSTC": TtcChannel("temperature", "deg C", "deg F", "tread temperature centre", "TTREADC"),
    "TSTO": TtcChannel("temperature", "deg C", "deg F", "tread temperature outer", "TTREADO"),
    "AMBTMP": TtcChannel("temperature", "deg C", "deg F", "ambient temperature", "TAMBIENT"),
    "SR": TtcChannel("ratio", "none", "none", "slip ratio based on RL", None),
    "SL": TtcChannel("ratio", "none", "none", "slip ratio based on RE", "LONGSLIP"),
    "RUN": TtcChannel("ratio", "none", "none", "run number", None),
}
#: TTC channel name -> TYDEX channel name of identify.io.trailer.
TTC_TO_TYDEX: dict[str, str] = {k: c.tydex for k, c in TTC_CHANNELS.items() if c.tydex}


def ttc_name(name: str) -> str:
    """A channel name as TTC writes it: ``"fz  "`` -> ``"FZ"`` (a name padded to the width of
    a MATLAB char matrix, or in another case); a name that is not a TTC channel only
    stripped."""
    name = str(name).strip()
    return name.upper() if name.upper() in TTC_CHANNELS else name


def is_ttc_naming(names) -> bool:
    """True when channel names are TTC's (``ET`` and two more TTC names, no ``RUNTIME``)."""
    names = set(names)
    return "ET" in names and "RUNTIME" not in names and len(names & TTC_CHANNELS.keys()) >= 3


def is_ttc_mat(path: str | Path) -> bool:
    """True when the file starts like a MATLAB .mat file (``MATLAB`` text header)."""
    return starts_with(path, MAT_MAGIC)


def is_ttc_dat(path: str | Path) -> bool:
    """True for a ``.dat`` file, or a text file whose line 2 holds tab-separated TTC names."""
    path = Path(path)
    if path.suffix.lower() == ".dat":
        return True
    try:
        with open_text(path, encoding="utf-8", errors="replace") as fh:
            fh.readline()
            names = fh.readline().rstrip("\r\n").split("\t")
    except (OSError, EOFError):
        return False
    return len(names) > 2 and is_ttc_naming(n.strip() for n in names)


def read_ttc(path: str | Path, problems: Problems, *, run: str | None = None) -> RawRun | None:
    """Read a TTC ``.mat`` or ``.dat`` file as stored (TTC names, file units, SAE axes).

    Parameters
    ----------
    path : str or Path
        The file (the format is recognised from the content: a MATLAB header, else .dat).
    problems : Problems
        Collector.
    run : str, optional
        The run id (default: the file stem).

    Returns
    -------
    RawRun or None
        Channels (float arrays), units, long names; ``attrs`` holds ``axes = "SAE"``, the
        format and, from a .mat file, ``source``, ``testid`` and ``tireid``.
    """
    path = Path(path)
    start = problems.total
    read = _read_mat if is_ttc_mat(path) else _read_dat
    found = read(path, problems)
    if found is None:
        return None
    data, units, attrs = found
    units = {k: _unit(k, u) for k, u in units.items() if _unit(k, u)}
    if "ET" not in data:
        problems.add(path, "missing required channel (elapsed time)", key="ET")
        return None
    n = data["ET"].size
    for name, values in data.items():
        if values.size != n:
            problems.add(path, f"{values.size} samples, but ET has {n}", key=name)
    if problems.total > start:
        return None
    long_names = {k: TTC_CHANNELS[k].long_name if k in TTC_CHANNELS else k for k in data}
    return RawRun(run or path.stem, data, units, long_names, {"axes": "SAE", **attrs})


def _unit(name: str, unit: str) -> str:
    """A TTC channel's unit with the spellings of a temperature (``C``, ``F``) and of a
    dimensionless channel (a blank cell) that only its dimension makes clear."""
    dim = TTC_CHANNELS[name].dimension if name in TTC_CHANNELS else None
    text = unit.strip()
    if dim == "temperature" and text.upper() in ("C", "F"):
        return f"deg {text.upper()}"
    return "none" if dim == "ratio" and not text else text


def _text(value) -> str:
    if isinstance(value, np.ndarray):
        return " ".join(_text(v) for v in value.reshape(-1))
    return value.decode("utf-8", "replace") if isinstance(value, bytes) else str(value)


def _read_mat(path: Path, problems: Problems):
    try:
        with open(path, "rb") as fh:
            head = fh.read(128)
            v73 = is_mat73_header(head)  # HDF5 inside: h5py reads it from the file
            data = b"" if v73 else head + fh.read()
    except OSError as exc:
        problems.add(path, f"cannot read file: {exc.strerror or exc}")
        return None
    if v73:
        try:
            mat = read_mat73(path)
        except Mat73Error as exc:
            problems.add(path, f"truncated or corrupt MATLAB v7.3 .mat file ({exc})")
            return None
        return _contents(path, mat, problems, "ttc-mat73")
    v5 = data[126:128] in (b"IM", b"MI")
    why = (mat_problem(data) or loadmat_crash(data)) if v5 else None
    if why is not None:  # scipy.io would crash on some (a segmentation fault)
        problems.add(path, f"truncated or corrupt .mat file ({why})")
        return None
    try:
        mat = scipy.io.loadmat(io.BytesIO(data), simplify_cells=True)
    except NotImplementedError:  # a version scipy does not know, not v5 nor v7.3
        problems.add(path, "not a MATLAB v5 or v7.3 .mat file: save it with -v7 or -v7.3")
        return None
    except Exception as exc:  # noqa: BLE001 - scipy.io's parser of untrusted bytes raises
        # any type on a corrupt file (MatReadError, ValueError, zlib.error, and even
        # UnboundLocalError from its Cython reader, found by tests/test_hostile_hypothesis.py)
        problems.add(path, f"truncated or corrupt .mat file (scipy.io: "
                           f"{type(exc).__name__}: {exc})")
        return None
    return _contents(path, mat, problems, "ttc-mat")


def _contents(path: Path, mat: Mapping, problems: Problems, fmt: str):
    """The channels, their units and the strings of a loaded .mat file (either version)."""
    struct = mat.get("channel")
    names, unit_list = ([], [])
    if isinstance(struct, (list, np.ndarray)) and len(struct) and all(
            isinstance(e, Mapping) for e in np.ravel(struct)):  # a struct array, one per channel
        struct = {k: [e.get(k, "") for e in np.ravel(struct)] for k in ("name", "units")}
    if isinstance(struct, Mapping):  # names padded to a char matrix's width, any case
        names = [_text(v).strip() for v in np.atleast_1d(struct.get("name", []))]
        names = [n if ttc_name(n) in names else ttc_name(n) for n in names]
        unit_list = [_text(v).strip() for v in np.atleast_1d(struct.get("units", []))]
    units = dict(zip(names, unit_list))
    data: dict[str, np.ndarray] = {}
    for key, value in mat.items():
        if key.startswith("__") or key == "channel" or key in TTC_STRINGS:
            continue
        array = np.asarray(value)
        if array.dtype.kind not in "fiub" or array.ndim > 1 and min(array.shape) > 1:
            continue  # not a channel (a string, a struct, a matrix)
        name = ttc_name(key) if ttc_name(key) not in mat else key  # "fz" next to "FZ": kept
        data[name] = np.atleast_1d(array).reshape(-1).astype(np.float64)
    n = data["ET"].size if "ET" in data else None
    # a number or vector of another length that the channel struct does not list (a rim
    # width, a calibration constant) is not a channel
    data = {k: v for k, v in data.items()
            if k in units or k in TTC_CHANNELS or n is None or v.size == n}
    # in the channel struct's order: a v7.3 file lists its variables by name
    order = {name: i for i, name in enumerate(names)}
    data = dict(sorted(data.items(), key=lambda kv: order.get(kv[0], len(order))))
    if not data:
        problems.add(path, "no channel vectors in the .mat file")
        return None
    if not units:
        problems.add(path, "no 'channel' struct with the channel units (name, units)",
                     key="channel")
        return None
    attrs = {k: _text(mat[k]).strip() for k in TTC_STRINGS if k in mat}
    return data, {k: units[k] for k in data if k in units}, {"format": fmt, **attrs}


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


def _read_dat(path: Path, problems: Problems):
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
    for dup in sorted({n for n in names if names.count(n) > 1}):
        problems.add(path, "channel named twice", line=2, key=dup)
    try:
        frame = _table(path, sep, names, ".")
    except (ValueError, pd.errors.ParserError) as exc:
        try:  # a decimal comma (a European locale's export), tab-separated
            frame = _table(path, sep, names, ",") if sep == "\t" else None
        except (ValueError, pd.errors.ParserError):
            frame = None
        if frame is None:
            problems.add(path, f"data below the header are not {_SEP_NAME[sep]}-separated "
                               f"numbers ({exc})", line=4)
            return None
    if len(frame) == 0:
        problems.add(path, "no data rows below the header", line=3)
        return None
    attrs = {"format": "ttc-dat", "title": lines[0].strip()}
    if frame.isna().to_numpy().any():  # pandas fills a short row with NaN: tell it from NaN
        cut = _ragged(path, len(names), sep, len(frame), problems)
        if cut is None:
            return None
        if cut:  # the last row cut short (a file copied while written): dropped, warned
            line, fields = cut.split()
            frame = frame.iloc[:-1]
            attrs["cut_row"] = line
            attrs["cut_row_detail"] = (f"the last row stops after {fields} of {len(names)} "
                                       "fields (the file ends inside it)")
    data = {n: frame[n].to_numpy(np.float64) for n in names}
    return data, dict(zip(names, unit_cells)), attrs


def _table(path: Path, sep: str, names: list[str], decimal: str) -> pd.DataFrame:
    return pd.read_csv(path, sep=sep, decimal=decimal, skiprows=3, header=None, names=names,
                       dtype=np.float64, index_col=False, engine="c", encoding="latin-1",
                       compression="infer" if path.suffix == ".gz" else None)


_SEP_NAME = {"\t": "tab", ",": "comma"}


def _ragged(path: Path, width: int, sep: str, rows: int, problems: Problems) -> str | None:
    """Report the rows whose number of fields is not ``width``: None if there is one; "" if
    there is none; ``"<line> <fields>"`` when the only one is the last row, with fewer fields
    (a file cut short: that row is dropped with a warning)."""
    with open_text(path, encoding="latin-1", newline="") as fh:
        lines = fh.read().split("\n")[3:]
    counts = np.array([_fields(line, sep) if line.strip() else width for line in lines])
    bad = np.flatnonzero(counts != width)
    filled = np.flatnonzero([bool(line.strip()) for line in lines])
    if bad.size == 1 and filled.size and bad[0] == filled[-1] and counts[bad[0]] < width:
        return f"{int(bad[0]) + 4} {int(counts[bad[0]])}"
    for i in bad[:10]:
        problems.add(path, f"ragged row: {counts[i]} fields, the header has {width}",
                     line=int(i) + 4, kind="ragged-row")
    for _ in bad[10:]:
        problems.add(path, "ragged row", kind="ragged-row")
    return None if bad.size else ""


def _fields(line: str, sep: str) -> int:
    """The fields of a data line, a trailing separator not counted (pandas drops it)."""
    line = line.rstrip("\r")
    return line.removesuffix(sep).count(sep) + 1


def _numeric(cells) -> bool:
    try:
        [float(c) for c in cells if c.strip()]
    except ValueError:
        return False
    return any(c.strip() for c in cells)
