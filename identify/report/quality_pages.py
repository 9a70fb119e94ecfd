"""The data-quality pages: data flags (fit.json and extraction.json) counted by kind, which
flagged runs were used in the fit and which excluded, fit diagnostics and report notes, then
every flag run by run with whether its run is in the fit."""
from __future__ import annotations

import math
import textwrap
from collections.abc import Sequence

from identify.io.fitdir import FitDir
from identify.report import tables as T
from identify.report.layout import (
    PAGE,
    Page,
    draw_table,
    footer,
    new_page,
    rows_fitting,
    table_pages,
    text_block,
)


def run_use(extraction) -> dict[str, str]:
    """run id -> "used" (its extracted value entered a characteristic) or "excluded" (the
    extraction gave it no value), from extraction.json's per-run records."""
    out: dict[str, str] = {}
    for r in (extraction or {}).get("runs") or ():
        if not isinstance(r, dict) or "run" not in r:
            continue
        v = r.get("value")
        try:
            finite = v is not None and math.isfinite(float(v))
        except (TypeError, ValueError):
            finite = False
        out[str(r["run"])] = "used" if finite else "excluded"
    return out


def quality_pages(fd: FitDir, notes: Sequence[str]) -> list[Page]:
    """Every data-quality flag (fit.json and extraction.json), fit diagnostics, report notes.

    First page: flags counted by kind and test (or "no flags"), fit diagnostics and notes;
    then the full list of flags, run by run."""
    flags = T.data_flags(fd.run, fd.extraction)
    diags = T.fit_diagnostics(fd.run)
    use = run_use(fd.extraction)
    flagged = sorted({f["run"] for f in flags if f.get("run")})
    used = [r for r in flagged if use.get(r) == "used"]
    excluded = [r for r in flagged if use.get(r) == "excluded"]
    fig = new_page("Data quality",
                   f"{len(flags)} data flag(s) from extraction (stick-slip, short runs, "
                   f"asymmetry, spread, conditions) on {len(flagged)} run(s): {len(used)} used "
                   f"(their value entered the characteristic), {len(excluded)} excluded (no "
                   "value); fit diagnostics; report notes")
    ax = fig.add_axes((0.04, 0.08, 0.40, 0.80))
    if flags:
        counts: dict[tuple[str, str], int] = {}
        for f in flags:
            counts[(f["flag"], f["test"])] = counts.get((f["flag"], f["test"]), 0) + 1
        rows = [[k[0], k[1], str(n)] for k, n in sorted(counts.items())]
        n_fit = rows_fitting(0.8 * PAGE[1], 8)
        if len(rows) > n_fit:
            rows = rows[:n_fit - 1] + [["...", f"{len(rows) - n_fit + 1} more kinds", ""]]
        draw_table(ax, ["flag", "test", "runs"], rows, [0.35, 0.5, 0.15], fontsize=8,
                   title="Data flags by kind (every flag: next pages)",
                   align=["left", "left", "right"])
    else:
        ax.set_axis_off()
        ax.text(0, 1, "Data flags", fontsize=9.5, weight="bold", va="top",
                transform=ax.transAxes)
        why = ("no raw runs were extracted" if fd.extraction is None
               else "the extraction flagged no run")
        ax.text(0, 0.95, f"no flags: {why}, and fit.json lists no flag", fontsize=9,
                va="top", transform=ax.transAxes)
    lines = [f"Flagged runs used: {len(used)}; excluded: {len(excluded)}"
             + (" (" + ", ".join(excluded[:6]) + (" ..." if len(excluded) > 6 else "") + ")"
                if excluded else ""), "", "Fit diagnostics:"]
    for d in diags[:16] or ["none: every fit converged, off its bounds"]:
        lines += textwrap.wrap(d, 88, initial_indent="  - ", subsequent_indent="    ")
    if len(diags) > 16:
        lines.append(f"  ... {len(diags) - 16} more")
    all_notes = list(fd.notes) + [n for n in notes if n]
    lines += ["", "Report notes:"]
    for n in all_notes[:12] or ["none"]:
        lines += textwrap.wrap(n, 88, initial_indent="  - ", subsequent_indent="    ")
    if len(all_notes) > 12:
        lines.append(f"  ... {len(all_notes) - 12} more")
    bx = fig.add_axes((0.48, 0.08, 0.48, 0.80))
    text_block(bx, lines[:60], fontsize=7.5)
    footer(fig, fd)
    flag_rows = [[f["run"], f["test"], f["flag"], use.get(f["run"], "n/a"), f["detail"][:100]]
                 for f in flags]
    return [("data quality", fig)] + table_pages(
        fd, "data flags", "Data flags", f"flags {{first}}-{{last}} of {len(flags)}",
        ["run", "test", "flag", "in the fit", "detail"], flag_rows, [0.24, 0.13, 0.08, 0.07, 0.48])
