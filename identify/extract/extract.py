"""``extract_folder``: raw Flatplank runs of a measurement set -> characteristic table.

One module per test type does the work (vertical, stiffness, parking, relaxation, rolling,
camber, eigen); this module cuts the tidy table into runs, calls each, and collects the
characteristics (in the characteristic-table schema, so the fit takes extracted and hand-entered
characteristics alike), the per-run diagnostics and the flags into one :class:`Extraction`.
"""
from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import pandas as pd

from identify.core.version import __version__
from identify.extract.camber import extract_camber
from identify.extract.diagnostics import Flag, Part, RunDiagnostic, json_safe
from identify.extract.eigen import pass_through
from identify.extract.flags import Thresholds
from identify.extract.parking import extract_parking
from identify.extract.relaxation import extract_relaxation
from identify.extract.rolling import extract_rolling
from identify.extract.runs import collect_runs
from identify.extract.stiffness import extract_stiffness
from identify.extract.vertical import extract_vertical

__all__ = ["Extraction", "extract_folder", "COLUMNS", "SCHEMA"]

#: Columns of the extracted characteristic table (docs/loaded-tables.md).
COLUMNS = ("quantity", "pi_bar", "Fz_N", "value", "unit", "Vx_mps", "gamma_deg", "mode")
#: Schema tag of :meth:`Extraction.to_dict` (``extraction.json``).
SCHEMA = "mfid.extraction/1"
_ORDER = ("CFz", "CFx", "CFy", "CMz", "sigma_y", "sigma_x", "Re", "FxRR", "Fy_gamma",
          "Mz_gamma", "Mx_gamma", "f_nat")
#: Tests whose set loads are the loads at which CFz is reported.
_GRID_TESTS = ("lateral_stiffness", "relaxation", "free_rolling", "camber")


@dataclass(frozen=True, eq=False)
class Extraction:
    """Characteristics extracted from a measurement set, with how and with what problems.

    Attributes
    ----------
    characteristics : pandas.DataFrame
        ``quantity, pi_bar, Fz_N, value, unit, Vx_mps, gamma_deg, mode`` (SI values, pressure
        in bar), one row per quantity and cell.
    diagnostics : tuple of RunDiagnostic
        One per run used (window, fit quality, flags, test-specific numbers).
    flags : tuple of dict
        ``{run, test, flag, detail}``; ``flag`` in stick_slip, short_run, asymmetry, spread,
        condition.
    thresholds : Thresholds
        Settings used.
    notes : tuple of str
        Runs skipped, rows dropped, and similar remarks.
    source : dict
        Folder path, tyre id and the mfid version.
    seconds : float
        Wall time of the extraction [s].
    """

    characteristics: pd.DataFrame
    diagnostics: tuple[RunDiagnostic, ...]
    flags: tuple[dict, ...]
    thresholds: Thresholds = field(default_factory=Thresholds)
    notes: tuple[str, ...] = ()
    source: dict = field(default_factory=dict)
    seconds: float = 0.0

    def diagnostics_frame(self) -> pd.DataFrame:
        """The per-run diagnostics as a table (one row per run; extras left out)."""
        recs = [{k: v for k, v in d.to_dict().items() if k != "extra"} for d in self.diagnostics]
        frame = pd.DataFrame.from_records(recs)
        if not frame.empty:
            frame["r2"] = [d.r2 for d in self.diagnostics]
            frame["rmse"] = [d.rmse for d in self.diagnostics]
            frame = frame.drop(columns="fit")
        return frame

    def summary(self) -> str:
        """One line: rows, runs and flags by kind."""
        kinds: dict[str, int] = {}
        for f in self.flags:
            kinds[f["flag"]] = kinds.get(f["flag"], 0) + 1
        flags = ", ".join(f"{n} {k}" for k, n in sorted(kinds.items())) or "no flags"
        return (f"{len(self.characteristics)} characteristics from {len(self.diagnostics)} "
                f"runs; {flags}")

    def to_dict(self) -> dict[str, Any]:
        """JSON-safe dict: the content of ``extraction.json``."""
        return json_safe({
            "schema": SCHEMA, "source": dict(self.source), "seconds": self.seconds,
            "thresholds": self.thresholds.to_dict(),
            "characteristics": self.characteristics.to_dict("records"),
            "runs": [d.to_dict() for d in self.diagnostics],
            "flags": [dict(f) for f in self.flags], "notes": list(self.notes)})


def _grid_loads(runs: dict) -> dict[float, list[float]]:
    loads: dict[float, set[float]] = {}
    tests = [t for t in _GRID_TESTS if t in runs] or [t for t in runs if t != "vertical"]
    for test in tests:
        for run in runs[test]:
            loads.setdefault(run.p_bar, set()).add(run.load_N)
    return {p: sorted(v) for p, v in loads.items()}


def extract_folder(measurement_set, thresholds: Thresholds | None = None) -> Extraction:
    """Extract every Flatplank characteristic of a measurement set.

    Parameters
    ----------
    measurement_set : MeasurementSet
        A loaded folder (:func:`identify.io.folder.load_folder`).
    thresholds : Thresholds, optional
        Flag thresholds and window settings (defaults: :class:`Thresholds`).

    Returns
    -------
    Extraction
    """
    began = time.perf_counter()
    th = thresholds or Thresholds()
    manifest = measurement_set.manifest
    declared = {r.id: dict(r.conditions) for r in manifest.runs}
    runs, skipped = collect_runs(measurement_set.flatplank, declared)
    notes = [f"run '{r}' skipped: no declared pressure and none in its name" for r in skipped]
    flags = [Flag(r, "unknown", "condition", "no declared pressure: run not used")
             for r in skipped]
    get = lambda test: runs.get(test, [])  # noqa: E731
    parts: list[Part] = []
    if get("vertical"):
        parts.append(extract_vertical(get("vertical"), _grid_loads(runs),
                                      float(manifest.tyre.nominal_load_N), th))
    for test in ("longitudinal_stiffness", "lateral_stiffness"):
        if get(test):
            parts.append(extract_stiffness(get(test), th))
    if get("parking"):
        parts.append(extract_parking(get("parking"), th))
    if get("relaxation"):
        parts.append(extract_relaxation(get("relaxation"), th))
    references = [r for r in get("relaxation") if abs(r.alpha_deg) < 0.05] + \
        [r for r in get("camber") if abs(r.gamma_deg) < 0.05]
    if get("free_rolling") or references:
        parts.append(extract_rolling(get("free_rolling"), references, th))
    if get("camber"):
        parts.append(extract_camber(get("camber"), th))
    for d in (d for p in parts for d in p.diagnostics):
        if not np.isfinite(d.value):
            why = d.extra.get("error", "the fit failed")
            notes.append(f"run '{d.run}': no {d.quantity} estimate ({why})")
    rows = [r for p in parts for r in p.rows]
    extra, dropped = pass_through(measurement_set.characteristics, rows)
    notes += dropped
    table = pd.DataFrame.from_records(rows + extra, columns=list(COLUMNS))
    if not table.empty:
        rank = {q: i for i, q in enumerate(_ORDER)}
        table = table.assign(_r=table["quantity"].map(lambda q: rank.get(q, len(rank))),
                             _g=table["gamma_deg"].fillna(0.0))
        table = table.sort_values(["_r", "pi_bar", "Fz_N", "_g", "mode"], kind="stable")
        table = table.drop(columns=["_r", "_g"]).reset_index(drop=True)
    flags += [f for p in parts for f in p.flags]
    source = {"path": measurement_set.path, "tyre_id": manifest.tyre.id,
              "tyre_source": manifest.tyre.source, "mfid_version": __version__,
              "runs_by_test": {t: len(v) for t, v in runs.items()}}
    return Extraction(table, tuple(d for p in parts for d in p.diagnostics),
                      tuple(f.to_dict() for f in flags), th, tuple(notes), source,
                      time.perf_counter() - began)
