"""The page of the written .tir against every loaded trailer sample (fit.json ``every_sample``,
identify.fit.every_sample).

The stage pages judge each stage on the points it fitted; this page judges the model a user
will run on the whole session: every sample with a positive load, the ones the segmentation
left out and the runs a stage did not fit included. A table (per group of samples: the pooled
error and the mean of model - measured of each force and moment), and below it the offsets
found, each naming the group. A fit without trailer data has no page.
"""
from __future__ import annotations

import math
import textwrap

from identify.fit.every_sample import UNITS, EverySample
from identify.io.fitdir import FitDir
from identify.report.layout import (
    GREY,
    Page,
    draw_table,
    footer,
    new_page,
    rows_fitting,
    text_block,
)

TITLE = "The .tir against every measured sample"
BY_TITLES = {"all": "", "run": "kind of run", "segmentation": "segmentation",
             "pressure": "pressure"}
"""The row label of each grouping (the first row of a grouping carries it)."""


def _cell(e) -> str:
    if e is None or not math.isfinite(e.pooled_pct):
        return "-"
    return f"{e.pooled_pct:.1f} ({e.mean_error:+.3g})"


def table_rows(es: EverySample) -> tuple[list[str], list[list[str]]]:
    """The page's columns and rows: grouping, group, samples, then per channel the pooled
    error [%] and, in brackets, the mean of model - measured [N or N m]."""
    channels = [c for c in UNITS if any(c in g.channels for g in es.groups)]
    columns = ["by", "samples of", "n"] + [f"{c} % (mean err. {UNITS[c]})" for c in channels]
    rows, last = [], None
    for g in es.groups:
        by = BY_TITLES.get(g.by, g.by) if g.by != last else ""
        last = g.by
        rows.append([by, g.name, str(g.samples)] + [_cell(g.channels.get(c)) for c in channels])
    return columns, rows


def every_sample_pages(fd: FitDir) -> list[Page]:
    """The page (none when the fit had no trailer data to judge)."""
    es = EverySample.from_dict(fd.run.every_sample)
    if es is None or not es.groups:
        return []
    fig = new_page(TITLE, f"the written .tir (useMode of the fits) on all {es.samples} loaded "
                          "trailer samples with a positive load, fitted or not: pooled error "
                          "100 RMS(model - measured) / RMS(measured) [%], in brackets the mean "
                          "of model - measured")
    columns, rows = table_rows(es)
    n = len(columns) - 3
    top, room = 0.86, 0.56  # the table's axes, from the top; the notes right under its rows
    n_fit = rows_fitting(room * fig.get_figheight(), 8)
    if len(rows) > n_fit:  # many pressure levels: the rest are in fit.json
        rows = rows[:n_fit - 1] + [["", f"... {len(rows) - n_fit + 1} more groups in "
                                        "fit.json (every_sample)", ""] + [""] * n]
    used = (len(rows) + 2) * 8 * 1.55 / 72 / fig.get_figheight()
    ax = fig.add_axes((0.04, top - room, 0.92, room))
    draw_table(ax, columns, rows, [0.11, 0.19, 0.08] + [0.62 / n] * n, fontsize=8,
               align=["left", "left", "right"] + ["right"] * n)
    lines = ["Where the model sits on one side of a group of samples (mean error at least half "
             "the RMS error, pooled error above 20 %):"]
    lines += [f"  - {note}" for note in es.notes] or ["  none"]
    left = [g.name.removeprefix("left out: ") for g in es.groups
            if g.name.startswith("left out: ")]
    segmented = es.group("segmentation", "kept: sweeps") is not None
    slipping = any(g.by == "run" and g.name != "free rolling" for g in es.groups)
    how = ("The stages fit the sweeps the segmentation kept (averaged into bins)"
           + (f"; the {', '.join(left)} it left out are shown to say how the model meets "
              "what it was not fitted to" if left else "") if segmented else
           "The stages fit the runs as loaded (dense sweeps averaged into bins)") + "."
    if slipping:
        how += (" The pure side-slip and Mx stages fit the freely rolling runs: the Magic "
                "Formula's Mx has no slip-ratio term, so an Mx offset on the drive/brake "
                "samples is not fitted (a moment zero that differs between the runs' files "
                "shows the same way).")
    lines += ["", how]
    tx = fig.add_axes((0.04, max(0.04, top - used - 0.27), 0.92, 0.24))
    text_block(tx, [w for line in lines for w in (textwrap.wrap(line, 150) or [""])],
               fontsize=7.5, colour=GREY)
    footer(fig, fd)
    return [("every sample", fig)]
