"""The data-quality pages: data flags (fit.json and extraction.json) counted by kind, fit
diagnostics and report notes, then every flag run by run."""
from __future__ import annotations

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
    text_block,
)


def quality_pages(fd: FitDir, notes: Sequence[str]) -> list[Page]:
    """Every data-quality flag (fit.json and extraction.json), fit diagnostics, report notes.

    First page: flags counted by kind and test (or "no flags"), fit diagnostics and notes;
    then the full list of flags, run by run."""
    flags = T.data_flags(fd.run, fd.extraction)
    diags = T.fit_diagnostics(fd.run)
    fig = new_page("Data quality",
                   f"{len(flags)} data flag(s) from extraction (stick-slip, short runs, "
                   "asymmetry, spread, conditions); fit diagnostics; report notes")
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
    lines = ["Fit diagnostics:"]
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
    pages = [("data quality", fig)]
    per_page = rows_fitting(0.82 * PAGE[1], 7)
    parts = T.chunks(flags, per_page) if flags else []
    for i, part in enumerate(parts):
        lfig = new_page(f"Data flags ({i + 1}/{len(parts)})",
                        f"flags {i * per_page + 1}-{i * per_page + len(part)} of {len(flags)}")
        lax = lfig.add_axes((0.04, 0.06, 0.92, 0.82))
        draw_table(lax, ["run", "test", "flag", "detail"],
                   [[f["run"], f["test"], f["flag"], f["detail"][:110]] for f in part],
                   [0.22, 0.14, 0.1, 0.54], fontsize=7)
        footer(lfig, fd)
        pages.append(("data flags", lfig))
    return pages
