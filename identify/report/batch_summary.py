"""The summary across the tyres of one ``mfid batch``: ``batch_summary.csv`` and the PDF.

``<out>/batch_summary.csv`` has one row per fit of every tyre (tyre, folder, the tyre's batch
status, relation, form, total thesis error [%], points, the fit's status as ``mfid fit`` and
fit.json give it: ok, poorly identified or failed, whether it supplied .tir keys, every fitted
coefficient as ``NAME=value``, message: why it failed or is poorly identified), and one row
without a fit for a folder that has no outputs (bad input, a lost task).
``<reports>/batch_summary.pdf`` compares the tyres side by side
(:mod:`identify.report.batch_compare`).

Both are rewritten only when the table changed (or the PDF is missing or older than the CSV),
so a second batch with nothing to do leaves them alone.
"""
from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from identify.core.atomic import atomic_write_text
from identify.fit.summary import tir_keys
from identify.io.fitdir import FitDir
from identify.report.batch_compare import write_comparison

__all__ = ["COLUMNS", "SUMMARY_CSV", "SUMMARY_PDF", "BatchEntry", "summary_frame",
           "write_batch_summary"]

SUMMARY_CSV = "batch_summary.csv"
SUMMARY_PDF = "batch_summary.pdf"
COLUMNS = ("tyre", "folder", "task", "relation", "form", "error_total_pct", "n_points",
           "status", "in_tir", "key_coefficients", "message")


@dataclass(frozen=True, eq=False)
class BatchEntry:
    """One folder of a batch as the summary sees it.

    Attributes
    ----------
    tyre_id : str            empty when the folder's tyre.toml could not be read
    folder : str             the measurement folder as given
    status : str             the task's status (ok, failed, bad input, lost, up to date)
    message : str            its one-line message
    fit : FitDir or None     the fit directory, when it could be read
    """

    tyre_id: str
    folder: str
    status: str
    message: str
    fit: FitDir | None


def _coefficients(result) -> str:
    """Every fitted coefficient as ``NAME=value`` (6 significant digits), comma-separated."""
    return ", ".join(f"{k}={float(v):.6g}" for k, v in result.fitted.items())


def summary_frame(entries: Sequence[BatchEntry]) -> pd.DataFrame:
    """The rows of batch_summary.csv (columns :data:`COLUMNS`)."""
    rows = []
    for e in entries:
        base = {"tyre": e.tyre_id, "folder": e.folder, "task": e.status}
        results = e.fit.results if e.fit is not None else ()
        for r in results:
            rows.append({**base, "relation": r.relation, "form": r.form,
                         "error_total_pct": r.error_total_pct, "n_points": r.n_points,
                         "status": r.status_text,
                         "in_tir": bool(tir_keys(r, e.fit.key_sources)),
                         "key_coefficients": _coefficients(r),
                         "message": r.message if not r.converged else "; ".join(r.reasons)
                         if r.identification != "ok" else ""})
        if not results:
            rows.append({**base, "relation": "", "form": "", "error_total_pct": float("nan"),
                         "n_points": 0, "status": e.status, "in_tir": False,
                         "key_coefficients": "", "message": e.message})
    return pd.DataFrame(rows, columns=list(COLUMNS))


def _mtime(path: Path) -> float | None:
    try:
        return path.stat().st_mtime
    except OSError:
        return None


def write_batch_summary(entries: Sequence[BatchEntry], out_root: str | Path,
                        reports: str | Path | None) -> tuple[Path, Path | None]:
    """Write ``<out_root>/batch_summary.csv`` and, with ``reports``, the comparison PDF
    ``<reports>/batch_summary.pdf``; leave both alone when the table did not change.

    Returns
    -------
    (Path, Path or None)
        The CSV and the PDF.

    Raises
    ------
    InputError
        A file cannot be written.
    """
    csv = Path(out_root) / SUMMARY_CSV
    pdf = None if reports is None else Path(reports) / SUMMARY_PDF
    text = summary_frame(entries).to_csv(index=False, lineterminator="\n")
    try:
        same = csv.read_text(encoding="utf-8") == text
    except OSError:
        same = False
    stamp = _mtime(csv)
    if same and (pdf is None or (_mtime(pdf) or -1.0) >= (stamp or 0.0)):
        return csv, pdf
    csv.parent.mkdir(parents=True, exist_ok=True)
    atomic_write_text(csv, text)
    if pdf is not None:
        pdf.parent.mkdir(parents=True, exist_ok=True)
        write_comparison(entries, pdf)
    return csv, pdf
