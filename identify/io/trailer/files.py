"""Trailer channel files (CSV, HDF5, TYDEX, TTC .mat/.dat) -> tidy tables in SI and ISO-W.

Channels carry TYDEX names (docs/measurement-folder.md): RUNTIME, LONGVEL, WHROTSPD, SLIPANGL,
LONGSLIP, INCLANGL, INFLPRES, FX, FYW, FZW, MXW, MZW, optionally MYW, RLOADED (loaded radius,
needed for TYDEX-C data unless the run declares ``loaded_radius_m``), REFFECT (effective
rolling radius) and the temperatures TTREADI, TTREADC, TTREADO (tread inner, centre, outer),
TROAD and TAMBIENT. Wheel-centre channels may be named FXC .. MZC. A file with the Tire Test
Consortium's names (ET, V, N, SA, IA, SL, P, FX .. MZ, RL, RE, TSTC ...; identify.io.ttc.files) is
read with those names; its default axes are SAE. Units come from the manifest, else from the
file (CSV header ``NAME [unit]``, HDF5 ``units`` attribute, TYDEX unit column, TTC channel
list), else SI (a TTC channel without a unit is a problem).

The format is detected from the content: ``**HEADER`` -> TYDEX, the HDF5 signature -> HDF5,
a MATLAB header -> TTC .mat, a ``.dat`` file (or TTC names on line 2) -> TTC .dat, anything
else -> CSV (:func:`~identify.io.trailer.channels.read_channels`, with the channel table, in
identify.io.trailer.channels). :func:`read_trailer` works without a manifest for quick use.

Real-data quirks (repeated time stamps, dropouts, spikes, NaN stretches, implausible channels)
are cleaned by :func:`identify.io.trailer.quirks.clean_run` after the unit and axis conversion and
reported as :class:`~identify.io.trailer.quirks.DataWarning` records (``warnings=`` list).
"""
from __future__ import annotations

from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import pandas as pd

from identify.core.atomic import atomic_write_text
from identify.core.errors import InputError
from identify.core.plausible import LARGEST, judge, judge_channel
from identify.core.units import SI_UNITS
from identify.io.axes import AXES, axes_name, to_iso_w
from identify.io.common import Problems, check_declared
from identify.io.hdf5.channel_files import RawRun, write_hdf5
from identify.io.trailer.channels import (
    ALIASES,
    C_NAMES,
    CHANNELS,
    OPTIONAL_COLUMNS,
    TRAILER_COLUMNS,
    Channels,
    canonical,
    read_channels,
)
from identify.io.trailer.quirks import DataWarning, clean_run, unused_slip_warning
from identify.io.trailer.ttc_rounds import TTC_OPTIONAL, sr_as_kappa, ttc_substitutes
from identify.io.ttc.files import TTC_TO_TYDEX, reader_notes
from identify.io.tydex import TydexChannel, TydexEntry, TydexFile, write_tydex

__all__ = [
    "ALIASES",
    "CHANNELS",
    "OPTIONAL_COLUMNS",
    "TRAILER_COLUMNS",
    "Channels",
    "channels_to_tidy",
    "read_channels",
    "read_trailer",
    "write_channels",
]


def channels_to_tidy(ch: Channels, *, axes: str | None = None,
                     conditions: Mapping[str, float] | None = None,
                     problems: Problems | None = None,
                     warnings: list[DataWarning] | None = None) -> pd.DataFrame | None:
    """The tidy table (:data:`TRAILER_COLUMNS` + present :data:`OPTIONAL_COLUMNS`, SI, ISO-W)
    of one run, with its quirks cleaned (:func:`identify.io.trailer.quirks.clean_run`).

    Parameters
    ----------
    ch : Channels
        The run's channels in SI.
    axes : {"ISO-W", "SAE", "TYDEX-C"}, optional
        The data's axis system; default: what the file declares, else TYDEX-C when C-axis
        channels (FYC ...) are present, else SAE for TTC channel names, else ISO-W.
    conditions : mapping, optional
        Declared ``pressure_Pa`` and ``load_N`` (medians further than 15 % are problems) and
        ``loaded_radius_m`` (for TYDEX-C without an RLOADED channel).
    problems : Problems, optional
        Collector; strict by default.
    warnings : list, optional
        Receives a :class:`~identify.io.trailer.quirks.DataWarning` per quirk found and cleaned.
        ``ch``'s arrays are never changed; the table shares those the cleaning leaves as read.
    """
    problems = Problems.or_strict(problems)
    conditions = conditions or {}
    start = problems.total
    ttc = ch.ttc
    c_names = sorted(n for n in ch.data if n in C_NAMES and not ttc)
    declared = axes_name(ch.axes) or ch.axes  # an HDF5 attribute in any case
    axes = axes_name(axes) or axes
    if axes is None:
        axes = declared or ("TYDEX-C" if c_names else "SAE" if ttc else "ISO-W")
    elif declared and declared != axes:
        problems.add(ch.file, f"the file declares axes '{ch.axes}', the manifest '{axes}'",
                     key=ch.run)
    if axes not in AXES:
        problems.add(ch.file, f"unknown axis system '{axes}' (expected one of: "
                              f"{', '.join(AXES)})", key=ch.run)
        return None
    if c_names and axes != "TYDEX-C":
        problems.add(ch.file, f"a wheel-centre (C-axis) channel, but the run's axes are "
                              f"'{axes}' (use TYDEX-C)", key=c_names[0])
    by_canon: dict[str, list[str]] = {}
    for name in ch.data:
        canon = canonical(name, ttc)
        if canon:
            by_canon.setdefault(canon, []).append(name)
    file_names = {canon: canon for canon in CHANNELS}  # tidy column -> name in the file
    if ttc:
        file_names.update({v: k for k, v in TTC_TO_TYDEX.items()})
    cols: dict[str, np.ndarray] = {}
    names: dict[str, str] = {}
    notes = ttc_substitutes(ch, by_canon) if ttc else []
    notes += [((name,), detail, action) for name, detail, action in reader_notes(ch.attrs)]
    for canon, (col, _, _, required) in CHANNELS.items():
        found = sorted(by_canon.get(canon, []),
                       key=lambda n: (n not in C_NAMES) if axes == "TYDEX-C" else 0)
        if found:
            cols[col], names[col] = ch.data[found[0]], found[0]
        elif ttc and canon in TTC_OPTIONAL:  # older TTC rounds: the wheel speed is missing
            notes.append(((file_names[canon],), TTC_OPTIONAL[canon], "channel absent"))
        elif required or (axes == "TYDEX-C" and canon == "MYW"):
            problems.add(ch.file, "missing required channel" + (
                " (TYDEX-C data need My to compute Mz at the contact point)"
                if canon == "MYW" else ""), key=file_names[canon])
    # a required channel in the file without one value is no channel (a TTC file's empty
    # channel is a warning of its own, ttc_substitutes, but its conditions are required)
    for col in _CONDITIONS if ttc else _REQUIRED:
        if col in cols and not np.isfinite(cols[col]).any():
            problems.add(ch.file, f"no finite value (all {cols[col].size} samples are "
                                  "NaN/inf)", key=names[col])
    rl = cols.get("rl")
    if axes == "TYDEX-C":
        rl = rl if rl is not None else conditions.get("loaded_radius_m")
        if rl is None:
            problems.add(ch.file, "TYDEX-C data need the loaded radius: an RLOADED channel "
                                  "or conditions.loaded_radius_m", key="RLOADED")
    if problems.total > start:
        return None
    n = cols["t"].size
    extra = [c for c in OPTIONAL_COLUMNS if c in cols]
    frame = pd.DataFrame({c: cols.get(c, np.full(n, np.nan)) for c in TRAILER_COLUMNS[1:]
                          + tuple(extra)}, copy=False)  # one block per channel is faster
    frame.insert(0, "run", ch.run)
    frame = to_iso_w(frame, axes, loaded_radius=rl)
    cleaned = clean_run(frame, file=ch.file, run=ch.run, names=names,
                        first_line=ch.first_line)
    if warnings is not None:
        warnings.extend(cleaned.warnings)
        warnings.extend(DataWarning(ch.file, ch.run, "channel", which, n, n, detail, action)
                        for which, detail, action in notes)
        sr = unused_slip_warning(ch.data["SR"], file=ch.file, run=ch.run, channel="SR") \
            if ttc and "SR" in ch.data else None
        warnings.extend([sr] if sr else [])
        if ch.attrs.get("cut_row"):  # a .dat file cut short inside its last row
            warnings.append(DataWarning(ch.file, ch.run, "truncated", tuple(ch.data)[:1], 1,
                                        n + 1, ch.attrs["cut_row_detail"], "row dropped",
                                        int(ch.attrs["cut_row"])))
    for col, message, row in cleaned.errors:
        where = ({"line": ch.first_line + row} if ch.first_line is not None and row is not None
                 else {})
        problems.add(ch.file, message, key=names.get(col, col), **where)
    if cleaned.frame is None:
        return None
    frame = cleaned.frame
    if names.get("kappa") == "SR":  # SR's zero is not free rolling: take its offset off
        frame, detail = sr_as_kappa(frame)
        if warnings is not None:
            warnings.append(DataWarning(ch.file, ch.run, "channel", ("SR",), n, n, detail,
                                        "used as kappa"))
    # one median per channel (each costs a sort of the channel): the cleaned
    # required channels are finite, so the median is that of the finite samples the checks want
    medians = {c: float(np.median(frame[c].to_numpy())) for c in ("p", "Fz", "Vx")}
    _plausible(frame, ch, names, problems, warnings, medians)
    check_declared(problems, ch.file, names.get("p", "INFLPRES"), frame["p"].to_numpy(),
                   conditions.get("pressure_Pa"), "pressure", "Pa", median=medians["p"])
    fz = medians["Fz"]
    check_declared(problems, ch.file, names.get("Fz", "FZW"), frame["Fz"].to_numpy(),
                   conditions.get("load_N"), "load Fz", "N", median=fz)
    if "load_N" not in conditions and fz < 0:
        problems.add(ch.file, _negative_load(fz, axes), key=names.get("Fz", "FZW"))
    elif "load_N" not in conditions and fz == 0:
        problems.add(ch.file, "median Fz is 0 N: the tyre carries no load",
                     key=names.get("Fz", "FZW"))
    return frame if problems.total == start else None


def _negative_load(fz: float, axes: str) -> str:
    """Why a run whose median load ``fz`` [N] (ISO-W) is negative is refused, in the file's
    own ``axes``: in SAE a loaded tyre's FZ is negative, so such a file has a positive one
    (a conversion script that made the load positive)."""
    if axes == "SAE":
        return (f"median FZ is positive ({-fz:.6g} N), but in SAE axes (those of a TTC file) a "
                "loaded tyre's FZ is negative: a file converted to a positive load? --axes "
                "names the axis system of a converted file")
    return (f"median Fz is negative ({fz:.6g} N): in {axes} Fz is positive up (are the axes "
            "right? --axes names them)")


#: Tidy columns of the required channels: a file that has one of them with no finite value
#: is refused (a force or moment without a value would leave its stages silently unfitted).
_REQUIRED = tuple(col for col, _, _, required in CHANNELS.values() if required)
#: The conditions among them, which every stage selects by: required in a TTC file too.
_CONDITIONS = ("t", "Vx", "alpha", "gamma", "p", "Fz")
#: Tidy column -> quantity of identify.core.plausible, checked on the cleaned SI table.
_PLAUSIBLE = (("p", "pressure"), ("Fz", "load"), ("Vx", "speed"), ("alpha", "angle"),
              ("gamma", "angle"), ("kappa", "slip"), ("Fx", "force"), ("Fy", "force"),
              ("Mx", "moment"), ("My", "moment"), ("Mz", "moment"),
              ("t", "time"))


def _plausible(frame: pd.DataFrame, ch: Channels, names: Mapping[str, str],
               problems: Problems, warnings: list[DataWarning] | None,
               medians: Mapping[str, float]) -> None:
    """The plausibility checks of one run, after the unit and axis conversion (SI, ISO-W);
    ``medians`` [SI] of the channels judged on their median, when known."""
    t = frame["t"].to_numpy()
    step = (float(np.median(np.diff(t))) if t.size > 1 else None)
    refused = set()  # one error per channel: a time stamp of 1e300 s is not also a step
    for col, quantity in _PLAUSIBLE + (("t", "time_step"),):
        if col not in frame.columns or col in refused or (col == "Fz" and medians["Fz"] <= 0):
            continue  # a load <= 0 has its own message below (the axes, or no load)
        if quantity == "time_step":
            finding = None if step is None else judge(quantity, step,
                                                      what="median time step")
            found = None if finding is None else (finding, None)
        else:
            found = judge_channel(quantity, frame[col].to_numpy(), median=(
                None if quantity in LARGEST else medians.get(col)))
        if found is None:
            continue
        finding, row = found
        line = None if row is None or ch.first_line is None else ch.first_line + row
        name = names.get(col, col)
        if finding.is_error:
            refused.add(col)
            problems.add(ch.file, finding.message, key=name,
                         **({"line": line} if line is not None else {}))
        elif warnings is not None:
            warnings.append(DataWarning(ch.file, ch.run, "plausible", (name,), len(frame),
                                        len(frame), finding.message, "kept", line))


def read_trailer(path: str | Path, *, run: str | None = None, axes: str | None = None,
                 units: Mapping[str, str] | None = None,
                 conditions: Mapping[str, float] | None = None,
                 warnings: list[DataWarning] | None = None) -> pd.DataFrame:
    """Read a trailer file into one tidy table (all its runs), raising on the first problem.

    See :func:`read_channels` and :func:`channels_to_tidy` for the arguments; the warnings of
    the cleaning go to ``warnings`` when given.
    """
    runs = read_channels(path, run=run, units=units)
    frames = [channels_to_tidy(ch, axes=axes, conditions=conditions, warnings=warnings)
              for ch in runs]
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
        CHANNELS[canonical(n)][1] if canonical(n) else "", "")) else f"{n} [{ch.units[n]}]"
            for n in names]
    text = "\n".join([",".join(head)] + [",".join(map(repr, row)) for row in rows]) + "\n"
    return atomic_write_text(path, text)
