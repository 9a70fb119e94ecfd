"""Read a fit directory (docs/fit-directory.md) for the report: fit.json, the measured-vs-model
table, the .tir, extraction.json and saved MCMC chains.

The report is rebuilt from this directory alone; nothing here refits or writes.
"""
from __future__ import annotations

import datetime as _dt
import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Mapping

import numpy as np
import pandas as pd

from identify.core.errors import InputError

SCHEMA = "mfid.fit/1"
CSV_NAME = "measured_vs_model.csv"
JSON_NAME = "fit.json"
EXTRACTION_NAME = "extraction.json"


@dataclass(frozen=True, eq=False)
class FitDir:
    """One fit directory, read.

    Attributes
    ----------
    path : Path                 the directory
    doc : dict                  fit.json
    points : DataFrame          measured_vs_model.csv (one row per fitted data point)
    tir : dict or None          numeric .tir values (SI), None when the .tir is unreadable
    tir_path : Path
    extraction : dict or None   extraction.json when present
    notes : tuple of str        problems met while reading that the report should show
    """

    path: Path
    doc: dict
    points: pd.DataFrame
    tir: Mapping[str, float] | None
    tir_path: Path
    extraction: dict | None = None
    notes: tuple[str, ...] = field(default=())

    # ----- convenience views ---------------------------------------------------------------
    @property
    def tyre(self) -> dict:
        return self.doc.get("tyre") or {}

    @property
    def tyre_id(self) -> str:
        return str(self.tyre.get("id") or self.path.name)

    @property
    def provenance(self) -> dict:
        return self.doc.get("provenance") or {}

    @property
    def fits(self) -> list[dict]:
        return list(self.doc.get("fits") or [])

    @property
    def key_sources(self) -> dict[str, str]:
        tir = self.doc.get("tir") or {}
        return dict(tir.get("key_sources") or {})

    @property
    def failed(self) -> list[str]:
        return [str(f) for f in (self.doc.get("failed") or [])]

    @property
    def created(self) -> _dt.datetime | None:
        """The fit's creation time (UTC) from fit.json, or None."""
        text = self.provenance.get("created_utc")
        if not text:
            return None
        try:
            stamp = _dt.datetime.fromisoformat(str(text))
        except ValueError:
            return None
        if stamp.tzinfo is None:
            stamp = stamp.replace(tzinfo=_dt.timezone.utc)
        return stamp

    @property
    def nominal_pressure_bar(self) -> float:
        return _float(self.tyre.get("nominal_pressure_Pa")) / 1e5

    @property
    def nominal_load_N(self) -> float:
        return _float(self.tyre.get("nominal_load_N"))

    def rows(self, fit: Mapping[str, Any]) -> pd.DataFrame:
        """The measured-vs-model rows of one fit (its relation and form)."""
        p = self.points
        if p.empty:
            return p
        sel = (p["relation"].astype(str) == str(fit.get("relation"))) & \
              (p["form"].astype(str) == str(fit.get("form")))
        return p[sel].reset_index(drop=True)

    def mf_rows(self) -> pd.DataFrame:
        """The rows of the Magic Formula stages (relation "MF")."""
        p = self.points
        if p.empty:
            return p
        return p[p["relation"].astype(str) == "MF"].reset_index(drop=True)

    def chain_file(self, fit: Mapping[str, Any]) -> Path | None:
        """The saved MCMC chain of one fit: fits/<id>/mcmc/<relation>_<form>.h5 (the contract),
        else the path fit.json recorded, if either exists."""
        own = self.path / "mcmc" / f"{fit.get('relation')}_{fit.get('form')}.h5"
        if own.is_file():
            return own
        mc = fit.get("mcmc") or {}
        recorded = mc.get("chain_file")
        if recorded:
            for cand in (Path(recorded), self.path / Path(recorded).name,
                         self.path / "mcmc" / Path(recorded).name):
                if cand.is_file():
                    return cand
        return None


def _float(x: Any) -> float:
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def _read_json(path: Path) -> Any:
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(path, f"cannot read file: {exc.strerror or exc}") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(path, f"not valid JSON: {exc.msg}", line=exc.lineno) from None


CSV_COLUMNS = ("relation", "form", "quantity", "unit", "pi_bar", "Fz_N", "gamma_deg",
               "alpha_rad", "kappa", "Vx_mps", "measured", "model")


def read_fit_dir(path: str | Path) -> FitDir:
    """Read a fit directory written by ``mfid fit``.

    Raises
    ------
    InputError
        The directory, fit.json or measured_vs_model.csv is missing or malformed.
    """
    root = Path(path)
    if not root.is_dir():
        raise InputError(root, "no such fit directory" if not root.exists()
                         else "not a directory (expected fits/<tyre id>/)")
    jpath = root / JSON_NAME
    if not jpath.is_file():
        raise InputError(root, f"not a fit directory: no {JSON_NAME}")
    doc = _read_json(jpath)
    if not isinstance(doc, dict) or doc.get("schema") != SCHEMA:
        found = doc.get("schema") if isinstance(doc, dict) else type(doc).__name__
        raise InputError(jpath, f"schema is {found!r}, expected {SCHEMA!r}", key="schema")
    if not isinstance(doc.get("fits"), list):
        raise InputError(jpath, "missing the list of fits", key="fits")
    cpath = root / CSV_NAME
    if not cpath.is_file():
        raise InputError(root, f"not a complete fit directory: no {CSV_NAME}")
    try:
        points = pd.read_csv(cpath)
    except pd.errors.EmptyDataError:
        points = pd.DataFrame({c: pd.Series(dtype=float) for c in CSV_COLUMNS})
    except (OSError, ValueError, pd.errors.ParserError) as exc:
        raise InputError(cpath, f"cannot read table: {exc}") from None
    if len(points):
        missing = [c for c in ("relation", "form", "quantity", "pi_bar", "measured", "model")
                   if c not in points.columns]
        if missing:
            raise InputError(cpath, "missing column(s) " + ", ".join(missing))
    for c in CSV_COLUMNS:
        if c not in points.columns:
            points[c] = np.nan
    notes: list[str] = []
    tir_name = (doc.get("tir") or {}).get("path") or f"{(doc.get('tyre') or {}).get('id')}.tir"
    tir_path = root / Path(str(tir_name)).name
    tir = None
    if tir_path.is_file():
        from identify.io.tir import read_tir

        try:
            tir = read_tir(tir_path).params()
        except InputError as exc:
            notes.append(f"the .tir could not be read ({exc}); MF pages and model curves that "
                         "need it are left out")
    else:
        notes.append(f"{tir_path.name} is missing; MF pages and model curves that need it are "
                     "left out")
    extraction = None
    epath = root / EXTRACTION_NAME
    if epath.is_file():
        extraction = _read_json(epath)
    return FitDir(root, doc, points, tir, tir_path, extraction, tuple(notes))
