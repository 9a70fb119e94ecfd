"""One whole fit of a measurement folder as typed data: the fit.json document.

:class:`FitRun` holds what ``mfid fit`` (and ``mfid discover``) produced: the tyre, the
provenance (version, time, command, seed, settings, input checksums), every
:class:`~identify.fit.result.FitResult`, where each .tir key came from, the data-quality flags
and the fits that failed. ``FitRun.to_dict()`` is the fit.json document and
``FitRun.from_dict()`` reads it back (``FitRun.from_dict(doc).to_dict() == doc``); the schema
string :data:`SCHEMA` is defined here only. The provenance's records (:class:`FitSettings`,
:class:`InputFile`, :class:`Provenance`) are written and read field by field
(identify.core.serial); an older fit.json is brought to the current layout by the explicit
migrations of :data:`FIT_SCHEMA` before it is read. The .tir values and the per-point arrays
are not in fit.json (they are in the .tir and measured_vs_model.csv):
:func:`identify.io.fitdir.read_fit_dir` fills them in.
"""
from __future__ import annotations

import datetime as _dt
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import pandas as pd

from identify.core.errors import InputError
from identify.core.jsonsafe import json_safe
from identify.core.serial import Schema, Serial, from_data
from identify.core.tyre import TyreInfo
from identify.core.version import __version__
from identify.fit.coverage import StageCoverage
from identify.fit.mcmc.chains import BUDGET_S, MAX_STEPS
from identify.fit.relations.forms import FormChoice
from identify.fit.result import FitResult
from identify.fit.sources import KINDS, KeySource
from identify.fit.status import FAILED
from identify.fit.summary import SummaryRow, summary_rows, summary_text, tir_keys

__all__ = ["BIN_ALPHA_DEG", "BIN_KAPPA", "FIT_SCHEMA", "SCHEMA", "FitRun", "FitSettings",
           "InputFile", "Provenance", "failures"]

SCHEMA = "mfid.fit/2"
"""The schema string of fit.json (its ``"schema"`` key): :data:`FIT_SCHEMA`'s tag."""

BIN_ALPHA_DEG = 0.25
"""[deg] default bin width of dense slip-angle sweeps (docs/procedures.md, "Sweep binning")."""
BIN_KAPPA = 0.0025
"""[-] default bin width of dense slip-ratio sweeps."""

JSON_NAME = "fit.json"
CSV_NAME = "measured_vs_model.csv"


@dataclass(frozen=True)
class FitSettings(Serial):
    """Settings that make a fit (recorded in fit.json's provenance).

    Attributes
    ----------
    seed : int             seeds the global search and MCMC
    mcmc : bool            run emcee on every fit
    mcmc_ar1 : bool        AR(1) noise along sweeps in MCMC
    save_chains : bool     keep MCMC chains as HDF5 under fits/<id>/mcmc/
    only : tuple of str    relation names to fit (empty = all)
    fittyp : int           61 or 62 for the written .tir
    mcmc_max_steps : int   cap on every MCMC chain [steps]; a chain stops at 50 tau before it,
                           and its summary says converged = false if the cap came first
    mcmc_budget_s : float or None   wall-time budget of the whole MCMC run, all chains
                           together [s], shared out between the chains (each gets the budget
                           left divided by the chains left); a chain stopped by it says
                           converged = false (None: no budget)
    mcmc_reparam : bool    sample the Fy0 cornering stiffness at three loads in place of
                           PKY1, PKY2, PKY4 (identify.fit.mcmc.reparam; same posterior)
    forms : tuple of str   ``RELATION=FORM`` choices of form made by the user (``--form``)
    hold : tuple of str    coefficients held at their default in every relation fit
                           (``--hold``)
    bin_alpha_deg : float or None   bin width [deg] of dense slip-angle sweeps of trailer data
                           before the MF stages (identify.workflows.sweep_bins); None: every
                           sample is fitted
    bin_kappa : float or None       the same for slip-ratio sweeps [-]
    bin_passes : bool      one bin point per pass of a sweep, not one per bin
                           (identify.segment.filters, ``binning``: merging the passes averages
                           operating points where a rig's load follows the slip direction)
    segment : bool         fit the trailer runs with a warm-up (logged test programmes) on
                           their quasi-steady sweeps only (identify.workflows.sweep_bins)
    revolution_average : bool   average the trailer samples over one wheel revolution
                           before the MF stages (identify.segment.filters; against a ripple
                           the forces do not follow); off, the raw samples go to the bins,
                           which average the ripple over the passes through each bin without
                           bending a curve that changes within a revolution (docs/intervals.md,
                           "What the averaging does to the tightest intervals")
    mf_passes : int        passes over the MF stages (identify.fit.mf.stages.fit_mf): the
                           second solves again, locally, the stages something they read has
                           moved in since they were fitted (SSZ1..4 act on the Mz0 points
                           through s Fx), where a Gauss-Newton step would gain more than
                           PASS_GAIN (docs/commands.md, "mfid fit")
    pressure_holdout : bool   predict each pressure level of the MF fit by the stages fitted
                           again without it (identify.fit.mf.pressure_holdout; the report's
                           pressure page; the session's own test of the mission's claim
                           that the pressure terms carry, so on by default: False saves a
                           local refit per level)
    """

    seed: int = 0
    mcmc: bool = False
    mcmc_ar1: bool = False
    save_chains: bool = False
    only: tuple[str, ...] = ()
    fittyp: int = 61
    mcmc_max_steps: int = MAX_STEPS
    mcmc_budget_s: float | None = BUDGET_S
    mcmc_reparam: bool = True
    forms: tuple[str, ...] = ()
    hold: tuple[str, ...] = ()
    bin_alpha_deg: float | None = BIN_ALPHA_DEG
    bin_kappa: float | None = BIN_KAPPA
    bin_passes: bool = False
    segment: bool = True
    revolution_average: bool = True
    mf_passes: int = 2
    pressure_holdout: bool = True

    @classmethod
    def from_dict(cls, d: Mapping[str, Any]) -> FitSettings:
        """Inverse of :meth:`to_dict`; an unknown setting is a TypeError.

        A missing setting means the record was written before that setting existed, so it
        takes the value that such a fit ran with (:data:`RECORD_DEFAULTS`: one MF pass, no
        segmentation, no Fy0 reparametrisation, no MCMC budget, no binning), else its
        default; a fit.json then says what was done, not what mfid would do today."""
        return from_data(cls, {**RECORD_DEFAULTS, **d})


RECORD_DEFAULTS: Mapping[str, Any] = {"mf_passes": 1, "segment": False,
                                     "mcmc_reparam": False, "mcmc_budget_s": None,
                                     "bin_alpha_deg": None, "bin_kappa": None,
                                     "pressure_holdout": False}
"""Settings of a fit recorded before the setting existed: what such a fit ran with (one MF
pass, no segmentation, neither Fy0 reparametrisation nor an MCMC budget, every trailer sample
fitted without binning, no pressure hold-out), so that an older fit.json reads back as what
it was."""


@dataclass(frozen=True)
class InputFile(Serial):
    """One input file of a fit and its SHA-256 (hex)."""

    path: str
    sha256: str


@dataclass(frozen=True)
class Provenance(Serial):
    """Where a fit came from: enough to reproduce it.

    Attributes
    ----------
    mfid_version : str
    created_utc : str             ISO 8601 time of the fit (UTC, seconds)
    command : str                 the command line that made it
    seed : int
    settings : FitSettings or None   None for the fit.json of ``mfid discover`` (its settings
                                     are in discovery.json)
    inputs : tuple of InputFile   every input file with its checksum
    """

    mfid_version: str
    created_utc: str
    command: str
    seed: int
    settings: FitSettings | None
    inputs: tuple[InputFile, ...] = ()

    @classmethod
    def now(cls, *, command: str, seed: int, settings: FitSettings | None,
            checksums: Mapping[str, str], folder: str | Path) -> Provenance:
        """The provenance of a fit made now by this mfid, from a folder's input checksums
        (file name relative to ``folder`` -> sha256)."""
        created = _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds")
        inputs = tuple(InputFile(str(Path(folder) / name), digest)
                       for name, digest in sorted(checksums.items()))
        return cls(__version__, created, command, int(seed), settings, inputs)

    @property
    def created(self) -> _dt.datetime | None:
        """:attr:`created_utc` as an aware datetime (UTC assumed without an offset), or None
        when it is missing or not ISO 8601."""
        if not self.created_utc:
            return None
        try:
            stamp = _dt.datetime.fromisoformat(self.created_utc)
        except ValueError:
            return None
        return stamp if stamp.tzinfo is not None else stamp.replace(tzinfo=_dt.UTC)


def _fit_v1_to_v2(doc: dict[str, Any]) -> dict[str, Any]:
    """mfid.fit/1 -> /2: every entry present. A version-1 document may lack the entries
    recorded later (``failed``, ``flags``, ``coverage``, ``data_quality``,
    ``pressure_holdout``, ``every_sample``, the .tir's ``key_sources`` and ``forms``) and the
    provenance's
    fields, or hold them as null: they read as empty (an unknown version and command, seed 0);
    a key source written as a plain string (the ``relation/form`` that supplied it) is a
    fitted one; a null text of the tyre (source, size, description) is its default; the
    .tir without a FITTYP is 61, without a path ``<tyre id>.tir``."""
    out = dict(doc)
    out["tyre"] = {k: v for k, v in (out.get("tyre") or {}).items()
                   if v is not None or k not in _TYRE_TEXTS}
    for key, empty in (("failed", []), ("flags", []), ("coverage", []), ("data_quality", {}),
                       ("pressure_holdout", {}), ("every_sample", {})):
        out[key] = out.get(key) or empty
    tir = dict(out.get("tir") or {})
    tir["fittyp"] = int(tir.get("fittyp") or 61)
    tir["path"] = str(tir.get("path") or f"{out['tyre'].get('id')}.tir")
    tir["key_sources"] = {str(k): KeySource.from_dict(v).to_dict()
                          for k, v in (tir.get("key_sources") or {}).items()}
    tir["forms"] = list(tir.get("forms") or [])
    out["tir"] = tir
    prov = dict(out.get("provenance") or {})
    out["provenance"] = {"mfid_version": str(prov.get("mfid_version") or ""),
                         "created_utc": str(prov.get("created_utc") or ""),
                         "command": str(prov.get("command") or ""),
                         "seed": int(prov.get("seed") or 0),
                         "settings": prov.get("settings"),
                         "inputs": list(prov.get("inputs") or [])}
    return out


_TYRE_TEXTS = ("source", "size", "description")
"""The tyre's texts: a null one in a version-1 document reads as its default."""

FIT_SCHEMA = Schema("mfid.fit", 2, {1: _fit_v1_to_v2})
"""fit.json's layout: its version and the migrations from the older ones."""


def failures(results: Sequence[FitResult]) -> tuple[str, ...]:
    """``relation[form]: why`` of every fit whose status is failed (identify.fit.status: it
    did not converge, or the model misses the data grossly): fit.json's ``failed``."""
    return tuple(f"{r.relation}[{r.form}]: "
                 + (r.message if not r.converged else (r.reasons[0] if r.reasons else FAILED))
                 for r in results if r.status_text == FAILED)


@dataclass(frozen=True)
class FitRun:
    """Everything one fit of a measurement folder produced (fit.json, typed).

    Attributes
    ----------
    tyre : TyreInfo
    provenance : Provenance
    results : tuple of FitResult      one per relation/form or MF stage, in fit order
    key_sources : Mapping[str, KeySource]  .tir key -> where its value came from (fitted by
                                      "relation/form" or "MF/<stage> (trailer)", tyre.toml,
                                      measured range, default ...): every key of the .tir
    form_choices : tuple of FormChoice  the form of each relation with a nested pair that
                                      the .tir takes, and why
    fittyp : int                      FITTYP of the written .tir (61 or 62)
    tir_name : str                    file name of the .tir in the fit directory
    flags : tuple of dict             data-quality flags {run, test, flag, detail} from
                                      extraction
    failed : tuple of str             fits that did not converge (``relation[form]: why``);
                                      empty when every fit succeeded
    coverage : tuple of StageCoverage  what the trailer data held for each MF stage, which
                                      coefficients they can identify, and why a stage was
                                      skipped (identify.fit.coverage); empty without trailer
                                      data
    data_quality : Mapping            the loading warnings (``warnings``: DataWarning dicts,
                                      each with its count), the trailer runs segmented, their
                                      segmentation and the channels the fit could not use
                                      (``trailer``); empty when there is nothing to say
    pressure_holdout : Mapping        each pressure level of the MF fit predicted by the stages
                                      fitted again without it (identify.fit.
                                      pressure_holdout.PressureHoldout.to_dict); empty when not
                                      computed
    every_sample : Mapping            the written .tir against every loaded trailer sample,
                                      per kind of run, segmentation group and pressure
                                      (identify.fit.every_sample.EverySample.to_dict); empty
                                      when the MF stages did not run
    tir_values : Mapping              the written .tir values (not in fit.json: read from the
                                      .tir by :func:`identify.io.fitdir.read_fit_dir`)
    fit_dir : Path or None            the fit directory (fits/<tyre id>), when known
    """

    tyre: TyreInfo
    provenance: Provenance
    results: tuple[FitResult, ...]
    key_sources: Mapping[str, KeySource]
    fittyp: int
    tir_name: str
    flags: tuple[Mapping[str, Any], ...] = ()
    failed: tuple[str, ...] = ()
    form_choices: tuple[FormChoice, ...] = ()
    coverage: tuple[StageCoverage, ...] = ()
    data_quality: Mapping[str, Any] = field(default_factory=dict, repr=False)
    pressure_holdout: Mapping[str, Any] = field(default_factory=dict, repr=False)
    every_sample: Mapping[str, Any] = field(default_factory=dict, repr=False)
    tir_values: Mapping[str, Any] = field(default_factory=dict, repr=False, compare=False)
    fit_dir: Path | None = field(default=None, compare=False)
    points: Any = field(default=None, repr=False, compare=False)
    extraction: Mapping[str, Any] | None = field(default=None, repr=False, compare=False)

    def __repr__(self) -> str:
        where = f", {self.fit_dir}" if self.fit_dir is not None else ", in memory"
        worst = ", ".join(self.failed[:2]) if self.failed else ""
        return (f"<FitRun {self.tyre.id}: {len(self.results)} fits, "
                f"{len(self.poorly_identified)} poorly identified, {len(self.failed)} failed"
                f"{' (' + worst + ')' if worst else ''}{where}>")

    def table(self) -> pd.DataFrame:
        """Every free coefficient of every fit, one row each (:meth:`FitResult.table`), with
        each fit's status and total error."""
        frames = [r.table().assign(status=r.status_text, error_total_pct=r.error_total_pct)
                  for r in self.results]
        return pd.concat(frames, ignore_index=True) if frames else pd.DataFrame()

    def _repr_html_(self) -> str:
        rows = "".join(f"<tr><td>{r.name}</td><td>{r.status_text}</td>"
                       f"<td>{r.error_total_pct:.3g}</td><td>{r.n_points}</td>"
                       f"<td>{len(r.free)}</td></tr>" for r in self.results)
        return (f"<p><b>{self.tyre.id}</b>: {len(self.results)} fits</p><table><tr>"
                "<th>fit</th><th>status</th><th>total error [%]</th><th>points</th>"
                f"<th>free</th></tr>{rows}</table>")

    def plot(self, name: str, ax=None):
        """The measured and model points of one fit (:meth:`FitResult.plot`)."""
        return self.result(name).plot(ax)

    # ----- paths -----------------------------------------------------------------------------
    @property
    def tyre_id(self) -> str:
        return self.tyre.id

    @property
    def settings(self) -> FitSettings | None:
        return self.provenance.settings

    @property
    def ok(self) -> bool:
        """Every fit converged."""
        return not self.failed

    @property
    def skipped(self) -> dict[str, str]:
        """MF stage -> why it was skipped (the data lack what it needs)."""
        return {c.stage: c.skipped for c in self.coverage if c.skipped}

    @property
    def poorly_identified(self) -> tuple[str, ...]:
        """``relation/form`` of every converged fit whose coefficients are not all identified
        (identification "poorly identified", whatever its status)."""
        return tuple(r.name for r in self.results
                     if r.converged and r.identification != "ok")

    def form_choice(self, relation: str) -> FormChoice | None:
        """The form choice of ``relation``, or None (no nested pair, or not fitted)."""
        for c in self.form_choices:
            if c.relation == relation:
                return c
        return None

    def source_counts(self) -> dict[str, int]:
        """How many .tir keys came from each kind of source (fitted, tyre.toml ...)."""
        counts = {k: 0 for k in KINDS}
        for s in self.key_sources.values():
            counts[s.kind] += 1
        return {k: n for k, n in counts.items() if n}

    def _in_dir(self, name: str) -> Path:
        if self.fit_dir is None:
            raise ValueError("this FitRun has no fit directory")
        return Path(self.fit_dir) / name

    @property
    def tir_path(self) -> Path:
        return self._in_dir(self.tir_name)

    @property
    def json_path(self) -> Path:
        return self._in_dir(JSON_NAME)

    @property
    def csv_path(self) -> Path:
        return self._in_dir(CSV_NAME)

    # ----- looking up fits -------------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        """``relation/form`` of every fit, in fit order."""
        return tuple(r.name for r in self.results)

    def result(self, name: str) -> FitResult:
        """One fit by name: ``"CFy/linear_load"``, ``"MF/Fy0"``, or a relation alone
        (``"CFy"``) when it has one fit or one fit that supplied .tir keys.

        Raises
        ------
        KeyError
            No such fit, or a relation name with several candidates; the message lists the
            names of the fits.
        """
        for r in self.results:
            if r.name == name:
                return r
        same = [r for r in self.results if r.relation == name]
        if len(same) > 1:
            same = [r for r in same if self.tir_keys(r)]
        if len(same) == 1:
            return same[0]
        listed = ", ".join(self.names) or "none"
        if same:
            raise KeyError(f"{name!r} is ambiguous: give relation/form, one of "
                           f"{', '.join(r.name for r in same)}")
        raise KeyError(f"no fit named {name!r}; the fits are: {listed}")

    def tir_keys(self, result: FitResult) -> list[str]:
        """The .tir keys ``result`` supplied."""
        return tir_keys(result, self.key_sources)

    # ----- summary ---------------------------------------------------------------------------
    def summary_rows(self) -> list[SummaryRow]:
        """One summary row per fit (relation, form, total error, points, status, .tir,
        key coefficients)."""
        return summary_rows(self.results, self.key_sources, self.form_choices)

    def report(self) -> str:
        """Plain-text summary: the table ``mfid fit`` prints, then the form choices, the
        poorly identified and the failed fits."""
        return summary_text(self.summary_rows(), self.failed, self.form_choices,
                            self.results)

    # ----- fit.json --------------------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        """The fit.json document (JSON-safe)."""
        return json_safe({
            "schema": SCHEMA, "tyre": self.tyre.to_dict(),
            "provenance": self.provenance.to_dict(),
            "fits": [r.to_dict() for r in self.results],
            "tir": {"path": self.tir_name, "fittyp": self.fittyp,
                    "key_sources": {k: s.to_dict() for k, s in self.key_sources.items()},
                    "forms": [c.to_dict() for c in self.form_choices]},
            "flags": [dict(f) for f in self.flags], "failed": list(self.failed),
            "coverage": [c.to_dict() for c in self.coverage],
            "data_quality": dict(self.data_quality),
            "pressure_holdout": dict(self.pressure_holdout),
            "every_sample": dict(self.every_sample)})

    @classmethod
    def from_dict(cls, doc: Any) -> FitRun:
        """Read a fit.json document.

        The .tir values and per-point arrays are left empty (see the module docstring).
        An older document is first migrated to the current layout (:data:`FIT_SCHEMA`), in
        which every entry is present: the reader knows that layout only.

        Raises
        ------
        InputError
            Not a fit.json of this schema, or an entry is malformed (the key names the entry,
            e.g. ``fits[2]``; no file is named: the caller adds it).
        """
        try:
            doc = FIT_SCHEMA.upgrade(doc)
        except ValueError as exc:
            raise InputError(None, str(exc), key="schema") from None
        if not isinstance(doc.get("fits"), list):
            raise InputError(None, "missing the list of fits", key="fits")
        with _entry("tyre"):
            tyre = TyreInfo.from_dict(doc["tyre"])
        with _entry("provenance"):
            provenance = Provenance.from_dict(doc["provenance"])
        results = []
        for i, d in enumerate(doc["fits"]):
            with _entry(f"fits[{i}]"):
                results.append(FitResult.from_dict(d))
        with _entry("tir"):
            tir = doc["tir"]
            fittyp = int(tir["fittyp"])
            key_sources = {str(k): KeySource.from_dict(v) for k, v in tir["key_sources"].items()}
            forms = tuple(FormChoice.from_dict(c) for c in tir["forms"])
            tir_name = str(tir["path"])
        with _entry("flags"):
            flags = tuple(dict(f) for f in doc["flags"])
        with _entry("failed"):
            failed = tuple(str(f) for f in doc["failed"])
        with _entry("coverage"):
            coverage = tuple(StageCoverage.from_dict(c) for c in doc["coverage"])
        with _entry("data_quality"):
            quality = dict(doc["data_quality"])
        with _entry("pressure_holdout"):
            holdout = dict(doc["pressure_holdout"])
        with _entry("every_sample"):  # a document written before it: empty
            every = dict(doc.get("every_sample") or {})
        return cls(tyre=tyre, provenance=provenance, results=tuple(results),
                   key_sources=key_sources, fittyp=fittyp, tir_name=tir_name, flags=flags,
                   failed=failed, form_choices=forms, coverage=coverage,
                   data_quality=quality, pressure_holdout=holdout, every_sample=every)


class _entry:
    """Turn a malformed entry (missing key, wrong type) into an InputError naming it."""

    def __init__(self, key: str):
        self.key = key

    def __enter__(self) -> None:
        return None

    def __exit__(self, exc_type, exc, tb) -> bool:
        if exc_type is not None and issubclass(exc_type, (KeyError, TypeError, ValueError,
                                                          AttributeError, IndexError)):
            what = f"missing {exc}" if exc_type is KeyError else f"malformed ({exc})"
            raise InputError(None, what, key=self.key) from None
        return False
