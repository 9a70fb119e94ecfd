"""The pressure prediction page: each measured pressure level predicted by the MF model fitted
without it, beside the error of the full fit at that level (fit.json ``pressure_holdout``,
identify.fit.mf.pressure_holdout).

A table (per level and force or moment stage: points, in-sample error, held-out error, their
ratio) and a bar plot (per stage, the in-sample and held-out error of every level side by side).
Where the hold-out was not computed, the page says why (one pressure level, or the fit was run
without ``--pressure-holdout``); a fit without MF stages has no page. The bars are on a
logarithmic scale: a level the remaining ones cannot predict can be off by orders of magnitude.
"""
from __future__ import annotations

import math
import textwrap

import numpy as np
from matplotlib.ticker import FuncFormatter, NullFormatter

from identify.fit.mf.pressure_holdout import FORCE_STAGES, PressureHoldout
from identify.io.fitdir import FitDir
from identify.report.layout import (
    GREY,
    Page,
    draw_table,
    footer,
    new_page,
    pressure_colours,
    rows_fitting,
    text_block,
)

TITLE = "Pressure prediction"
FEW_POINTS = 20
"""A stage with fewer points at a level is greyed: its errors there rest on a handful of
points (a few free-rolling points of a slip-ratio stage)."""


def _pct(x: float) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.2f}"


def _ratio(held: float, ins: float) -> str:
    if not (math.isfinite(held) and math.isfinite(ins)) or ins <= 0:
        return "-"
    return f"{held / ins:.2f}"


def table_rows(ph: PressureHoldout) -> list[list[str]]:
    """Rows of the page's table: level [bar], stage, points, in-sample %, held-out %, ratio."""
    rows = []
    for lv in ph.levels:
        for stage in (s for s in FORCE_STAGES if s in lv.heldout_pct):
            ins, held = lv.insample_pct.get(stage, math.nan), lv.heldout_pct[stage]
            rows.append([f"{lv.pressure_bar:.2f}", stage, str(lv.points.get(stage, 0)),
                         _pct(ins), _pct(held), _ratio(held, ins)])
    return rows


def pressure_pages(fd: FitDir) -> list[Page]:
    """The pressure prediction page (none when the fit has no MF stage of a force)."""
    if not any(r.relation == "MF" and r.form in FORCE_STAGES for r in fd.results):
        return []
    ph = PressureHoldout.from_dict(fd.run.pressure_holdout)
    if ph is None or not ph.levels:
        settings = fd.run.settings
        why = (ph.skipped if ph is not None and ph.skipped else
               "not computed: the fit ran without it (mfid fit --no-pressure-holdout, or a "
               "fit.json written before it was on by default); mfid fit refits the force and "
               "moment stages without each pressure level and predicts it" if settings is not None
               and not settings.pressure_holdout else "not computed for this fit")
        fig = new_page(TITLE, "each measured pressure predicted by the model fitted without it")
        ax = fig.add_axes((0.04, 0.1, 0.92, 0.75))
        text_block(ax, textwrap.wrap(f"No pressure hold-out: {why}.", 120), fontsize=10)
        footer(fig, fd)
        return [("pressure prediction", fig)]
    fig = new_page(TITLE, "each measured pressure level predicted by the MF stages fitted "
                          "without it (held-out), beside the full fit's error at that level "
                          "(in-sample); thesis error [%] on the level's fitted points")
    rows = table_rows(ph)
    n_fit = rows_fitting(0.62 * fig.get_figheight(), 7.5)
    shown = rows if len(rows) <= n_fit else rows[:n_fit - 1] + [
        ["...", f"{len(rows) - n_fit + 1} more rows in fit.json", "", "", "", ""]]
    ax = fig.add_axes((0.04, 0.22, 0.36, 0.64))
    few = [r[2].isdigit() and int(r[2]) < FEW_POINTS for r in shown]
    draw_table(ax, ["p [bar]", "stage", "points", "in-sample %", "held-out %", "ratio"], shown,
               [0.14, 0.14, 0.15, 0.2, 0.2, 0.14], fontsize=7.5,
               align=["right", "left", "right", "right", "right", "right"],
               colours=[GREY if f else "black" for f in few])
    note = (f"How: {ph.method}. {len(ph.levels)} refits, {ph.seconds:.1f} s in all. "
            + (f"Grey rows: under {FEW_POINTS} points at the level, too few for their ratio "
               "to say much. " if any(few) else "") +
            "A ratio near 1 says the pressure terms carry to a pressure the model never saw; "
            "with one level left, the pressure terms stay at their defaults and the ratio "
            "shows what the pressure changes.")
    if not all(lv.converged for lv in ph.levels):
        note += (" Not converged: the refit without "
                 + ", ".join(f"{lv.pressure_bar:.2f} bar" for lv in ph.levels
                             if not lv.converged) + ".")
    tx = fig.add_axes((0.04, 0.07, 0.38, 0.14))  # its lines run down from the top
    text_block(tx, textwrap.wrap(note, 92), fontsize=6.5, colour=GREY)
    _bars(fig.add_axes((0.47, 0.12, 0.50, 0.72)), ph)
    footer(fig, fd)
    return [("pressure prediction", fig)]


def _bars(ax, ph: PressureHoldout) -> None:
    """Per stage, for every level: the in-sample error (hatched, light) and the held-out error
    (solid), in the level's colour."""
    stages = [s for s in FORCE_STAGES if any(s in lv.heldout_pct for lv in ph.levels)]
    colours = pressure_colours([lv.pressure_bar for lv in ph.levels])
    n = len(ph.levels)
    width = 0.8 / max(n, 1)
    x = np.arange(len(stages), dtype=float)
    for i, lv in enumerate(ph.levels):
        c = colours[round(lv.pressure_bar, 4)]
        ins = [lv.insample_pct.get(s, math.nan) for s in stages]
        held = [lv.heldout_pct.get(s, math.nan) for s in stages]
        pos = x - 0.4 + (i + 0.5) * width
        ax.bar(pos, held, width * 0.9, color=c, label=f"{lv.pressure_bar:.2f} bar held out")
        ax.bar(pos, ins, width * 0.45, color="white", edgecolor="black", hatch="///", lw=0.5,
               label="in-sample (full fit)" if i == 0 else None)
    ax.set_xticks(x, stages)
    ax.set_yscale("log")
    # plain numbers (the log axis writes 10^0 and, under a decade, labels its minor ticks
    # 1.2 x 10^0): the minor ticks labelled only where the bars span less than a decade
    plain = FuncFormatter(lambda v, _pos: f"{v:g}")
    lo, hi = ax.get_ylim()
    ax.yaxis.set_major_formatter(plain)
    ax.yaxis.set_minor_formatter(plain if hi < 10 * lo else NullFormatter())
    ax.set_ylabel("thesis error at the level [%] (log scale)")
    ax.set_title("held-out (coloured) and in-sample (hatched) error per level", fontsize=9)
    ax.grid(axis="y", which="both", lw=0.3, alpha=0.6)
    ax.legend(fontsize=7, loc="upper left")
