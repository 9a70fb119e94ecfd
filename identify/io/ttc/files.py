"""Tire Test Consortium (TTC) trailer files: MATLAB ``.mat`` (v5/v7 and v7.3) and ``.dat``.

The layout follows the public description of the TTC data (Calspan flat-belt machine, 100 Hz):

- ``.mat`` (MATLAB v5 or v7, read with :func:`scipy.io.loadmat`; v7.3, which is HDF5, with
  :mod:`identify.io.ttc.mat73`): one column vector per channel
  (:data:`TTC_CHANNELS`), a struct ``channel`` whose cell arrays ``name`` and ``units`` give
  each channel's unit, and the strings ``source``, ``testid`` and ``tireid``;
- ``.dat``: line 1 a title, line 2 the channel names, line 3 their units, data from line 4,
  tab-separated;
- the older ``.mat`` layout (earlier rounds, and files converted by teams): the same vectors
  without the ``channel`` struct. The units then follow the TTC convention
  (:func:`convention_units`: SI, or USCS when the pressure is in psi), said in a warning;
  the user's ``--units`` replace the assumed ones.

A channel of another length than the time (an index vector assembled by hand) is left out
with a warning and the rest of the file is read. So is a MATLAB ``logical`` (true/false)
vector: a flag read as 1/0 is not a measurement (``true`` as a camber would be 57 deg); one in
the place of a channel the fit cannot do without (:data:`LOGICAL_REFUSED`) refuses the file.

Both come in SI (kph, N, N-m, kPa, cm, deg C) and USCS (mph, lbf, ft-lb, psi, in, deg F)
variants; the units are read from the file and converted by :mod:`identify.core.units`. The
axes are SAE (FZ is negative under load; SA, FY and MZ change sign to ISO-W), so a run read
here declares ``axes = "SAE"``. Of the two slip ratios, SL (based on the effective radius:
SL = 0 gives FX = 0) is kappa; SR (based on the loaded radius) is kept but not used.

Channels keep their TTC names here; :data:`TTC_TO_TYDEX` says which TYDEX channel each one is
for :mod:`identify.io.trailer.files` (temperatures and radii become optional columns of the tidy
table). Every unusable file gives one problem naming the file (and the channel when there is
one): not a MATLAB v5/v7/v7.3 file, a truncated or corrupt one, a ``.dat`` whose header is short, a
channel without a unit in a file that lists units. The channel table is
:mod:`identify.io.ttc.channel_names`, the ``.dat`` reader :mod:`identify.io.ttc.dat`.
"""
from __future__ import annotations

import io
from collections.abc import Mapping
from pathlib import Path

import numpy as np
import scipy.io

from identify.io.common import Problems, open_text, starts_with
from identify.io.hdf5.channel_files import RawRun
from identify.io.ttc.channel_names import (
    TTC_CHANNELS,
    TTC_TO_TYDEX,
    TtcChannel,
    is_ttc_naming,
    ttc_name,
)
from identify.io.ttc.dat import read_dat
from identify.io.ttc.mat73 import Mat73Error, Mat73Unread, is_mat73_header, read_mat73
from identify.io.ttc.mat_guard import loadmat_crash, mat_problem

__all__ = [
    "assumed_units",
    "READER_NOTES",
    "TTC_CHANNELS",
    "TTC_STRINGS",
    "TTC_TO_TYDEX",
    "TtcChannel",
    "UNITS_SOURCE",
    "convention_units",
    "reader_note",
    "reader_notes",
    "is_ttc_dat",
    "is_ttc_mat",
    "is_ttc_naming",
    "read_ttc",
    "ttc_name",
]

MAT_MAGIC = b"MATLAB"
#: The strings a TTC .mat file carries besides the channels.
TTC_STRINGS = ("source", "testid", "tireid")


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
    read = _read_mat if is_ttc_mat(path) else read_dat
    found = read(path, problems)
    if found is None:
        return None
    data, units, attrs = found
    units = {k: text for k, u in units.items() if (text := _unit(k, u))}
    if "ET" not in data:
        problems.add(path, "missing required channel (elapsed time)", key="ET")
        return None
    if problems.total > start:
        return None
    n = data["ET"].size
    notes = [attrs.pop(READER_NOTES)] if attrs.get(READER_NOTES) else []
    for name in [k for k, v in data.items() if v.size != n]:
        # a channel of another length than the time (an index vector such as RUN that was
        # assembled by hand, a channel cut short): its samples cannot be matched to the
        # others' times, so it is left out and the rest is read
        notes.append(reader_note(name, f"{data[name].size} samples, but ET has {n}",
                                 "channel left out"))
        del data[name]
        units.pop(name, None)
    if notes:
        attrs[READER_NOTES] = "\n".join(notes)
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


class _TtcVariables:
    """The variables of a TTC .mat file that must be read (any case of a channel's name): a
    v7.3 variable of another MATLAB class is left out, as in a v5 file."""

    def __contains__(self, name: object) -> bool:
        return isinstance(name, str) and (ttc_name(name) in TTC_CHANNELS
                                          or name in ("channel", *TTC_STRINGS))


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
            mat = read_mat73(path, needed=_TtcVariables())
        except Mat73Unread as exc:
            problems.add(path, f"MATLAB v7.3 .mat file: {exc}")
            return None
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
        # UnboundLocalError from its Cython reader, found by tests/unit/test_hostile_hypothesis.py)
        problems.add(path, f"truncated or corrupt .mat file (scipy.io: "
                           f"{type(exc).__name__}: {exc})")
        return None
    try:  # scipy.io gives a logical array as uint8: its class tells it from a measurement
        logical = {name for name, _, cls in scipy.io.whosmat(io.BytesIO(data))
                   if cls == "logical"}
    except Exception as exc:  # noqa: BLE001 - as loadmat above
        problems.add(path, f"truncated or corrupt .mat file (scipy.io: "
                           f"{type(exc).__name__}: {exc})")
        return None
    mat = {k: np.asarray(v, dtype=bool) if k in logical else v for k, v in mat.items()}
    return _contents(path, mat, problems, "ttc-mat")


def _wrapping_struct(mat: Mapping) -> tuple[str, Mapping] | None:
    """The one struct variable of a .mat file that holds the TTC channels as its fields (a
    team's export: ``run26.FX``, ``run26.SA``, ...) and its name; None when a channel is a
    variable of its own, or when no single struct holds at least three TTC channels."""
    variables = {k: v for k, v in mat.items() if not k.startswith("__")}
    if any(ttc_name(k) in TTC_CHANNELS for k in variables):
        return None
    structs = [(k, v) for k, v in variables.items() if isinstance(v, Mapping)
               and sum(ttc_name(f) in TTC_CHANNELS for f in v) >= 3]
    return structs[0] if len(structs) == 1 else None


def _unnamed_matrix(mat: Mapping) -> str | None:
    """A description of the first numeric matrix of a .mat file (a team's export of every
    channel as one column): its name and shape, or None."""
    for key, value in mat.items():
        array = np.asarray(value) if not key.startswith("__") else None
        if array is not None and array.dtype.kind in "fiu" and array.ndim == 2 \
                and min(array.shape) > 1:
            return f"'{key}' ({array.shape[0]} x {array.shape[1]})"
    return None


def _contents(path: Path, mat: Mapping, problems: Problems, fmt: str):
    """The channels, their units and the strings of a loaded .mat file (either version)."""
    start = problems.total
    wrapped = _wrapping_struct(mat)
    wrapper_note = []
    if wrapped is not None:  # the channels are the fields of one struct: read them there
        name, fields = wrapped
        mat = {**{k: v for k, v in mat.items() if k in TTC_STRINGS}, **fields}
        wrapper_note = [reader_note(name, "a struct holding the channels as its fields",
                                    "channels read from its fields")]
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
    logical: dict[str, int] = {}  # MATLAB logical vectors: name -> samples
    for key, value in mat.items():
        if key.startswith("__") or key == "channel" or key in TTC_STRINGS:
            continue
        array = np.asarray(value)
        if array.dtype.kind not in "fiub" or array.ndim > 1 and min(array.shape) > 1:
            continue  # not a channel (a string, a struct, a matrix)
        name = ttc_name(key) if ttc_name(key) not in mat else key  # "fz" next to "FZ": kept
        if array.dtype.kind == "b":
            logical[name] = array.size
            continue
        data[name] = np.atleast_1d(array).reshape(-1).astype(np.float64)
    n = data["ET"].size if "ET" in data else None

    def channel(name: str, size: int) -> bool:
        # a number or vector of another length that the channel struct does not list (a rim
        # width, a calibration constant) is not a channel
        return name in units or name in TTC_CHANNELS or n is None or size == n

    data = {k: v for k, v in data.items() if channel(k, v.size)}
    # true/false read as 1/0 would be a camber of 57 deg: a flag is not a measurement
    notes = []
    for name in [k for k, size in logical.items() if channel(k, size)]:
        if name in LOGICAL_REFUSED:
            problems.add(path, "a MATLAB logical (true/false) array, not a measurement",
                         key=name)
        else:
            notes.append(reader_note(name, "a MATLAB logical (true/false) array, not a "
                                           "measurement", "channel left out"))
    notes = wrapper_note + notes
    if problems.total > start:
        return None
    # in the channel struct's order: a v7.3 file lists its variables by name
    order = {name: i for i, name in enumerate(names)}
    data = dict(sorted(data.items(), key=lambda kv: order.get(kv[0], len(order))))
    if not data:
        matrix = _unnamed_matrix(mat)
        problems.add(path, "no channel vectors in the .mat file" + (
            f": the numeric matrix {matrix} names no channel; save each channel (ET, V, SA, "
            "FZ, ...) as a variable of its own" if matrix else ""))
        return None
    attrs = {k: _text(mat[k]).strip() for k in TTC_STRINGS if k in mat}
    if not units:  # the older layout: no channel struct, the units follow a convention
        units, assumed = assumed_units(data)
        attrs[UNITS_SOURCE] = "convention"
        notes += assumed
    if notes:
        attrs[READER_NOTES] = "\n".join(notes)
    return data, {k: units[k] for k in data if k in units}, {"format": fmt, **attrs}


#: TTC channels a run cannot do without (identify.io.trailer.files's required channels, less the
#: wheel speed older rounds lack): one held as a MATLAB logical array refuses the file.
LOGICAL_REFUSED = frozenset({"ET", "V", "SA", "IA", "P", "SL", "FX", "FY", "FZ", "MX", "MZ"})
#: ``attrs`` key of a run read here: what the reader decided about the file, one line each
#: (channels left out, units taken by convention); the trailer loader gives them as warnings.
READER_NOTES = "reader_notes"
#: ``attrs`` key: ``"convention"`` when the units are not in the file but assumed (a unit
#: given by the manifest or ``--units`` then replaces the assumed one without a conflict).
UNITS_SOURCE = "units_source"
#: Where a .mat file's units are missing, as its warning says.
NO_STRUCT = "no 'channel' struct with the units"
#: Median inflation pressure below which a file without units is taken to be in psi [file
#: units]: no tyre is tested below 45 kPa (6.5 psi), and none above 45 psi is in kPa's range.
PSI_BELOW = 45.0


def convention_units(data: Mapping[str, np.ndarray], missing: str = NO_STRUCT
                     ) -> tuple[dict[str, str], str]:
    """The units of a TTC file that does not give them, and the note that says so.

    Older TTC files (and files converted by teams) carry no ``channel`` struct. The TTC SI
    convention is then assumed (ET s, V kph, N rpm, SA/IA deg, RL/RE cm, P kPa, forces N,
    moments N-m, temperatures deg C); a file whose median pressure is below
    :data:`PSI_BELOW` is in the USCS convention (psi, lbf, ft-lb, mph, in, deg F): no tyre is
    tested below 45 kPa, so a kPa file is never read as psi. A USCS file of a tyre above
    45 psi (a truck tyre) reads as kPa; its pressure is then implausibly low for the load,
    and ``--units`` (named in the warning) sets the file's units.
    """
    pressure = data.get("P")
    finite = pressure[np.isfinite(pressure)] if pressure is not None else np.empty(0)
    median = float(np.median(finite)) if finite.size else float("nan")
    uscs = bool(0.0 < median < PSI_BELOW)
    units = {name: (ch.uscs_unit if uscs else ch.si_unit) for name, ch in TTC_CHANNELS.items()
             if name in data}
    system = "USCS (psi, lbf, ft-lb, mph, in, deg F)" if uscs else \
        "TTC SI (kPa, N, N-m, kph, cm, deg C)"
    why = (f"the median pressure {median:.4g} is below {PSI_BELOW:g}, so psi" if uscs else
           f"the median pressure {median:.4g} is a pressure in kPa" if np.isfinite(median)
           else "no pressure channel to tell psi from kPa")
    return units, (f"{missing}: the {system} convention is "
                   f"assumed ({why}); --units CHANNEL=UNIT sets another")


#: Largest slip-angle amplitude [rad] that a sweep in radians reaches (20 deg): a file without
#: units whose SA stays within it while the lateral force reaches :data:`SATURATED_FY` of the
#: load holds radians (no tyre develops that force within a third of a degree).
RADIAN_SWEEP = 0.35
#: |FY| / |FZ| that a slip-angle sweep reaches on every tyre (friction 0.8-3).
SATURATED_FY = 0.5


def _radius(values: np.ndarray | None, factor: float) -> float:
    """Median of ``values`` times ``factor`` where finite and non-zero (nan when none)."""
    if values is None:
        return float("nan")
    finite = np.abs(values[np.isfinite(values) & (values != 0)])
    return float(np.median(finite)) * factor if finite.size else float("nan")


def magnitude_units(data: Mapping[str, np.ndarray], units: Mapping[str, str]
                    ) -> tuple[dict[str, str], dict[str, str]]:
    """The convention's ``units`` with the channels whose magnitudes show another unit, and
    per such channel why (a file converted by a team script keeps the TTC names but may hold
    radians, metres or m/s):

    - SA in rad: 99.9 % of the loaded samples within :data:`RADIAN_SWEEP` (a spike does not
      hide the unit) while |FY| reaches :data:`SATURATED_FY` of |FZ| (IA then in rad too: one
      script converts both angles; ``--units IA=deg`` says otherwise);
    - RL and RE in m: a median of 0.1-1.5 (a tyre radius in metres, 1-15 mm in cm);
    - V in m/s: V / omega is a tyre radius (0.1-1.5 m) with V in m/s but not in the
      convention's km/h (needs the wheel speed N in rpm).
    Only metric files are judged (a USCS file keeps its convention).
    """
    units = dict(units)
    told: dict[str, str] = {}
    if units.get("P") != "kPa":
        return units, told
    sa, fy, fz = (np.asarray(data[k], float) if k in data else None for k in ("SA", "FY", "FZ"))
    if sa is not None and fy is not None and fz is not None and units.get("SA") == "deg":
        loaded = np.isfinite(sa) & np.isfinite(fy) & (np.abs(np.nan_to_num(fz)) > 50.0)
        # the 99.9th percentile: a spike the cleaning removes later must not hide the unit
        amplitude = float(np.quantile(np.abs(sa[loaded]), 0.999)) if loaded.any() else np.inf
        ratio = float(np.quantile(np.abs(fy[loaded] / fz[loaded]), 0.99)) if loaded.any() \
            else 0.0
        if amplitude <= RADIAN_SWEEP and ratio >= SATURATED_FY:
            units["SA"] = "rad"
            told["SA"] = (f"slip angle within +-{amplitude:.3g} while |FY| reaches "
                          f"{ratio:.2g} |FZ|: radians, not degrees")
            if units.get("IA") == "deg":
                units["IA"] = "rad"
                told["IA"] = "inclination angle in the unit of the slip angle (radians)"
    for name in ("RL", "RE"):
        metres = _radius(data.get(name), 1.0)
        if units.get(name) == "cm" and 0.1 <= metres <= 1.5:
            units[name] = "m"
            told[name] = f"median {metres:.4g}: a tyre radius in metres, not centimetres"
    v, n = data.get("V"), data.get("N")
    if v is not None and n is not None and units.get("V") == "kph" and units.get("N") == "rpm":
        moving = np.isfinite(v) & np.isfinite(n) & (np.abs(n) > 10.0)
        if moving.any():
            ratio = float(np.median(np.abs(v[moving]) / (np.abs(n[moving]) * np.pi / 30.0)))
            if not 0.1 <= ratio / 3.6 <= 1.5 and 0.1 <= ratio <= 1.5:
                units["V"] = "m/s"
                told["V"] = (f"V / omega is {ratio:.3g} m with V in m/s, {ratio / 3.6:.3g} m "
                             "in km/h: metres per second")
    return units, told


def assumed_units(data: Mapping[str, np.ndarray], missing: str = NO_STRUCT
                  ) -> tuple[dict[str, str], list[str]]:
    """The units of TTC channels read from a file that gives none (a .mat without its channel
    struct, a CSV with the TTC names): the convention (:func:`convention_units`) with the
    channels whose magnitudes show another unit (:func:`magnitude_units`), and the reader
    notes (:func:`reader_note`) that say so; ``missing`` says where the units are missing."""
    units, note = convention_units(data, missing)
    units, told = magnitude_units(data, units)
    return units, [reader_note("channel", note, "units assumed")] + [
        reader_note(name, detail, f"unit taken as {units[name]}") for name, detail in told.items()]


def reader_note(channel: str, detail: str, action: str) -> str:
    """One line of :data:`READER_NOTES`: the channel, what was found, what was done."""
    return "\t".join((channel, detail.replace("\t", " "), action))


def reader_notes(attrs: Mapping[str, str]) -> list[tuple[str, str, str]]:
    """The (channel, detail, action) triples of a run's :data:`READER_NOTES`."""
    lines = str(attrs.get(READER_NOTES, "")).split("\n")
    return [tuple(line.split("\t", 2)) for line in lines if line.count("\t") >= 2]


