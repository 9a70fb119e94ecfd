"""The fit summary as plain rows and text: one row per fit (relation, form, total thesis error,
points, status, whether it supplied .tir keys, key coefficients).

The same rows feed ``FitRun.report()``, the ``mfid fit`` table on the terminal and the report's
cover page; number formatting for all of them lives here. After the table come the form each
relation with a choice of form took and why, and the fits that are poorly identified with their
first reason (:func:`notes_text`).
"""
from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from identify.fit.relations.forms import FormChoice
from identify.fit.result import FitResult
from identify.fit.sources import KeySource
from identify.fit.status import FAILED, OK

__all__ = [
    "SUMMARY_TITLE",
    "SummaryRow",
    "fmt",
    "fmt_pct",
    "key_coefficients",
    "notes_lines",
    "num",
    "summary_rows",
    "summary_text",
    "tir_keys",
]

SUMMARY_TITLE = "fit summary (thesis error: mean of the per-pressure errors)"


def num(x: Any) -> float:
    """float(x), NaN for None or anything not a number."""
    try:
        return float(x)
    except (TypeError, ValueError):
        return math.nan


def fmt(x: Any, digits: int = 4) -> str:
    """A number with ``digits`` significant digits; "n/a" for NaN/None."""
    v = num(x)
    if not math.isfinite(v):
        return "n/a" if math.isnan(v) else ("inf" if v > 0 else "-inf")
    return f"{v:.{digits}g}"


def fmt_pct(x: Any) -> str:
    """A percentage: 3 decimals below 100, 1 above, 2 significant digits below 0.001 (a small
    error is not written as 0.000); "n/a" when not finite."""
    v = num(x)
    if not math.isfinite(v):
        return "n/a"
    if v != 0 and abs(v) < 0.0005:
        return f"{v:.2g}"
    return f"{v:.3f}" if abs(v) < 100 else f"{v:.1f}"


def tir_keys(result: FitResult, key_sources: Mapping[str, KeySource]) -> list[str]:
    """The .tir keys ``result`` supplied: those fitted by ``relation/form`` (MF stages:
    ``MF/<stage> (trailer)``), sorted."""
    tag = result.name
    return sorted(k for k, src in key_sources.items() if src.supplied_by == tag)


def key_coefficients(result: FitResult, limit: int = 4) -> str:
    """The free parameters as ``NAME=value`` (``limit`` of them, then "+n more")."""
    params = result.fitted
    items = [f"{k}={fmt(v)}" for k, v in params.items()]
    if len(items) > limit:
        items = items[:limit] + [f"+{len(params) - limit} more"]
    return ", ".join(items)


@dataclass(frozen=True)
class SummaryRow:
    """One fit in the summary table."""

    relation: str
    form: str
    error_total_pct: float
    n_points: int
    converged: bool
    in_tir: bool
    key_coefficients: str
    status: str = OK
    chosen: bool = False

    @property
    def status_cell(self) -> str:
        """The status as the table shows it (identify.fit.status.STATUSES; failed in capitals:
        ok, poorly identified, poor fit, FAILED)."""
        return "FAILED" if not self.converged or self.status == FAILED else self.status

    @property
    def tir_cell(self) -> str:
        """"x" when the fit supplied .tir keys ("x*": the form chosen among a nested pair)."""
        return ("x*" if self.chosen else "x") if self.in_tir else ""


def summary_rows(results: Iterable[FitResult], key_sources: Mapping[str, KeySource],
                 form_choices: Sequence[FormChoice] = ()) -> list[SummaryRow]:
    """One row per fit, in fit order."""
    chosen = {(c.relation, c.form) for c in form_choices}
    return [SummaryRow(r.relation, r.form, num(r.error_total_pct), int(r.n_points),
                       bool(r.converged), bool(tir_keys(r, key_sources)), key_coefficients(r),
                       r.status_text, (r.relation, r.form) in chosen)
            for r in results]


def notes_lines(form_choices: Sequence[FormChoice] = (),
                results: Sequence[FitResult] = ()) -> list[str]:
    """The lines after the summary table: the form each nested relation took and why
    (x* in the .tir column), then the fits whose status is not ok (failed, poor fit, poorly
    identified: identify.fit.status), counted per status, each with its first reason."""
    out = []
    for c in form_choices:
        how = "chosen by --form" if c.overridden else "chosen by the data"
        out.append(f"form {c.relation}: {c.form} ({how}): {c.reason}")
    results = list(results)
    for status in (FAILED, "poor fit", "poorly identified"):
        those = [r for r in results if r.status_text == status and r.converged]
        if not those:
            continue
        hint = ("; --hold NAME holds a coefficient at its default"
                if status == "poorly identified" else "")
        out.append(f"{status}: {len(those)} of {len(results)} fits (fit.json 'reasons'{hint})")
        for r in those:
            first = r.reasons[0] if r.reasons else ""
            more = f" (+{len(r.reasons) - 1} more)" if len(r.reasons) > 1 else ""
            floor = (f" [error {fmt_pct(r.error_total_pct)} %, noise floor "
                     f"{fmt_pct(r.noise_floor_pct)} %]"
                     if math.isfinite(r.noise_floor_pct) else "")
            out.append(f"  {r.name}{floor}: {first}{more}")
    return out


def summary_text(rows: Sequence[SummaryRow], failed: Sequence[str] = (),
                 form_choices: Sequence[FormChoice] = (),
                 results: Sequence[FitResult] = ()) -> str:
    """The summary table as plain text (the table ``mfid fit`` prints), then the form choices,
    the poorly identified fits and any failures."""
    head = ("relation", "form", "total error %", "points", "status", ".tir", "key coefficients")
    body = [(r.relation, r.form, fmt_pct(r.error_total_pct), str(r.n_points),
             r.status_cell, r.tir_cell, r.key_coefficients)
            for r in rows]
    widths = [max(len(row[i]) for row in [head, *body]) for i in range(len(head) - 1)]
    right = {2, 3}

    def line(row) -> str:
        cells = [c.rjust(w) if i in right else c.ljust(w)
                 for i, (c, w) in enumerate(zip(row, widths))]
        return "  ".join(cells + [row[-1]]).rstrip()

    out = [SUMMARY_TITLE, line(head), line(tuple("-" * len(h) for h in head))]
    out += [line(row) for row in body] or ["(no fits)"]
    out += notes_lines(form_choices, results)
    out += [f"FAILED {f}" for f in failed]
    return "\n".join(out)
