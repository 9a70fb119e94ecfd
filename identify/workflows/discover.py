"""``discover_folder``: a measurement folder in, ``fits/<tyre id>/discovery/`` out.

Outputs (each written atomically): ``discovery.json`` (schema in
:mod:`identify.discover.result`), ``discovery.pdf`` (:mod:`identify.report.discovery`), the
enriched ``<tyre id>.tir`` (base .tir + every fitted and accepted coefficient) and ``fit.json``
(the final fits, ``mfid.fit/1`` layout). The measurement folder is only read.
"""
from __future__ import annotations

import datetime as _dt
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable


from identify.core.version import __version__
from identify.discover.library import load_library
from identify.discover.problems import (Base, apply_base, base_values, relation_problems,
                                        select, trailer_problems)
from identify.discover.result import Discovery
from identify.discover.search import Settings, discover
from identify.core.errors import InputError
from identify.fit.relations import Context
from identify.model.parameters import spec
from identify.io.atomic import atomic_write_text
from identify.io.tir.write import source_text
from identify.core.jsonsafe import json_default

__all__ = ["DiscoveryRun", "discover_folder", "start_tir"]

Progress = Callable[[str], None]


@dataclass(frozen=True)
class DiscoveryRun:
    """What :func:`discover_folder` wrote.

    Attributes
    ----------
    out_dir : Path
    json_path, pdf_path, tir_path, fit_json_path : Path
    discovery : Discovery
    notes : tuple of str     data the run could not use, and why
    """

    out_dir: Path
    json_path: Path
    pdf_path: Path
    tir_path: Path
    fit_json_path: Path
    discovery: Discovery
    notes: tuple[str, ...] = ()


def start_tir(mset, base_tir: str | Path | None) -> tuple[dict, int]:
    """(numeric .tir values, FITTYP): the given base .tir, or the bundled 225/50 R17 tyre with
    the folder's nominal load, pressure and radius (start values of the MF coefficients)."""
    from identify.io.tir import read_tir
    from identify.simulate import default_tir_path

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
    import pandas as pd

    frames = []
    if mset.flatplank is not None and len(mset.flatplank):
        try:
            from identify.extract import extract_folder
            frames.append(extract_folder(mset).characteristics)
        except (ImportError, AttributeError, NotImplementedError) as exc:
            notes.append(f"raw Flatplank runs not used: extraction unavailable ({exc})")
    if mset.characteristics is not None and len(mset.characteristics):
        frames.append(mset.characteristics)
    chars = pd.concat(frames, ignore_index=True) if frames else pd.DataFrame(
        columns=["quantity", "pi_bar", "Fz_N", "value", "unit"])
    if len(chars) and ("p_Pa" not in chars or chars["p_Pa"].isna().any()):
        chars["p_Pa"] = chars["pi_bar"] * 1e5
    return chars


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
    from identify.io.folder import load_folder
    from identify.io.tir import write_tir

    say = progress or (lambda s: None)
    if base_tir is not None and base_form is not None:
        raise InputError(None, "give --base or --base-form, not both", key="--base-form")
    library = load_library(candidates)
    say(f"load: {source}")
    mset = load_folder(source)
    tyre = mset.manifest.tyre
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
    problems = trailer_problems(mset.trailer, tir, ctx, tests, with_rr=not has_rr) + relations
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
    created = _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds")
    provenance = {"mfid_version": __version__, "created_utc": created, "command": command,
                  "seed": settings.seed, "inputs": [{"path": str(Path(mset.path) / k),
                                                     "sha256": v}
                                                    for k, v in sorted(mset.checksums.items())]}
    doc = {**d.to_dict(), "tyre": tyre.to_dict(), "provenance": provenance,
           "notes": notes}
    json_path = atomic_write_text(out / "discovery.json",
                                  json.dumps(doc, indent=1, default=json_default))
    from identify.report.discovery import write_pdf
    pdf_path = write_pdf(d, out / "discovery.pdf")
    values, sources = _enriched(tir, d)
    tir_path = write_tir(out / f"{tyre.id}.tir", values, fittyp=fittyp, sources=sources,
                         comment_lines=[f"mfid discover {__version__}: base {base.kind} "
                                        f"{base.name}".rstrip(),
                                        "accepted: " + (", ".join(a.name for a in d.accepted)
                                                        or "none")])
    fit_doc = {"schema": "mfid.fit/1", "tyre": tyre.to_dict(), "provenance": provenance,
               "fits": [p.fit.to_dict() for p in d.problems if p.fit is not None],
               "tir": {"path": tir_path.name, "fittyp": fittyp}, "flags": []}
    fit_json = atomic_write_text(out / "fit.json",
                                 json.dumps(fit_doc, indent=1, default=json_default))
    return DiscoveryRun(out, json_path, pdf_path, Path(tir_path), fit_json, d, tuple(notes))

