"""The PDF comparing the tyres of one ``mfid batch`` side by side (``batch_summary.pdf``).

Pages: an overview table (tyre, batch status, its fits counted by status, nominal conditions,
message or the fits that are not ok), every fit of every tyre with its status as ``mfid fit``
gives it (ok, poorly identified, failed) and its first reason, then per
group of up to :data:`PER_PAGE` tyres: the pressure sensitivities of the stiffnesses (relative
slope at the nominal pressure, bars one per tyre, and the .tir pressure coefficients), the
stiffnesses Cz, Cx, Cy against pressure, and the cornering stiffness and relaxation length
against pressure, one line per tyre.

Every curve is the tyre's written .tir evaluated by the model (``identify.model.evaluate``,
useMode ``FIT_MODE`` as in the fits) at its nominal load, zero slip and camber, over the
pressures it was measured at. A quantity is drawn for a tyre only when a fit supplied the .tir
keys it rests on (its ``key_sources`` say ``fitted``): a .tir default, or a key held at it, is
never shown as a result.
"""
from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from matplotlib import colormaps
from matplotlib.backends.backend_pdf import PdfPages

from identify.core.atomic import atomic_path
from identify.core.version import __version__
from identify.fit.sources import FITTED
from identify.io.fitdir import FitDir
from identify.model.evaluate import evaluate
from identify.model.modes import FIT_MODE
from identify.report.layout import GREY, ORANGE, RED, Page, draw_table, new_page, rows_fitting
from identify.report.tables import chunks, fmt, fmt_pct

if TYPE_CHECKING:  # pragma: no cover
    from identify.report.batch_summary import BatchEntry

__all__ = ["PER_PAGE", "QUANTITIES", "Quantity", "comparison_pages", "fit_counts",
           "tyre_curves", "write_comparison"]

OK_FIT, POOR_FIT, FAILED_FIT = "ok", "poorly identified", "failed"
"""The statuses of one fit (``FitResult.status_text``)."""
PER_PAGE = 10
"""Tyres per comparison page (one colour each)."""
N_PRESSURES = 41
DP_BAR = 0.05
"""Half step of the central difference of the sensitivities [bar]."""


@dataclass(frozen=True)
class Quantity:
    """A model output compared across tyres.

    Attributes
    ----------
    output : str            the name in ``evaluate``'s outputs
    label : str
    unit : str              the unit it is drawn in
    scale : float           SI value x scale = drawn value
    needs : tuple of str    .tir keys a fit must have supplied for it to be drawn
    coefficient : str       the .tir coefficient of its linear pressure dependence
    """

    output: str
    label: str
    unit: str
    scale: float
    needs: tuple[str, ...]
    coefficient: str


QUANTITIES = (
    Quantity("Cz", "vertical stiffness Cz", "N/mm", 1e-3, ("VERTICAL_STIFFNESS",), "PFZ1"),
    Quantity("Cx", "longitudinal stiffness Cx", "N/mm", 1e-3, ("LONGITUDINAL_STIFFNESS",),
             "PCFX3"),
    Quantity("Cy", "lateral stiffness Cy", "N/mm", 1e-3, ("LATERAL_STIFFNESS",), "PCFY3"),
    Quantity("Kya", "cornering stiffness |K_ya|", "N/deg", math.pi / 180, ("PKY1",), "PPY1"),
    Quantity("sigmay", "relaxation length sigma_y", "mm", 1e3, ("PKY1", "LATERAL_STIFFNESS"),
             ""),
)
_BY_NAME = {q.output: q for q in QUANTITIES}


@dataclass(frozen=True)
class TyreCurves:
    """One tyre's compared quantities: pressures [bar] and, per fitted quantity, its values
    (drawn units) and relative slope at the nominal pressure [% per bar]."""

    tyre_id: str
    p_bar: np.ndarray
    values: dict[str, np.ndarray]
    sensitivity_pct_per_bar: dict[str, float]


def _pressures(fd: FitDir, p0_bar: float) -> np.ndarray:
    p = fd.points["pi_bar"].to_numpy(float) if len(fd.points) else np.empty(0)
    p = p[np.isfinite(p)]
    lo, hi = (p.min(), p.max()) if p.size and p.max() > p.min() else (0.8 * p0_bar,
                                                                       1.2 * p0_bar)
    return np.linspace(lo, hi, N_PRESSURES)


def _outputs(tir, p_bar: np.ndarray) -> dict[str, np.ndarray]:
    n = p_bar.size
    zero = np.zeros(n)
    vx = float(tir.get("LONGVL") or 16.7)
    out = evaluate(tir, np.full(n, float(tir["FNOMIN"])), zero, zero, zero, np.full(n, vx),
                   p=p_bar * 1e5, mode=FIT_MODE)
    out["Kya"] = np.abs(out["Kya"])
    return out


def _fitted(fd: FitDir, key: str) -> bool:
    """Whether a fit identified .tir key ``key`` (every key has a source; most are defaults)."""
    source = fd.key_sources.get(key)
    return source is not None and source.kind == FITTED


def tyre_curves(fd: FitDir) -> TyreCurves | None:
    """The compared quantities of one fit directory (None without a readable .tir)."""
    if fd.tir is None:
        return None
    tir = dict(fd.tir)
    fitted = [q for q in QUANTITIES if all(_fitted(fd, k) for k in q.needs)]
    if not fitted:
        return TyreCurves(fd.tyre_id, np.empty(0), {}, {})
    p0 = float(tir.get("NOMPRES") or fd.tyre.nominal_pressure_Pa) / 1e5
    p = _pressures(fd, p0)
    with np.errstate(all="ignore"):
        curve = _outputs(tir, p)
        near = _outputs(tir, np.array([p0 - DP_BAR, p0, p0 + DP_BAR]))
        values = {q.output: curve[q.output] * q.scale for q in fitted}
        slopes = {q.output: float((near[q.output][2] - near[q.output][0]) / (2 * DP_BAR)
                                  / near[q.output][1] * 100) for q in fitted}
    return TyreCurves(fd.tyre_id, p, values, slopes)


def _footer(fig, text: str) -> None:
    fig.text(0.04, 0.02, f"mfid batch - mfid {__version__}", fontsize=7, color=GREY)
    fig.text(0.96, 0.02, text, fontsize=7, color=GREY, ha="right")


def fit_counts(fd: FitDir | None) -> dict[str, int]:
    """How many of a tyre's fits have each status (ok, poorly identified, failed), as
    ``mfid fit`` and fit.json give it; empty without a fit directory."""
    counts: dict[str, int] = {}
    for r in fd.results if fd is not None else ():
        counts[r.status_text] = counts.get(r.status_text, 0) + 1
    return counts


def _fits_cell(counts: dict[str, int]) -> str:
    n = sum(counts.values())
    if not n:
        return ""
    parts = [f"{counts[s]} {s}" for s in (OK_FIT, POOR_FIT, FAILED_FIT) if counts.get(s)]
    return ", ".join(parts) + f" of {n}"


def _tyre_message(e: BatchEntry) -> str:
    """The task's message, else the fits that are not ok, stage by stage."""
    if e.message:
        return e.message
    fd = e.fit
    poor = [r.name for r in fd.results if r.status_text != OK_FIT] if fd is not None else []
    return ("not ok: " + ", ".join(poor)) if poor else ""


def _overview(entries: Sequence[BatchEntry]) -> list[Page]:
    rows, colours = [], []
    for e in entries:
        fd = e.fit
        counts = fit_counts(fd)
        nominal = (f"{fmt(fd.nominal_pressure_bar, 3)} bar, {fmt(fd.nominal_load_N)} N"
                   if fd is not None else "")
        message = _tyre_message(e)
        rows.append([e.tyre_id or "?", e.status, _fits_cell(counts), nominal,
                     message[:80] + (" ..." if len(message) > 80 else "")])
        colours.append(RED if e.status not in ("ok", "up to date") or counts.get(FAILED_FIT)
                       else ORANGE if counts.get(POOR_FIT) else "black")
    per = rows_fitting(0.80 * 8.27, 8.0)
    pages = []
    parts = chunks(list(zip(rows, colours)), per) or [[]]
    for i, part in enumerate(parts):
        fig = new_page(f"Batch summary: {len(entries)} tyres",
                       "status of every folder (ok, failed: a fit did not converge, bad input, "
                       "lost: its worker died too often, up to date: not refitted, missing: "
                       "the fit directory of an earlier batch is gone); its fits "
                       "by status as mfid fit gives them (each fit on the pages 'Fits of "
                       "every tyre')")
        ax = fig.add_axes((0.04, 0.08, 0.92, 0.80))
        draw_table(ax, ["tyre", "status", "fits", "nominal", "message"],
                   [r for r, _ in part], [0.14, 0.08, 0.22, 0.13, 0.43], fontsize=8.0,
                   colours=[c for _, c in part])
        _footer(fig, f"overview {i + 1}/{len(parts)}")
        pages.append(("overview", fig))
    return pages


def _fit_rows(entries: Sequence[BatchEntry]) -> list[tuple[list[str], str]]:
    """One row per fit of every tyre: tyre, relation, form, total error, points, status, why
    (the first reason it is poorly identified, or why it failed)."""
    out = []
    for e in entries:
        if e.fit is None:
            continue
        for r in e.fit.results:
            why = r.message if not r.converged else r.reasons[0] if r.reasons else ""
            more = len(r.reasons) - 1 if r.converged and r.reasons else 0
            why = why[:95] + (" ..." if len(why) > 95 else "") + (f" (+{more} more)"
                                                                  if more else "")
            colour = (RED if r.status_text == FAILED_FIT else
                      ORANGE if r.status_text != OK_FIT else "black")
            out.append(([e.tyre_id, r.relation, r.form, fmt_pct(r.error_total_pct),
                         str(r.n_points), r.status_text, why], colour))
    return out


def _fit_pages(entries: Sequence[BatchEntry]) -> list[Page]:
    rows = _fit_rows(entries)
    per = rows_fitting(0.82 * 8.27, 7.0)
    parts = chunks(rows, per) if rows else []
    pages = []
    for i, part in enumerate(parts):
        fig = new_page(f"Fits of every tyre ({i + 1}/{len(parts)})",
                       "each fit's status as mfid fit and fit.json give it (ok, poorly "
                       "identified, failed) with its first reason (fit.json 'reasons')")
        ax = fig.add_axes((0.04, 0.06, 0.92, 0.82))
        draw_table(ax, ["tyre", "relation", "form", "total error %", "points", "status",
                        "why"], [r for r, _ in part],
                   [0.13, 0.07, 0.10, 0.08, 0.06, 0.11, 0.45], fontsize=7.0,
                   colours=[c for _, c in part],
                   align=["left", "left", "left", "right", "right", "left", "left"])
        _footer(fig, f"fits {i + 1}/{len(parts)}")
        pages.append(("fits", fig))
    return pages


def _colours(n: int) -> list:
    cmap = colormaps["tab10"]
    return [cmap(i % 10) for i in range(n)]


def _sensitivity_page(group: list[TyreCurves], fits: list[FitDir], tag: str) -> Page:
    fig = new_page("Pressure sensitivities of the stiffnesses",
                   "relative slope (1/C) dC/dp at the nominal pressure and load [% per bar], "
                   "from each tyre's .tir; below, the .tir's linear pressure coefficients")
    ax = fig.add_axes((0.07, 0.42, 0.70, 0.45))
    names = [q.output for q in QUANTITIES if q.coefficient]
    width = 0.8 / max(len(group), 1)
    for i, (tc, colour) in enumerate(zip(group, _colours(len(group)))):
        xs = [j + (i - (len(group) - 1) / 2) * width for j in range(len(names))]
        ys = [tc.sensitivity_pct_per_bar.get(n, np.nan) for n in names]
        ax.bar(xs, ys, width * 0.95, color=colour, label=tc.tyre_id)
    ax.set_xticks(range(len(names)), [_BY_NAME[n].label for n in names], fontsize=8)
    ax.axhline(0, color="black", lw=0.6)
    ax.set_ylabel("sensitivity [% per bar]")
    ax.grid(axis="y", alpha=0.3)
    if group:
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), frameon=False)
    coef = [q.coefficient for q in QUANTITIES if q.coefficient]
    rows = []
    for fd in fits:
        tir = fd.tir or {}
        rows.append([fd.tyre_id] + [fmt(tir.get(c)) if _fitted(fd, c) else "not fitted"
                                    for c in coef])
    tab = fig.add_axes((0.07, 0.07, 0.86, 0.28))
    draw_table(tab, ["tyre"] + coef, rows, [0.22] + [0.15] * len(coef), fontsize=8.0)
    _footer(fig, tag)
    return ("sensitivities", fig)


def _curve_page(title: str, names: Sequence[str], group: list[TyreCurves], tag: str) -> Page:
    fig = new_page(title, "each tyre's .tir at its nominal load, zero slip and camber, over the "
                          "pressures it was measured at; a tyre is left out of a panel when no "
                          "fit supplied that quantity")
    n = len(names)
    for j, name in enumerate(names):
        q = _BY_NAME[name]
        ax = fig.add_axes((0.07 + j * 0.86 / n, 0.12, 0.86 / n - 0.06, 0.72))
        shown = 0
        for tc, colour in zip(group, _colours(len(group))):
            if name in tc.values:
                ax.plot(tc.p_bar, tc.values[name], color=colour, lw=1.5, label=tc.tyre_id)
                shown += 1
        ax.set_title(q.label, fontsize=10)
        ax.set_xlabel("inflation pressure [bar]")
        ax.set_ylabel(f"{q.label.split()[-1]} [{q.unit}]")
        ax.grid(alpha=0.3)
        if shown:
            ax.legend(fontsize=7, frameon=False)
        else:
            ax.text(0.5, 0.5, f"not fitted for these tyres\n(needs {', '.join(q.needs)})",
                    ha="center", va="center", transform=ax.transAxes, color=GREY, fontsize=8)
    _footer(fig, tag)
    return (title, fig)


def comparison_pages(entries: Sequence[BatchEntry]) -> Iterator[Page]:
    """Every page of the comparison PDF, in order (made one group of tyres at a time)."""
    yield from _overview(entries)
    yield from _fit_pages(entries)
    fits = [e.fit for e in entries if e.fit is not None]
    groups = chunks(fits, PER_PAGE)
    for g, group in enumerate(groups):
        curves = [c for c in (tyre_curves(fd) for fd in group) if c is not None]
        tag = f"tyres {g * PER_PAGE + 1}-{g * PER_PAGE + len(group)} of {len(fits)}"
        yield _sensitivity_page(curves, group, tag)
        yield _curve_page("Stiffnesses vs pressure", ("Cz", "Cx", "Cy"), curves, tag)
        yield _curve_page("Cornering stiffness and relaxation length vs pressure",
                          ("Kya", "sigmay"), curves, tag)


def write_comparison(entries: Sequence[BatchEntry], path: str | Path) -> Path:
    """Write the comparison PDF atomically. Its CreationDate is the newest fit's time, so the
    same fits give the same file."""
    stamps = [e.fit.provenance.created for e in entries if e.fit is not None]
    stamps = [s for s in stamps if s is not None]
    meta = {"Title": f"mfid batch summary: {len(entries)} tyres",
            "Author": f"mfid {__version__}", "Creator": f"mfid {__version__} (matplotlib)",
            "Subject": "tyres of one mfid batch compared side by side"}
    if stamps:
        meta["CreationDate"] = max(stamps)
    with atomic_path(path) as tmp, PdfPages(tmp, metadata=meta) as pdf:
        for _, fig in comparison_pages(entries):
            pdf.savefig(fig)
            fig.clear()
    return Path(path)
