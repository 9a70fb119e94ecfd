"""``import_session``: trailer files (a TTC session, plain CSV/HDF5/TYDEX) -> a measurement folder.

No manifest is written by hand: everything the folder's ``tyre.toml`` says comes from the files
or from a stated rule.

- Tyre id: ``--id``, else the files' ``tireid`` (TTC .mat), else the ``--out`` folder's name
  (a TTC ``.dat`` carries no tireid; a note says where the id came from), made a safe file
  name (letters, digits, ``.``, ``_``, ``-``; other runs of characters become one ``-``).
- Runs: every run of every file (an HDF5 file may hold several); the same data given twice (a
  TTC run's ``.mat`` and ``.dat``) is imported once, from the ``.mat`` (exact values).
- Test of each run, from its content (identify.segment): slip-angle sweeps only ->
  ``cornering`` (camber steps included); slip-ratio sweeps, all at a zero set slip angle ->
  ``braking_driving``; slip-ratio sweeps at a non-zero set slip angle (or both kinds of sweep)
  -> ``combined``; no sweep but a moving inclination -> ``camber``; nothing swept -> free
  rolling, ``rolling_resistance``.
- Nominal pressure: the middle pressure level of all runs (the lower middle of an even number),
  rounded to 100 Pa; nominal load: the middle load level, rounded to 10 N (a TTC programme's
  load steps centre on the tyre's rated load). Unloaded radius: the loaded radius RL of the
  sweeps at the nominal pressure extrapolated to zero load (least-squares line RL(Fz)), rounded
  to 0.1 mm; without an RL channel it must be given.
- Units and axes: each run's ``units`` (every channel's unit as the file or ``--units`` gives
  it) and ``axes`` (the file's own, SAE for TTC, else ``--axes``, else ISO-W) are recorded.

The files are copied byte for byte into ``<out>/trailer/`` (never modified: their SHA-256 is
taken before and after, and recorded under ``[provenance]``); the folder is built in a
temporary directory and renamed into place when complete.
"""
from __future__ import annotations

import re
import shutil
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pandas as pd

from identify.core.atomic import replace_dir, temp_dir
from identify.core.errors import InputError
from identify.core.names import safe_name
from identify.core.progress import Progress
from identify.core.tyre_size import find_tyre_size
from identify.core.version import __version__
from identify.io.common import Problems, sha256_file
from identify.io.manifest import MANIFEST_NAME
from identify.io.trailer.files import CHANNELS, Channels, channels_to_tidy, read_channels
from identify.io.trailer.quirks import DataWarning
from identify.io.ttc.files import TTC_TO_TYDEX
from identify.segment import Segmentation, segment_trailer
from identify.simulate.manifest import toml_value

__all__ = ["ImportResult", "ImportedRun", "classify_run", "import_session", "safe_id",
           "tyre_model"]


@dataclass(frozen=True)
class ImportedRun:
    """One run of the folder: its id, file (relative), source file, test, axes, units."""

    id: str
    file: str
    source: str
    test: str
    axes: str
    units: Mapping[str, str]
    samples: int
    sweeps: int


@dataclass(frozen=True, eq=False)
class ImportResult:
    """What :func:`import_session` wrote and how it decided."""

    path: Path
    tyre_id: str
    nominal_pressure_Pa: float
    nominal_load_N: float
    unloaded_radius_m: float
    runs: tuple[ImportedRun, ...]
    warnings: tuple[DataWarning, ...]
    segmentation: Segmentation
    notes: tuple[str, ...] = field(default=())


def safe_id(text: str) -> str:
    """A safe file name from a tyre id: ``"Hoosier 18.0x6.0-10 R25B"`` ->
    ``"Hoosier-18.0x6.0-10-R25B"`` (:func:`identify.core.names.safe_name`)."""
    return safe_name(text)


def classify_run(seg: Segmentation, run: str, gamma_span: float) -> str:
    """The manifest test of a run from its sweeps (see the module notes; a sweep at a level
    of its own, ``isolated``, counts too: a file may hold a single sweep)."""
    sweeps = [s for s in seg.segments if s.run == run and s.kind in ("sweep", "isolated")]
    kinds = {s.sweep for s in sweeps}
    if "kappa" in kinds:
        alphas = [s.medians.get("alpha", 0.0) for s in sweeps if s.sweep == "kappa"]
        if "alpha" in kinds or any(abs(a) > np.deg2rad(1.0) for a in alphas):
            return "combined"
        return "braking_driving"
    if "alpha" in kinds:
        return "cornering"
    return "camber" if gamma_span > np.deg2rad(1.0) else "rolling_resistance"


#: A specimen number at the end of a tireid (``"Hoosier 20.5x7.0-13 -- Tire 37"``): the TTC
#: tests several specimens of one tyre model, one per run or programme.
_SPECIMEN = re.compile(r"[\s,;:/-]*(?:tire|tyre|specimen|sample)\s*(?:no\.?|#)?\s*\d+\s*$",
                       re.IGNORECASE)


def tyre_model(tireid: str) -> str:
    """The tyre model of a tireid, without a trailing specimen number (see :data:`_SPECIMEN`)."""
    return _SPECIMEN.sub("", tireid).strip() or tireid.strip()


def _middle(values: Sequence[float]) -> float:
    ordered = sorted(values)
    return float(ordered[(len(ordered) - 1) // 2])


#: A pressure level is the programme's baseline when it holds this share more swept
#: samples than any other level [-].
BASELINE_MARGIN = 1.25


def _baseline_pressure(table: pd.DataFrame, p_levels: Sequence[float]) -> tuple[float, str]:
    """The nominal pressure [Pa, rounded to 100 Pa] and how it was chosen.

    A test programme runs most of its sweeps at the tyre's baseline pressure and visits the
    others for the pressure effect (a TTC round: 12 psi with 8, 10, 14 psi runs): the level
    with clearly the most swept samples (:data:`BASELINE_MARGIN`) is the nominal pressure,
    the one the pressure relations and the .tir's NOMPRES are centred on. Without a clear
    majority, the middle level (the lower middle of an even number).
    """
    if "p_level" in table and len(p_levels) > 1:
        counts = table["p_level"].value_counts()
        counts = counts[counts.index.isin(p_levels)].sort_values(ascending=False)
        if len(counts) > 1 and counts.iloc[0] >= BASELINE_MARGIN * counts.iloc[1]:
            share = counts.iloc[0] / counts.sum()
            return (round(float(counts.index[0]), -2),
                    f"the level with the most swept samples ({100 * share:.0f} %) of the "
                    "pressure levels")
    return round(_middle(p_levels), -2), "the middle of the pressure levels"


def _unloaded_radius(table: pd.DataFrame, p_level: float) -> float:
    rows = table[(table["p_level"] == p_level)] if "p_level" in table else table
    if "rl" not in rows or rows["rl"].notna().sum() < 10:
        return float("nan")
    ok = rows["rl"].notna() & rows["Fz"].notna()
    _, intercept = np.polyfit(rows.loc[ok, "Fz"], rows.loc[ok, "rl"], 1)
    return float(intercept)


def _effective_radius_at_zero_load(table: pd.DataFrame, p_level: float) -> float:
    """The effective rolling radius V / omega of the free-rolling samples (|alpha| < 1 deg,
    |kappa| < 0.01, |Fx| < 2 % of Fz) at the pressure level, extrapolated to zero load [m].

    At zero load the effective and the unloaded radius are one (the MF effective radius
    falls from R0 with the deflection), so the line Re(Fz) meets R0 at Fz = 0.
    """
    need = ("Vx", "omega", "alpha", "kappa", "Fx", "Fz")
    if any(c not in table for c in need):
        return float("nan")
    # the loaded samples as read (the segmented table keeps no wheel speed), within 5 % of
    # the pressure level
    near = (table["p"] - p_level).abs() < 0.05 * p_level
    rows = table[near] if near.any() and table.loc[near, "omega"].notna().sum() >= 50 else table
    v, w = rows["Vx"].to_numpy(float), rows["omega"].to_numpy(float)
    fz = rows["Fz"].to_numpy(float)
    free = (np.abs(rows["alpha"].to_numpy(float)) < np.deg2rad(1.0)) \
        & (np.abs(rows["kappa"].to_numpy(float)) < 0.01) \
        & (np.abs(rows["Fx"].to_numpy(float)) < 0.02 * np.abs(fz)) \
        & (np.abs(w) > 1.0) & (fz > 0) & np.isfinite(v) & np.isfinite(w)
    if free.sum() < 50 or np.ptp(fz[free]) < 0.2 * np.median(fz[free]):
        return float("nan")  # too few samples, or one load: no line to extrapolate
    _, intercept = np.polyfit(fz[free], np.abs(v[free] / w[free]), 1)
    return float(intercept)


def _radius_at_zero_load(table: pd.DataFrame, loaded: pd.DataFrame, p_level: float,
                         tireids: Sequence[str]) -> tuple[float, str]:
    """The unloaded radius [m] and how it was found (``table`` segmented, ``loaded`` as
    read): the loaded radius RL extrapolated to zero load, else the effective radius V / omega
    extrapolated to zero load, else the nominal radius of the tyre size in the tireid; NaN
    when none is at hand."""
    radius = round(_unloaded_radius(table, p_level), 4)
    if np.isfinite(radius) and radius > 0:
        return radius, "RL extrapolated to zero load at the nominal pressure"
    radius = round(_effective_radius_at_zero_load(loaded, p_level), 4)
    if np.isfinite(radius) and radius > 0:
        return radius, ("no usable loaded radius RL: the effective radius V / omega of the "
                        "free-rolling samples extrapolated to zero load at the nominal pressure")
    size = next((s for s in map(find_tyre_size, tireids) if s is not None), None)
    if size is not None:
        return round(size.unloaded_radius_m, 4), (
            f"no usable loaded radius RL or wheel speed: the nominal radius of the size "
            f"{size.text!r} in the tireid")
    return float("nan"), ""


def _same_run(a: pd.DataFrame, b: pd.DataFrame) -> bool:
    """True when two tables are one run read twice (a TTC run's .mat and .dat): the same
    time span (to the .dat's 0.01 s), sample count (to 0.1 %) and median load (to 1 N)."""
    ta, tb = a["t"].to_numpy(), b["t"].to_numpy()
    return (abs(ta[0] - tb[0]) < 0.011 and abs(ta[-1] - tb[-1]) < 0.011
            and abs(len(a) - len(b)) <= 0.001 * len(a)
            and abs(float(a["Fz"].median()) - float(b["Fz"].median())) < 1.0)


def _manifest(tyre_id: str, pressure: float, load: float, radius: float,
              runs: Sequence[ImportedRun], sources: Mapping[str, str],
              command: str) -> str:
    lines = ["# Measurement folder written by `mfid import` (identify.workflows.import_session).",
             "# Nominal pressure: the middle pressure level; nominal load: the middle load",
             "# level; unloaded radius: RL extrapolated to zero load (or as given).",
             "[tyre]", f"id = {toml_value(tyre_id)}",
             f"nominal_pressure_Pa = {toml_value(pressure)}",
             f"nominal_load_N = {toml_value(load)}", f"unloaded_radius_m = {toml_value(radius)}",
             'source = "measured"']
    for r in runs:
        lines += ["", "[[runs]]", f"id = {toml_value(r.id)}", f"file = {toml_value(r.file)}",
                  'kind = "trailer"', f"test = {toml_value(r.test)}",
                  f"axes = {toml_value(r.axes)}"]
        if r.units:
            lines.append(f"units = {toml_value(dict(r.units))}")
    lines += ["", "[provenance]", f"mfid_version = {toml_value(__version__)}",
              f"command = {toml_value(command)}", "[provenance.sha256]"]
    lines += [f"{toml_value(name)} = {toml_value(digest)}" for name, digest in sources.items()]
    return "\n".join(lines) + "\n"


def _units(ch: Channels) -> dict[str, str]:
    """The units of the channels mfid reads, as the file gave them (recorded in the run)."""
    known = set(CHANNELS) | (set(TTC_TO_TYDEX) if ch.ttc else set())
    return {k: v for k, v in ch.file_units.items() if k in known}


def import_session(files: Sequence[str | Path], out: str | Path, *,
                   tyre_id: str | None = None, nominal_pressure_Pa: float | None = None,
                   nominal_load_N: float | None = None, unloaded_radius_m: float | None = None,
                   units: Mapping[str, str] | None = None, axes: str | None = None,
                   overwrite: bool = False, command: str = "mfid import",
                   progress: Progress | None = None) -> ImportResult:
    """Import trailer files into a new measurement folder ``out`` (see the module notes).

    Raises
    ------
    InputError
        A file that cannot be used (one line naming file and channel), no tyre id, no way to
        the unloaded radius, or an occupied ``out``.
    """
    say = progress or (lambda text: None)
    out = Path(out)
    paths = [Path(f) for f in files]
    if not paths:
        raise InputError(None, "no input files")
    for p in paths:
        if not p.is_file():
            raise InputError(p, "no such file" if not p.exists() else "not a file")
    if out.exists() and (not out.is_dir() or (any(out.iterdir()) and not overwrite)):
        raise InputError(out, "exists and is not an empty folder (use --overwrite)")
    before = {p: sha256_file(p) for p in paths}
    order = sorted(paths, key=lambda p: p.suffix.lower() != ".mat")  # .mat before .dat
    kept: list[tuple[Path, Channels, pd.DataFrame]] = []
    warnings: list[DataWarning] = []
    notes: list[str] = []
    for p in order:
        say(f"read {p}")
        for ch in read_channels(p, units=units, problems=Problems(strict=True)):
            found: list[DataWarning] = []
            frame = channels_to_tidy(ch, axes=axes, warnings=found)
            twin = next((q for q, _, f in kept if _same_run(f, frame)), None)
            if twin is not None:
                notes.append(f"{p}: the same data as {twin}: not imported twice")
                continue
            warnings += found
            kept.append((p, ch, frame))
    ids = [ch.run for _, ch, _ in kept]
    if len(set(ids)) != len(ids):
        dup = next(i for i in ids if ids.count(i) > 1)
        raise InputError(None, f"two runs are named '{dup}': rename one of the files")
    tireids = sorted({ch.attrs["tireid"] for _, ch, _ in kept if ch.attrs.get("tireid")})
    models = sorted({tyre_model(t) for t in tireids})
    if len(tireids) > 1 and len(models) == 1:  # specimens of one tyre: one tyre model
        notes.append(f"tireids {', '.join(map(repr, tireids))}: specimens of one tyre, "
                     f"imported as {models[0]!r}")
        tireids = models
    if len(tireids) > 1:  # two tyres in one folder would be fitted as one
        first = {t: next(q for q, ch, _ in kept if ch.attrs.get("tireid") == t) for t in tireids}
        if tyre_id is None:
            raise InputError(first[tireids[1]], f"tireid {tireids[1]!r}, but {first[tireids[0]]}"
                                                f" has {tireids[0]!r}: one tyre per folder (give "
                                                "--id to import them as one tyre)")
        notes.append(f"tireids {', '.join(map(repr, tireids))} imported as one tyre (--id)")
    name = safe_id(tyre_id if tyre_id is not None else (tireids[0] if tireids else ""))
    if tyre_id is not None and not name:
        raise InputError(None, f"{tyre_id!r} makes no tyre id (a file name needs a letter, "
                               "digit, '.', '_' or '-')", key="--id")
    if not name:  # e.g. TTC .dat files: the folder's name, said so
        name = safe_id(out.resolve().name)
        if name:
            notes.append(f"tyre id {name!r}: the --out folder's name (the files carry no "
                         "'tireid'; --id sets another)")
    if not name:
        title = next((ch.attrs["title"] for _, ch, _ in kept if ch.attrs.get("title")), "")
        hint = (f" (a TTC .dat has only its title line: {title[:60]!r})" if title else "")
        raise InputError(None, f"no tyre id: the files carry no 'tireid'{hint} and the --out "
                               "folder's name makes none; give --id", key="--id")
    say("segment: condition levels and sweeps")
    table = pd.concat([f for _, _, f in kept], ignore_index=True)
    seg = segment_trailer(table)
    p_levels = seg.segmentation.level_values("p")
    fz_levels = seg.segmentation.level_values("Fz")
    if nominal_pressure_Pa is None:
        if not p_levels:
            raise InputError(None, "no pressure level found (no sweeps): give "
                                   "--nominal-pressure", key="--nominal-pressure")
        nominal_pressure_Pa, how = _baseline_pressure(seg.table, p_levels)
        notes.append(f"nominal pressure {nominal_pressure_Pa:g} Pa: {how} "
                     f"{', '.join(f'{v:.0f}' for v in p_levels)} Pa")
    if nominal_load_N is None:
        if not fz_levels:
            raise InputError(None, "no load level found (no sweeps): give --nominal-load",
                             key="--nominal-load")
        nominal_load_N = round(_middle(fz_levels), -1)
        notes.append(f"nominal load {nominal_load_N:g} N: the middle of the load levels "
                     f"{', '.join(f'{v:.0f}' for v in fz_levels)} N")
    if unloaded_radius_m is None:
        level = min(p_levels, key=lambda v: abs(v - nominal_pressure_Pa)) if p_levels else 0
        unloaded_radius_m, how = _radius_at_zero_load(seg.table, table, level, tireids)
        if not np.isfinite(unloaded_radius_m) or unloaded_radius_m <= 0:
            raise InputError(None, "no loaded-radius channel (RL), no wheel speed and no "
                                   "tyre size in the tireid to find the unloaded radius "
                                   "from: give --unloaded-radius", key="--unloaded-radius")
        notes.append(f"unloaded radius {unloaded_radius_m:g} m: {how}")
    runs, targets = [], {}
    for p, ch, frame in kept:
        if p not in targets:  # one copy per file (an HDF5 file may hold several runs)
            name_in = p.name if p.name not in targets.values() else f"{len(targets)}-{p.name}"
            targets[p] = name_in
        target = targets[p]
        gamma = frame["gamma"].to_numpy()
        span = float(np.nanpercentile(gamma, 99) - np.nanpercentile(gamma, 1))
        test = classify_run(seg.segmentation, ch.run, span)
        sweeps = sum(1 for s in seg.segmentation.segments
                     if s.run == ch.run and s.kind == "sweep")
        axes_used = axes or ch.axes or ("SAE" if ch.ttc else "ISO-W")
        runs.append(ImportedRun(ch.run, f"trailer/{target}", str(p), test, axes_used,
                                _units(ch), len(frame), sweeps))
    files_written = {r.source: r.file for r in runs}
    digests = {Path(r.file).name: before[Path(r.source)] for r in runs}
    text = _manifest(name, float(nominal_pressure_Pa), float(nominal_load_N),
                     float(unloaded_radius_m), runs, digests, command)
    say(f"write {out}")
    _write(out, text, files_written, overwrite)
    changed = [str(p) for p in paths if sha256_file(p) != before[p]]
    if changed:
        raise InputError(changed[0], "the input file changed while it was imported")
    return ImportResult(out, name, float(nominal_pressure_Pa), float(nominal_load_N),
                        float(unloaded_radius_m), tuple(runs), tuple(warnings),
                        seg.segmentation, tuple(notes))


def _write(out: Path, manifest: str, copies: Mapping[str, str], overwrite: bool) -> None:
    """Build the folder in a temporary directory and rename it into place."""
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = temp_dir(out)
    try:
        (tmp / "trailer").mkdir()
        for source, target in copies.items():
            shutil.copyfile(source, tmp / target)
        (tmp / MANIFEST_NAME).write_text(manifest, encoding="utf-8")
        replace_dir(tmp, out)
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise

