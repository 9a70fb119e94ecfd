"""``discover_folder``: a measurement folder in, ``fits/<tyre id>/discovery/`` out.

Outputs (each written atomically): ``discovery.json`` (schema in
:mod:`identify.discover.result`), ``discovery.pdf`` (:mod:`identify.report.discovery`), the
enriched ``<tyre id>.tir`` (the base .tir with the discovery's one model state: every key some
problem fits or tests, from the problem that owns it, :mod:`identify.discover.state`) and
``fit.json``
(the final fits, ``mfid.fit/2`` layout). The measurement folder is only read.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from identify.core.atomic import atomic_write_text
from identify.core.errors import InputError
from identify.core.jsonsafe import json_text
from identify.core.names import name_problem
from identify.core.progress import Progress
from identify.core.version import __version__
from identify.discover.library import load_library
from identify.discover.problems import (
    Base,
    apply_base,
    base_values,
    relation_problems,
    select,
    trailer_problems,
)
from identify.discover.result import Discovery
from identify.discover.search import Settings, discover
from identify.extract import extract_folder
from identify.fit.relations.problems import Context
from identify.fit.run import JSON_NAME, FitRun, Provenance, failures
from identify.fit.sources import KeySource
from identify.io.fitdir import write_fit_json
from identify.io.folder import load_folder
from identify.io.output_guard import Inputs, check_files_in, check_folder_output, measurement_inputs
from identify.io.tir import read_tir, write_tir
from identify.io.tir.write import source_text
from identify.model.parameters import spec
from identify.report.discovery import write_pdf
from identify.segment import SegmentSettings, segment_trailer
from identify.simulate import default_tir_path
from identify.workflows.trailer_prep import SEGMENTED_SUFFIXES

__all__ = ["DiscoveryRun", "discover_folder", "start_tir"]


@dataclass(frozen=True)
class DiscoveryRun:
    """What :func:`discover_folder` wrote.

    Attributes
    ----------
    out_dir : Path
    json_path, pdf_path, tir_path, fit_json_path : Path
    discovery : Discovery
    notes : tuple of str     data the run could not use, and why
    fit_run : FitRun or None the final fits as written to fit.json
    """

    out_dir: Path
    json_path: Path
    pdf_path: Path
    tir_path: Path
    fit_json_path: Path
    discovery: Discovery
    notes: tuple[str, ...] = ()
    fit_run: FitRun | None = None


def start_tir(mset, base_tir: str | Path | None) -> tuple[dict, int]:
    """(numeric .tir values, FITTYP): the given base .tir, or the bundled 225/50 R17 tyre with
    the folder's nominal load, pressure and radius (start values of the MF coefficients)."""
    tirfile = read_tir(base_tir if base_tir is not None else default_tir_path())
    t = {k: float(v) for k, v in tirfile.params().items() if isinstance(v, (int, float))}
    if base_tir is None:
        tyre = mset.manifest.tyre
        t["FNOMIN"] = float(tyre.nominal_load_N)
        t["NOMPRES"] = t["INFLPRES"] = float(tyre.nominal_pressure_Pa)
        if tyre.unloaded_radius_m and math.isfinite(tyre.unloaded_radius_m):
            t["UNLOADED_RADIUS"] = float(tyre.unloaded_radius_m)
    return t, int(tirfile.fittyp)


class _NoRuns:
    """A measurement set seen without its raw Flatplank runs and tables (``--only MF``)."""

    def __init__(self, mset):
        self.flatplank = None
        self.characteristics = None


def _characteristics(mset, notes: list[str]):
    frames = []
    if mset.flatplank is not None and len(mset.flatplank):
        try:
            frames.append(extract_folder(mset).characteristics)
        except (AttributeError, NotImplementedError) as exc:
            notes.append(f"raw Flatplank runs not used: extraction unavailable ({exc})")
    if mset.characteristics is not None and len(mset.characteristics):
        frames.append(mset.characteristics)
    chars = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame(
        columns=["quantity", "pi_bar", "Fz_N", "value", "unit"])
    if len(chars) and ("p_Pa" not in chars or chars["p_Pa"].isna().any()):
        chars["p_Pa"] = chars["pi_bar"] * 1e5
    return chars


def sweeps_only(trailer: pd.DataFrame | None, notes: list[str],
                continuous: tuple[str, ...] | frozenset = ()) -> pd.DataFrame | None:
    """The samples of ``trailer`` inside sweeps (:func:`identify.segment.segment_trailer`,
    no revolution averaging or binning: every sample keeps its own values) when the table is
    a continuous log of a session: its runs named in ``continuous`` (the session files
    ``mfid fit`` segments too, :data:`identify.workflows.trailer_prep.SEGMENTED_SUFFIXES`),
    or recognised by their warm-ups; else the table as it is (a folder of test runs, whose
    steady camber and rolling-resistance runs are no sweeps).

    A TTC session holds warm-ups, transitions and stops the Magic Formula does not describe:
    fitted as they are, they made a 40 % base error and a 32 % noise floor on MF/Fy of a
    generated session and hid the pressure effects in it. A real session whose warm-ups the
    segmentation does not recognise as such is still a session log: taken whole, its load and
    pressure ramps became sweeps of their own at one pressure each, and discovery saw another
    design than ``mfid fit`` on the same folder."""
    if trailer is None or trailer.empty or "t" not in trailer:
        return trailer
    named = trailer["run"].astype(str).isin(set(continuous)).to_numpy() \
        if "run" in trailer and continuous else np.zeros(len(trailer), dtype=bool)
    seg = segment_trailer(trailer, SegmentSettings(revolution_average=False))
    warm = any(g.kind == "warmup" for g in seg.segmentation.segments)
    if warm or named.all():
        kept, parts = seg.table, len(trailer)
    elif named.any():
        kept = segment_trailer(trailer[named], SegmentSettings(revolution_average=False)).table
        parts = int(named.sum())
    else:
        return trailer
    if kept.empty:
        return trailer
    notes.append(f"trailer: {len(kept)} of {parts} samples of the session logs in sweeps "
                 f"(identify.segment); warm-ups, transitions and stops left out")
    kept = kept.drop(columns=["sweep"]).rename(columns={"segment": "segment_id"})
    if parts == len(trailer):
        return kept
    rest = trailer[~named].copy()
    rest["segment_id"] = np.nan  # label_sweeps splits these by time, run and load
    return pd.concat([kept, rest], ignore_index=True)


def _enriched(tir: dict, d: Discovery) -> tuple[dict, dict]:
    """(the .tir values, key -> source): the base .tir with every key of the discovery's one
    model state (each from the problem that owns it; identify.discover.state)."""
    out, sources = dict(tir), {}
    vals = dict(d.state)
    if "YAW_STIFFNESS" in vals and d.sources.get("YAW_STIFFNESS") == "CMz":
        # T1 nested in T2 (identify.discover.problems.cmz_problem) -> the .tir's CMz form
        t2 = abs(vals.get("PCMZ2", 0.0)) > 0
        pcmz1 = vals.pop("PCMZ1", 0.0)
        cmz = {"YAW_STIFFNESS": vals.pop("YAW_STIFFNESS"), "CMZ_FORM": 2.0 if t2 else 1.0,
               "PCMZ1": 1.0 if t2 else pcmz1, "PCMZ2": vals.pop("PCMZ2", 0.0) if t2 else 0.0,
               "PCMZ3": pcmz1 if t2 else 0.0}
        vals.pop("PCMZ2", None)
        out.update(cmz)
        sources.update({k: source_text("mfid discover", "CMz") for k in cmz})
    for k, v in vals.items():
        try:
            if spec(k).is_string or not spec(k).vary:
                continue
        except KeyError:
            continue
        out[k] = float(v)
        sources[k] = source_text("mfid discover", d.sources.get(k, ""))
    return out, sources


def discover_folder(source: str | Path, *, base_tir: str | Path | None = None,
                    base_form: str | None = None, candidates: str | Path | None = None,
                    settings: Settings = Settings(), out_dir: str | Path | None = None,
                    out_root: str | Path = "fits", only: tuple[str, ...] = (),
                    command: str = "", progress: Progress | None = None) -> DiscoveryRun:
    """Run discovery on a measurement folder and write the outputs.

    Raises
    ------
    InputError
        Bad folder, .tir, candidates file or form name, or nothing to discover (exit 2).
    """
    say = progress or (lambda s: None)
    if base_tir is not None and base_form is not None:
        raise InputError(None, "give --base or --base-form, not both", key="--base-form")
    library = load_library(candidates)
    say(f"load: {source}")
    mset = load_folder(source)
    tyre = mset.manifest.tyre
    bad_id = name_problem(tyre.id)
    if bad_id:  # load_folder refuses it; a second lock on the output paths
        raise InputError(mset.manifest.path, bad_id, key="tyre.id")
    out = Path(out_dir) if out_dir is not None else Path(out_root) / tyre.id / "discovery"
    # before any work: never into the measurement folder, nor over the base or candidates
    check_folder_output(out, measurement_inputs(source) + Inputs.of(
        files=(base_tir, candidates)), key="--out")
    check_files_in(out, ("discovery.json", "discovery.pdf", f"{tyre.id}.tir", JSON_NAME),
                   key="--out")
    tir0, fittyp = start_tir(mset, base_tir)
    if base_form is not None:
        if base_form not in library.forms:
            raise InputError(None, f"unknown base form {base_form!r}; choose from "
                                   f"{', '.join(sorted(library.forms))}", key="--base-form")
        base = Base("form", base_form, library.forms[base_form])
    else:
        base = Base("tir", str(base_tir)) if base_tir is not None else Base()
    tir = base_values(tir0, base, library)
    notes: list[str] = []
    wants_tables = not only or any(not p.startswith("MF") for p in only)
    chars = _characteristics(mset, notes) if wants_tables else _characteristics(
        _NoRuns(mset), notes)
    ctx = Context(fz0=float(tir["FNOMIN"]), p0_bar=float(tir["NOMPRES"]) / 1e5, tir=tir)
    tests = {r.id: r.test for r in mset.manifest.runs}
    relations = relation_problems(chars, ctx)
    has_rr = any(p.extra.get("name") == "RR" for p in relations)
    # model-state order (identify.discover.state): the trailer's MF stages own the keys they
    # fit, as in `mfid fit`; the relations read them
    continuous = frozenset(r.id for r in mset.manifest.runs if r.kind == "trailer"
                           and Path(r.file).suffix.lower() in SEGMENTED_SUFFIXES)
    trailer = sweeps_only(mset.trailer, notes, continuous)
    problems = trailer_problems(trailer, tir, ctx, tests, with_rr=not has_rr) + relations
    if base.form is not None:
        problems = [p for p in problems if base.form.selects(p.extra["name"])]
    problems = [apply_base(p, base, library, tir) for p in select(problems, tuple(only))]
    if not problems:
        raise InputError(mset.path, "nothing to discover: no trailer sweeps and no "
                                    "characteristics of a known quantity"
                                    + (" for --only/--base-form" if only or base_form else ""))
    say(f"discover: {len(problems)} problem(s): "
        + ", ".join(p.extra["name"] for p in problems))
    d = discover(problems, library, settings,
                 base={**base.to_dict(), "tir": str(base_tir) if base_tir else "bundled"},
                 progress=say)
    out = Path(out_dir) if out_dir is not None else Path(out_root) / tyre.id / "discovery"
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(out, f"cannot create output folder: {exc.strerror or exc}") from None
    provenance = Provenance.now(command=command, seed=settings.seed, settings=None,
                                checksums=mset.checksums, folder=mset.path)
    recorded = {k: v for k, v in provenance.to_dict().items() if k != "settings"}
    doc = {**d.to_dict(), "tyre": tyre.to_dict(), "provenance": recorded,
           "notes": notes + list(d.notes)}
    json_path = atomic_write_text(out / "discovery.json", json_text(doc))
    pdf_path = write_pdf(d, out / "discovery.pdf")
    enriched, sources = _enriched(tir, d)
    tir_path = write_tir(out / f"{tyre.id}.tir", enriched, fittyp=fittyp, sources=sources,
                         comment_lines=[f"mfid discover {__version__}: base {base.kind} "
                                        f"{base.name}".rstrip(),
                                        "accepted: " + (", ".join(a.name for a in d.accepted)
                                                        or "none")])
    results = tuple(p.fit for p in d.problems if p.fit is not None)
    key_sources = {k: KeySource.fitted(f"mfid discover {d.sources.get(k, 'CMz')}")
                   for k in sources}
    run = FitRun(tyre=tyre, provenance=provenance, results=results, key_sources=key_sources,
                 fittyp=fittyp, tir_name=Path(tir_path).name, failed=failures(results),
                 tir_values=enriched)
    fit_json = write_fit_json(run, out / "fit.json")
    return DiscoveryRun(out, json_path, pdf_path, Path(tir_path), fit_json, d, tuple(notes),
                        dataclasses.replace(run, fit_dir=out))

