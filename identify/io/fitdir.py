"""The fit directory (docs/fit-directory.md): write it from a :class:`FitRun`, read it back.

``fits/<tyre id>/`` holds the .tir, fit.json (``FitRun.to_dict()``), measured_vs_model.csv (one
row per fitted data point), extraction.json when raw runs were extracted, and saved MCMC chains
under ``mcmc/``. :func:`write_fit_dir` writes every file to a temporary name first and renames
them back to back at the end; :func:`read_fit_dir` reads the directory into a :class:`FitDir`
whose ``run`` is the typed FitRun with the .tir values and per-point arrays filled in. The
report is rebuilt from this directory alone; nothing here refits.
"""
from __future__ import annotations

import dataclasses
import json
from collections.abc import Mapping
from contextlib import ExitStack
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from identify.core.atomic import atomic_path, atomic_write_text
from identify.core.errors import InputError
from identify.core.jsonsafe import json_text
from identify.core.names import inside
from identify.core.tyre import TyreInfo
from identify.fit.result import FitResult
from identify.fit.run import CSV_NAME, JSON_NAME, SCHEMA, FitRun, Provenance
from identify.fit.sources import KeySource
from identify.io.tir import format_tir, read_tir
from identify.io.tir.write import FIT_DIGITS

__all__ = [
    "CSV_COLUMNS",
    "CSV_NAME",
    "EXTRACTION_NAME",
    "JSON_NAME",
    "SCHEMA",
    "FitDir",
    "read_fit_dir",
    "rows_of",
    "with_points",
    "write_fit_dir",
    "write_fit_json",
]

EXTRACTION_NAME = "extraction.json"
CSV_COLUMNS = ("relation", "form", "quantity", "unit", "pi_bar", "Fz_N", "gamma_deg",
               "alpha_rad", "kappa", "Vx_mps", "measured", "model")
_REQUIRED_COLUMNS = ("relation", "form", "quantity", "pi_bar", "measured", "model")


@dataclass(frozen=True, eq=False)
class FitDir:
    """One fit directory, read.

    Attributes
    ----------
    path : Path                 the directory
    run : FitRun                fit.json, typed; its results carry their measured-vs-model
                                arrays and its ``tir_values`` the .tir's values
    points : DataFrame          measured_vs_model.csv (one row per fitted data point)
    tir : dict or None          numeric .tir values (SI), None when the .tir is unreadable
    extraction : dict or None   extraction.json when present
    notes : tuple of str        problems met while reading that the report should show
    """

    path: Path
    run: FitRun
    points: pd.DataFrame
    tir: Mapping[str, float] | None
    extraction: dict | None = None
    notes: tuple[str, ...] = field(default=())

    # ----- views of the run ----------------------------------------------------------------
    @property
    def tyre(self) -> TyreInfo:
        return self.run.tyre

    @property
    def tyre_id(self) -> str:
        return self.run.tyre.id or self.path.name

    @property
    def provenance(self) -> Provenance:
        return self.run.provenance

    @property
    def results(self) -> tuple[FitResult, ...]:
        return self.run.results

    @property
    def key_sources(self) -> Mapping[str, KeySource]:
        return self.run.key_sources

    @property
    def failed(self) -> tuple[str, ...]:
        return self.run.failed

    @property
    def tir_path(self) -> Path:
        return self.path / Path(self.run.tir_name).name

    @property
    def nominal_pressure_bar(self) -> float:
        return self.run.tyre.nominal_pressure_Pa / 1e5

    @property
    def nominal_load_N(self) -> float:
        return self.run.tyre.nominal_load_N

    # ----- rows and chains of one fit -------------------------------------------------------
    def rows(self, result: FitResult) -> pd.DataFrame:
        """The measured-vs-model rows of one fit (its relation and form)."""
        return rows_of(self.points, result)

    def mf_rows(self) -> pd.DataFrame:
        """The rows of the Magic Formula stages (relation "MF")."""
        p = self.points
        if p.empty:
            return p
        return p[p["relation"].astype(str) == "MF"].reset_index(drop=True)

    def chain_file(self, result: FitResult) -> Path | None:
        """The saved MCMC chain of one fit: fits/<id>/mcmc/<relation>_<form>.h5 (the contract),
        else the path fit.json recorded, if either exists."""
        own = self.path / "mcmc" / f"{result.relation}_{result.form}.h5"
        if own.is_file():
            return own
        recorded = result.mcmc.chain_file if result.mcmc is not None else None
        if recorded:  # a path read from fit.json: only ever a file of this fit directory
            named = inside(self.path, recorded)[0] if "\x00" not in recorded else None
            for cand in (named, self.path / Path(recorded).name,
                         self.path / "mcmc" / Path(recorded).name):
                if cand is not None and "\x00" not in str(cand) and cand.is_file():
                    return cand
        return None


def rows_of(points: pd.DataFrame, result: FitResult) -> pd.DataFrame:
    """The rows of measured_vs_model.csv (``points``) that belong to ``result``."""
    if points.empty:
        return points
    sel = (points["relation"].astype(str) == result.relation) & \
          (points["form"].astype(str) == result.form)
    return points[sel].reset_index(drop=True)


def with_points(result: FitResult, rows: pd.DataFrame) -> FitResult:
    """``result`` with its per-point arrays from its measured_vs_model rows."""
    col = (lambda c: rows[c].to_numpy(float) if len(rows) else np.empty(0))
    return dataclasses.replace(result, predicted=col("model"), measured=col("measured"),
                               pressure_bar=col("pi_bar"), points=rows)


# ----- reading ------------------------------------------------------------------------------------

def _read_json(path: Path) -> Any:
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as exc:
        raise InputError(path, f"cannot read file: {exc.strerror or exc}") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise InputError(path, f"not valid JSON: {exc.msg}", line=exc.lineno) from None


def _read_points(root: Path) -> pd.DataFrame:
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
        missing = [c for c in _REQUIRED_COLUMNS if c not in points.columns]
        if missing:
            raise InputError(cpath, "missing column(s) " + ", ".join(missing))
    for c in CSV_COLUMNS:
        if c not in points.columns:
            points[c] = np.nan
    return points


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
    try:
        run = FitRun.from_dict(_read_json(jpath))
    except InputError as exc:
        if exc.file is not None:
            raise
        raise InputError(jpath, exc.message, line=exc.line, key=exc.key) from None
    points = _read_points(root)
    notes: list[str] = []
    tir_path = root / Path(run.tir_name).name
    tir = None
    if tir_path.is_file():
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
    run = dataclasses.replace(
        run, fit_dir=root, tir_values=dict(tir or {}),
        results=tuple(with_points(r, rows_of(points, r)) for r in run.results))
    return FitDir(root, run, points, tir, extraction, tuple(notes))


# ----- writing ------------------------------------------------------------------------------------

def _tir_comment(run: FitRun) -> list[str]:
    prov, inputs = run.provenance, run.provenance.inputs
    return [f"fitted by mfid {prov.mfid_version} from {run.tyre.id} ({run.tyre.source} data)",
            f"seed {prov.seed}; inputs: " + ", ".join(
                f"{i.path} sha256:{i.sha256[:12]}" for i in inputs[:6])
            + (" ..." if len(inputs) > 6 else "")]


def write_fit_json(run: FitRun, path: str | Path) -> Path:
    """Write ``run.to_dict()`` to ``path`` (atomically)."""
    return Path(atomic_write_text(path, json_text(run.to_dict())))


def write_fit_dir(run: FitRun, fit_dir: str | Path, *, points: pd.DataFrame,
                  extraction: Mapping[str, Any] | None = None) -> FitRun:
    """Write a fit directory: the .tir (``run.tir_values``), fit.json, measured_vs_model.csv
    (``points``, columns :data:`CSV_COLUMNS`) and extraction.json (when given).

    Every file goes to a temporary name first; the renames come last, back to back, so an
    interrupt leaves either the previous set of outputs or the complete new one.

    Returns
    -------
    FitRun
        ``run`` with ``fit_dir`` set.

    Raises
    ------
    InputError
        The directory or a file cannot be written.
    """
    fit_dir = Path(fit_dir)
    made = [d for d in (fit_dir, *fit_dir.parents) if not d.exists()]  # removed on failure
    try:
        fit_dir.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(fit_dir, f"cannot create folder: {exc.strerror or exc}") from None
    try:
        return _write_files(run, fit_dir, points, extraction)
    except BaseException:
        for d in made:  # innermost first; a folder something else wrote into stays
            try:
                d.rmdir()
            except OSError:
                break
        raise


def _write_files(run: FitRun, fit_dir: Path, points: pd.DataFrame,
                 extraction: Mapping[str, Any] | None) -> FitRun:
    run = dataclasses.replace(run, fit_dir=fit_dir)
    # fit.json first: entered first, renamed last (the stack exits in reverse), so a rename
    # that fails leaves no fit.json naming files that are not there
    texts = {run.json_path: json_text(run.to_dict()),
             run.tir_path: format_tir(run.tir_values, fittyp=run.fittyp,
                                      comment_lines=_tir_comment(run),
                                      sources=dict(run.key_sources) or None,
                                      digits=FIT_DIGITS),
             run.csv_path: points.to_csv(index=False, lineterminator="\n")}
    if extraction is not None:
        texts[fit_dir / EXTRACTION_NAME] = json_text(extraction)
    with ExitStack() as stack:
        for path, text in texts.items():
            tmp = stack.enter_context(atomic_path(path))
            tmp.write_bytes(text.encode("utf-8"))  # bytes: the .tir's CRLF kept on every OS
    return run
