"""A small PDF of a discovery run: the conclusion, the candidate table, residual maps.

Page 1 holds the plain conclusion, then the accepted effects and the first step's candidates
as tables.
Then, per problem (those with an accepted effect first, at most ``MAX_PROBLEMS``), binned
maps of the mean residual (model - measured, in % of the RMS of the measurement) over pairs of
conditions (pressure x camber, pressure x load, camber x load, or the swept slip), before
(base model) and after (final model), on one colour scale.
"""
from __future__ import annotations

import itertools
import textwrap
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_pdf import PdfPages
from matplotlib.figure import Figure

from identify.core.atomic import atomic_path
from identify.discover.result import Discovery, ProblemSummary
from identify.report.layout import GREY, PAGE, draw_table, new_page, rows_fitting, text_block

__all__ = ["write_pdf", "MAX_PROBLEMS"]

MAX_PROBLEMS = 6
_AXES = (("pressure_bar", "p [bar]"), ("Fz_N", "Fz [N]"), ("gamma_deg", "gamma [deg]"),
         ("alpha_deg", "alpha [deg]"), ("kappa", "kappa [-]"))


def _edges(x: np.ndarray, n: int = 8) -> tuple[np.ndarray, list[str]]:
    """Bin edges and tick labels: the values themselves when there are few, else quantile
    bins labelled by their centres."""
    u = np.unique(np.round(x, 6))
    if u.size <= n:
        mids = (u[1:] + u[:-1]) / 2
        return np.concatenate([[u[0] - 1], mids, [u[-1] + 1]]), [f"{v:.3g}" for v in u]
    e = np.unique(np.quantile(x, np.linspace(0, 1, n + 1)))
    return e, [f"{(a + b) / 2:.3g}" for a, b in zip(e[:-1], e[1:])]


def _binned(x, y, v, ex, ey) -> np.ndarray:
    ix = np.clip(np.searchsorted(ex, x, side="right") - 1, 0, ex.size - 2)
    iy = np.clip(np.searchsorted(ey, y, side="right") - 1, 0, ey.size - 2)
    total = np.zeros((ey.size - 1, ex.size - 1))
    count = np.zeros_like(total)
    np.add.at(total, (iy, ix), v)
    np.add.at(count, (iy, ix), 1)
    with np.errstate(invalid="ignore"):
        return np.where(count > 0, total / np.maximum(count, 1), np.nan)


def _pairs(a: dict) -> list[tuple[str, str]]:
    names = [k for k, _ in _AXES if k in a and np.unique(np.round(a[k], 6)).size > 1]
    return list(itertools.combinations(names, 2))[:3]


def _problem_page(pdf, s: ProblemSummary) -> None:
    a = dict(s.arrays)
    if "alpha_rad" in a:
        a["alpha_deg"] = np.rad2deg(a["alpha_rad"])
    pairs = _pairs(a)
    fig = Figure(figsize=(11.7, 8.3))
    axes = fig.subplots(2, max(len(pairs), 1), squeeze=False)
    fig.suptitle(f"{s.name}: thesis error {s.base_error_pct:.3g} % (base) -> "
                 f"{s.final_error_pct:.3g} % (final), noise floor {s.noise_floor_pct:.3g} %; "
                 f"noise model {s.noise.kind}", fontsize=10)
    rms = np.sqrt(np.mean(a["measured"] ** 2)) or 1.0
    maps = []
    for row, key in enumerate(("base_predicted", "final_predicted")):
        res = 100 * (a[key] - a["measured"]) / rms
        for col, (kx, ky) in enumerate(pairs):
            (ex, lx), (ey, ly) = _edges(a[kx]), _edges(a[ky])
            maps.append((row, col, kx, ky, ex, ey, lx, ly,
                         _binned(a[kx], a[ky], res, ex, ey)))
    lim = max([np.nanmax(np.abs(m[-1])) for m in maps if np.isfinite(m[-1]).any()] or [1.0])
    lim = lim if lim > 0 else 1.0
    labels = dict(_AXES)
    for row, col, kx, ky, ex, ey, lx, ly, grid in maps:
        ax = axes[row][col]
        im = ax.pcolormesh(np.arange(ex.size), np.arange(ey.size), grid, cmap="RdBu_r",
                           vmin=-lim, vmax=lim)
        ax.set_xticks(np.arange(ex.size - 1) + 0.5, lx, fontsize=6)
        ax.set_yticks(np.arange(ey.size - 1) + 0.5, ly, fontsize=6)
        ax.set_xlabel(labels[kx], fontsize=8)
        ax.set_ylabel(labels[ky], fontsize=8)
        ax.set_title(("before" if row == 0 else "after") + ": mean residual [% RMS]",
                     fontsize=8)
        fig.colorbar(im, ax=ax, fraction=0.046)
    if not pairs:
        for ax in axes.ravel():
            ax.text(0.5, 0.5, "one condition only: no map", ha="center", va="center")
            ax.set_axis_off()
    fig.tight_layout(rect=(0, 0, 1, 0.95))
    pdf.savefig(fig)


def _text_page(pdf, d: Discovery) -> None:
    """Page 1: the conclusion, then the accepted effects and the first step's candidates as
    tables with aligned columns, then each problem's noise note."""
    fig = new_page("mfid discover: which effect is the model missing?",
                   "conclusion, accepted effects, and the first step's candidates (sorted by "
                   "the Holm-adjusted p-value)")
    lines = []
    for line in d.conclusion.splitlines():
        lines += textwrap.wrap(line, 170, subsequent_indent="    ") or [""]
    top = fig.add_axes((0.04, 0.74, 0.92, 0.15))
    text_block(top, lines[:9], fontsize=8)
    acc = fig.add_axes((0.04, 0.56, 0.92, 0.17))
    rows = [[a.name, a.problem,
             ", ".join(f"{k} = {v:.4g} +/- {a.stderr.get(k, float('nan')):.2g}"
                       for k, v in a.coefficients.items())[:60],
             f"{a.error_before_pct:.3g} -> {a.error_after_pct:.3g}",
             f"{a.heldout_before_pct:.3g} -> {a.heldout_after_pct:.3g}",
             f"{a.p_value:.2g}", f"{a.excess_explained:.2f}"] for a in d.accepted[:6]]
    draw_table(acc, ["accepted", "problem", "coefficients", "error %", "held-out %", "p",
                     "explained"], rows or [["none", "", "", "", "", "", ""]],
               [0.09, 0.14, 0.37, 0.12, 0.12, 0.07, 0.09], fontsize=7.5,
               title="Accepted effects (error and held-out error before -> after)",
               align=["left", "left", "left", "right", "right", "right", "right"])
    cand = fig.add_axes((0.04, 0.06, 0.92, 0.48))
    n_rows = rows_fitting(0.48 * PAGE[1], 7.0)
    crow = []
    if d.steps:
        for r in sorted(d.steps[0].candidates, key=lambda r: r.p_holm)[:n_rows]:
            cos = ", ".join(f"{k} {v:.2f}" for k, v in r.cosines.items() if v > 0.5)
            crow.append([r.name, r.problem, f"{r.statistic:.3g}" if r.testable
                         else "untestable", f"{r.p_holm:.2g}",
                         f"{r.predicted_error_pct:.3g}", "yes" if r.passes else "",
                         cos[:60]])
    draw_table(cand, ["candidate", "problem", "statistic", "p (Holm)", "predicted error %",
                      "passes", "|cos| > 0.5 with"], crow or [["none", "", "", "", "", "",
                                                               ""]],
               [0.10, 0.16, 0.10, 0.09, 0.12, 0.07, 0.36], fontsize=7.0,
               title="Step 1 candidates",
               align=["left", "left", "right", "right", "right", "left", "left"])
    notes = [f"{p.name}: {p.noise.reason}" for p in d.problems]
    if notes:
        fig.text(0.04, 0.025, " | ".join(notes)[:260], fontsize=6.5, color=GREY)
    pdf.savefig(fig)


def write_pdf(d: Discovery, path: str | Path) -> Path:
    """Write the discovery PDF atomically; returns the path."""
    changed = {a.problem for a in d.accepted}
    probs = sorted(d.problems, key=lambda p: (p.name not in changed,
                                              -(p.base_error_pct - p.noise_floor_pct)))
    with atomic_path(path) as tmp:
        with PdfPages(tmp) as pdf:
            _text_page(pdf, d)
            for s in probs[:MAX_PROBLEMS]:
                _problem_page(pdf, s)
    return Path(path)
