"""The report's pages as matplotlib ``Figure`` objects (no pyplot state), one page each.

Every builder returns a list of ``(title, Figure)``; :mod:`identify.report.pdf` writes them.
Landscape A4, measured points as markers, model as lines, one colour per pressure (per load on
the MF slip pages, one panel per pressure).
"""
from __future__ import annotations

import math
from typing import Any, Mapping, Sequence

import numpy as np
import pandas as pd
from matplotlib import colormaps
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from identify.core.version import __version__
from identify.report import tables as T
from identify.report.curves import (X_LABEL, RelationCurves, SlipPage, group_key,
                                    relation_curves, secondary_columns)

PAGE = (11.69, 8.27)  # landscape A4 [in]
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "*")
STYLES = ("-", "--", ":", "-.")
RED = "#b00020"
GREY = "#666666"

Page = tuple[str, Figure]


def new_page(title: str, subtitle: str = "") -> Figure:
    fig = Figure(figsize=PAGE)
    fig.text(0.04, 0.955, title, fontsize=15, weight="bold", va="top")
    if subtitle:
        import textwrap

        lines = textwrap.wrap(subtitle, 165)
        if len(lines) > 2:
            lines = lines[:2]
            lines[1] = lines[1][:160] + " ..."
        fig.text(0.04, 0.915, "\n".join(lines), fontsize=9, color=GREY, va="top")
    return fig


def footer(fig: Figure, fd, text: str = "") -> None:
    left = f"{fd.tyre_id} - mfid {__version__}"
    fig.text(0.04, 0.02, left, fontsize=7, color=GREY)
    if text:
        fig.text(0.96, 0.02, text, fontsize=7, color=GREY, ha="right")


def pressure_colours(pressures: Sequence[float]) -> dict[float, Any]:
    """One colour per pressure, ordered from low (dark) to high (light)."""
    ps = sorted(set(round(float(p), 4) for p in pressures if math.isfinite(float(p))))
    cmap = colormaps["viridis"]
    if len(ps) == 1:
        return {ps[0]: cmap(0.35)}
    return {p: cmap(0.05 + 0.8 * i / (len(ps) - 1)) for i, p in enumerate(ps)}


def load_colours(loads: Sequence[float]) -> dict[float, Any]:
    ls = sorted(set(float(v) for v in loads))
    cmap = colormaps["plasma"]
    if len(ls) == 1:
        return {ls[0]: cmap(0.2)}
    return {v: cmap(0.05 + 0.75 * i / (len(ls) - 1)) for i, v in enumerate(ls)}


def draw_table(ax, columns: Sequence[str], rows: Sequence[Sequence[str]],
               widths: Sequence[float], *, fontsize: float = 8.0, title: str = "",
               colours: Sequence[Any] | None = None, bold_first: bool = False,
               align: Sequence[str] | None = None) -> None:
    """A plain text table in an axes (axes coordinates, top down), with rules under the
    header and at the end. ``widths`` are fractions of the axes width."""
    ax.set_axis_off()
    fig = ax.figure
    h_in = ax.get_position().height * fig.get_figheight()
    dy = fontsize * 1.55 / 72 / h_in
    y = 1.0
    if title:
        ax.text(0, y, title, fontsize=fontsize + 1.5, weight="bold", va="top",
                transform=ax.transAxes)
        y -= 1.5 * dy
    xs = np.concatenate([[0.0], np.cumsum(widths)[:-1]])
    align = list(align or ["left"] * len(columns))

    def put(row, yy, weight="normal", colour="black"):
        for x, w, text, al in zip(xs, widths, row, align):
            xx = x + (w - 0.01 if al == "right" else 0.0)
            ax.text(xx, yy, str(text), fontsize=fontsize, va="top", ha=al, weight=weight,
                    color=colour, transform=ax.transAxes, clip_on=False)
    put(columns, y, weight="bold")
    y -= dy
    ax.plot([0, sum(widths)], [y + 0.2 * dy] * 2, color="black", lw=0.6,
            transform=ax.transAxes, clip_on=False)
    for i, row in enumerate(rows):
        put(row, y, weight="bold" if bold_first and i == 0 else "normal",
            colour=(colours[i] if colours is not None else "black"))
        y -= dy
    ax.plot([0, sum(widths)], [y + 0.2 * dy] * 2, color="black", lw=0.4,
            transform=ax.transAxes, clip_on=False)


def rows_fitting(ax_height_in: float, fontsize: float) -> int:
    """How many table rows fit an axes of this height."""
    return max(1, int(ax_height_in / (fontsize * 1.55 / 72)) - 3)


def _text_block(ax, lines: Sequence[str], fontsize: float = 8.5, colour: str = "black"):
    ax.set_axis_off()
    ax.text(0, 1, "\n".join(lines), fontsize=fontsize, va="top", ha="left",
            transform=ax.transAxes, color=colour, linespacing=1.45)


# ----- cover -----------------------------------------------------------------------------------

def cover(fd) -> list[Page]:
    tyre, prov = fd.tyre, fd.provenance
    source = str(tyre.get("source") or "unknown")
    real = {"measured": "real (measured)", "simulated": "simulated"}.get(source, source)
    fig = new_page(f"Fit report: {fd.tyre_id}",
                   "Magic Formula with inflation pressure: pressure relations and MF "
                   "coefficients identified by mfid")
    settings = prov.get("settings") or {}
    inputs = list(prov.get("inputs") or [])
    setting_text = ", ".join(f"{k}={v}" for k, v in settings.items())
    lines = [
        f"tyre              {fd.tyre_id}",
        f"data              {real}",
        f"nominal           {T.fmt(T.num(tyre.get('nominal_pressure_Pa')) / 1e5)} bar, "
        f"{T.fmt(tyre.get('nominal_load_N'))} N",
        f"fitted            {prov.get('created_utc', 'n/a')} (UTC), mfid "
        f"{prov.get('mfid_version', 'n/a')}",
        f"report            mfid {__version__}",
        f".tir              {fd.tir_path.name} (FITTYP "
        f"{(fd.doc.get('tir') or {}).get('fittyp', 'n/a')})",
        f"seed              {prov.get('seed', 'n/a')}",
    ]
    lines += _wrap("settings          ", setting_text, 70)
    lines += _wrap("command           ", str(prov.get("command") or "n/a"), 70)
    ax = fig.add_axes((0.04, 0.60, 0.50, 0.29))
    ax.set_axis_off()
    ax.text(0, 1, "\n".join(lines), fontsize=7.5, family="monospace", va="top",
            transform=ax.transAxes, linespacing=1.35)
    files = [f"input files ({len(inputs)}), SHA-256 (first 16 hex digits):"]
    shown = inputs if len(inputs) <= 12 else inputs[:8]
    for i in shown:
        files.append(f"  {_short_path(i.get('path'), fd):<40.40} {str(i.get('sha256', ''))[:16]}")
    if len(shown) < len(inputs):
        by_dir: dict[str, int] = {}
        for i in inputs[len(shown):]:
            rel = _short_path(i.get("path"), fd)
            d = rel.rsplit("/", 1)[0] + "/" if "/" in rel else "./"
            by_dir[d] = by_dir.get(d, 0) + 1
        files.append("  ... and " + ", ".join(f"{n} more in {d}" for d, n in by_dir.items()))
        files.append("  (every file and its checksum: appendix)")
    fax = fig.add_axes((0.56, 0.60, 0.40, 0.29))
    fax.set_axis_off()
    fax.text(0, 1, "\n".join(files), fontsize=7, family="monospace", va="top",
             transform=fax.transAxes, linespacing=1.35)
    if fd.failed:
        fig.text(0.04, 0.69, "FIT FAILED: " + "; ".join(fd.failed)[:170], fontsize=9,
                 color=RED, weight="bold", va="top")
    rows = T.summary_rows(fd.doc)
    fs = 8.0
    height_in = 0.60 * PAGE[1]
    while fs > 5.0 and rows_fitting(height_in, fs) < len(rows):
        fs -= 0.5
    per = rows_fitting(height_in, fs)
    parts = T.chunks(rows, per)
    pages = [("cover", fig)]
    for i, part in enumerate(parts):
        if i:
            fig = new_page(f"Fit report: {fd.tyre_id} (summary continued)")
        tax = fig.add_axes((0.04, 0.06, 0.92, 0.60 if i == 0 else 0.82))
        table = [[r.relation, r.form, T.fmt_pct(r.error_total_pct), str(r.n_points),
                  "yes" if r.converged else "NO", "yes" if r.in_tir else "",
                  r.key_coefficients[:95]] for r in part]
        draw_table(tax, ["relation", "form", "total error %", "points", "converged",
                         "-> .tir", "key coefficients"], table,
                   [0.07, 0.12, 0.09, 0.06, 0.08, 0.06, 0.52], fontsize=fs,
                   title="Every fit: total thesis error (mean of the per-pressure errors)",
                   colours=[RED if not r.converged else "black" for r in part],
                   align=["left", "left", "right", "right", "left", "left", "left"])
        if not rows:
            tax.text(0, 0.8, "no fits", fontsize=9, transform=tax.transAxes)
        footer(fig, fd, "thesis metric: eps = 100 sqrt(sum (model - meas)^2 / sum meas^2) per "
                        "pressure; total = mean over pressures")
        if i:
            pages.append(("cover (continued)", fig))
    return pages


def _wrap(head: str, text: str, width: int) -> list[str]:
    import textwrap

    body = textwrap.wrap(text, width) or [""]
    return [head + body[0]] + [" " * len(head) + b for b in body[1:]]


def _short_path(path: Any, fd) -> str:
    text = str(path or "")
    src_root = None  # paths relative to the measurement folder where possible
    for inp in fd.provenance.get("inputs") or []:
        p = str(inp.get("path", ""))
        if p.endswith("tyre.toml"):
            src_root = p[: -len("tyre.toml")]
    if src_root and text.startswith(src_root):
        return text[len(src_root):]
    return text if len(text) <= 60 else "..." + text[-57:]


def inputs_appendix(fd) -> list[Page]:
    """Every input file and its SHA-256 (only when the cover could not list them all)."""
    inputs = list(fd.provenance.get("inputs") or [])
    if len(inputs) <= 12:
        return []
    per_col, cols = 64, 2
    pages = []
    for start in range(0, len(inputs), per_col * cols):
        chunk = inputs[start:start + per_col * cols]
        fig = new_page("Appendix: input files and SHA-256",
                       f"files {start + 1}-{start + len(chunk)} of {len(inputs)}")
        for c in range(cols):
            part = chunk[c * per_col:(c + 1) * per_col]
            if not part:
                continue
            ax = fig.add_axes((0.04 + 0.47 * c, 0.06, 0.45, 0.83))
            ax.set_axis_off()
            ax.text(0, 1, "\n".join(f"{_short_path(i.get('path'), fd):<48.48} "
                                    f"{str(i.get('sha256', ''))[:16]}" for i in part),
                    fontsize=5.6, family="monospace", va="top", transform=ax.transAxes,
                    linespacing=1.25)
        footer(fig, fd)
        pages.append(("inputs", fig))
    return pages


# ----- one page per fit ------------------------------------------------------------------------

def _unit(rows: pd.DataFrame) -> str:
    if "unit" in rows and rows["unit"].notna().any():
        return str(rows["unit"].dropna().iloc[0])
    return ""


def _x_values(rows: pd.DataFrame, xcol: str) -> np.ndarray:
    if xcol == "alpha_deg":
        return np.rad2deg(rows["alpha_rad"].to_numpy(float))
    return rows[xcol].to_numpy(float)


def _mf_x(rows: pd.DataFrame) -> str:
    """x-axis of an MF stage page: the slip quantity that varies most for its outputs."""
    q = set(rows["quantity"].astype(str)) if len(rows) else set()
    spread = {}
    for col, scale in (("alpha_rad", np.deg2rad(1.0)), ("kappa", 0.01), ("gamma_deg", 1.0),
                       ("Fz_N", 500.0)):
        v = rows[col].to_numpy(float) if col in rows else np.array([])
        v = v[np.isfinite(v)]
        spread[col] = float(np.ptp(v)) / scale if v.size else 0.0
    prefer = ["kappa"] if q <= {"Fx"} else ["gamma_deg"] if q <= {"Mx"} else \
        ["Fz_N"] if q <= {"Fz", "My", "Re"} else ["alpha_rad"]
    for col in prefer + sorted(spread, key=spread.get, reverse=True):
        if spread.get(col, 0) > 1:
            return "alpha_deg" if col == "alpha_rad" else col
    return "Fz_N"


def fit_pages(fd, fit: Mapping[str, Any]) -> tuple[list[Page], str]:
    """The page(s) of one fit and a note on how its model lines were drawn."""
    rows = fd.rows(fit)
    is_mf = str(fit.get("relation")) == "MF"
    note = ""
    if len(rows) == 0:
        curves = None
        xcol = "Fz_N"
        note = f"{T.label(fit)}: no measured-vs-model rows"
    elif is_mf:
        xcol = _mf_x(rows)
        curves = _joined(rows, xcol)
        note = ""
    else:
        rc = relation_curves(fd, fit, rows)
        curves, xcol = rc, rc.x_column
        if not rc.exact:
            note = f"{T.label(fit)}: {rc.note}"
    status = "converged" if fit.get("converged") else f"NOT CONVERGED: {fit.get('message')}"
    keys = T.tir_keys(fit, fd.key_sources)
    sub = (f"total thesis error {T.fmt_pct(fit.get('error_total_pct'))} %, "
           f"{fit.get('n_points')} points, objective {fit.get('objective')}, {status}, "
           f"{fit.get('starts_at_best')}/{fit.get('n_starts')} starts at the best value"
           + (f"; supplies {_keys_text(keys)} to the .tir" if keys else "; not used in the .tir"))
    fig = new_page(f"MF stage {fit.get('form')}" if is_mf else f"Relation {T.label(fit)}",
                   sub)
    unit = _unit(rows)
    quantity = str(rows["quantity"].iloc[0]) if len(rows) else str(fit.get("relation"))
    pcol = pressure_colours(rows["pi_bar"]) if len(rows) else {}
    ax = fig.add_axes((0.09, 0.47, 0.39, 0.37))
    rax = fig.add_axes((0.56, 0.47, 0.40, 0.37))
    if len(rows):
        _plot_fit(ax, rax, rows, curves, xcol, pcol, quantity, unit)
    else:
        for a in (ax, rax):
            a.text(0.5, 0.5, "no data rows", ha="center", transform=a.transAxes)
    # tables: thesis error (total first) and parameters
    eax = fig.add_axes((0.06, 0.07, 0.17, 0.32))
    draw_table(eax, ["pressure", "error %"], T.error_rows(fit), [0.6, 0.4], fontsize=8,
               title="Thesis error", bold_first=True, align=["left", "right"])
    prow = T.parameter_rows(fit, fd.key_sources)
    pax = fig.add_axes((0.27, 0.07, 0.70, 0.32))
    n_fit = rows_fitting(0.32 * PAGE[1], 7.5)
    first, rest = prow[:n_fit], prow[n_fit:]
    _param_table(pax, first, fit, more=len(rest))
    fixed = fit.get("fixed") or {}
    if fixed:
        text = "held fixed: " + ", ".join(f"{k}={T.fmt(v)}" for k, v in fixed.items())
        fig.text(0.27, 0.05, text[:200] + (" ..." if len(text) > 200 else ""), fontsize=7,
                 color=GREY)
    extra = []
    if fit.get("active_constraints"):
        extra.append("active constraints: " + "; ".join(fit["active_constraints"]))
    if note and not is_mf:
        extra.append(note)
    elif not is_mf and curves is not None:
        extra.append(curves.note)
    footer(fig, fd, "  |  ".join(extra)[:220])
    pages = [(T.label(fit), fig)]
    for i, part in enumerate(T.chunks(rest, rows_fitting(0.8 * PAGE[1], 7.5))):
        if not part:
            break
        cfig = new_page(f"{T.label(fit)}: parameters (continued, {i + 2})", sub)
        cax = cfig.add_axes((0.04, 0.06, 0.92, 0.82))
        _param_table(cax, part, fit)
        footer(cfig, fd)
        pages.append((T.label(fit) + " parameters", cfig))
    return pages, note


def _keys_text(keys: Sequence[str], limit: int = 8) -> str:
    if len(keys) <= limit:
        return ", ".join(keys)
    return f"{len(keys)} keys ({', '.join(keys[:limit])}, ...)"


def _bounds_text(lo: float, hi: float) -> str:
    """[lo, hi]; JSON stores infinite bounds as null (NaN here): shown as -inf / inf."""
    if math.isnan(lo) and math.isnan(hi):
        return "none"
    a = "-inf" if math.isnan(lo) else T.fmt(lo, 3)
    b = "inf" if math.isnan(hi) else T.fmt(hi, 3)
    return f"[{a}, {b}]"


def _param_table(ax, prow, fit, more: int = 0) -> None:
    how = {r.interval for r in prow}
    title = "Parameters (free): 95 % interval " + (" / ".join(sorted(how)) if how else "")
    if more:
        title += f"   ({more} more on the next page)"
    table = [[r.name, T.fmt(r.value, 6), T.fmt(r.stderr, 3), T.fmt(r.lo95, 4),
              T.fmt(r.hi95, 4), _bounds_text(r.lower, r.upper),
              "AT BOUND" if r.at_bound else "", "yes" if r.in_tir else ""] for r in prow]
    draw_table(ax, ["parameter", "value", "std. error", "95 % low", "95 % high", "bounds",
                    "at bound", ".tir"], table,
               [0.16, 0.14, 0.11, 0.12, 0.12, 0.21, 0.09, 0.05], fontsize=7.5, title=title,
               colours=[RED if r.at_bound else "black" for r in prow],
               align=["left", "right", "right", "right", "right", "left", "left", "left"])
    if not prow:
        ax.text(0, 0.8, "no free parameters", fontsize=8, transform=ax.transAxes)


class _Joined:
    """Model lines that join the recorded model values (MF stages)."""

    def __init__(self, rows: pd.DataFrame, xcol: str):
        self.x_column = xcol
        self.rows = rows
        self.exact = False
        self.note = "model lines join the model values at the measured points"


def _joined(rows, xcol):
    return _Joined(rows, xcol)


MAX_STYLED_LEVELS = 4
"""Above this many secondary levels (loads, cambers, speeds) the levels are not told apart by
marker and line style (an MF stage can hold dozens of sweeps): one marker, thin lines."""


def _plot_fit(ax, rax, rows, curves, xcol, pcol, quantity, unit) -> None:
    x = _x_values(rows, xcol)
    meas = rows["measured"].to_numpy(float)
    model = rows["model"].to_numpy(float)
    pis = np.round(rows["pi_bar"].to_numpy(float), 4)
    sec = secondary_columns(rows, xcol if xcol != "alpha_deg" else "alpha_rad")
    keys = group_key(rows, sec)
    levels = sorted(set(keys))
    level_of = {k: j for j, k in enumerate(levels)}
    idx = np.array([level_of[k] for k in keys], dtype=int)
    styled = len(levels) <= MAX_STYLED_LEVELS
    many = len(rows) > 400
    ms = 2.0 if many else 4.5
    for p in sorted(set(pis)):
        c = pcol.get(round(float(p), 4), "black")
        for j in range(len(levels)):
            sel = (pis == p) & (idx == j)
            if not sel.any():
                continue
            mk = MARKERS[j % len(MARKERS)] if styled else "o"
            hollow = styled and j > 0
            ax.plot(x[sel], meas[sel], mk, color=c, ms=ms, mfc="none" if hollow else c,
                    mew=0.8, ls="none", alpha=0.5 if many else 1.0)
            rax.plot(x[sel], model[sel] - meas[sel], mk, color=c, ms=ms * 0.9, ls="none",
                     mfc="none" if hollow else c, alpha=0.5 if many else 1.0)
    if isinstance(curves, RelationCurves):
        for cv in curves.curves:
            c = pcol.get(round(cv.pi_bar, 4), "black") if math.isfinite(cv.pi_bar) else "black"
            j = level_of.get(cv.group, 0)
            ax.plot(cv.x, cv.y, STYLES[j % len(STYLES)] if styled else "-", color=c, lw=1.3)
    else:  # joined model values per pressure and secondary level, sorted by x
        for p in sorted(set(pis)):
            for j in range(len(levels)):
                sel = (pis == p) & (idx == j)
                if sel.sum() < 2:
                    continue
                o = np.argsort(x[sel], kind="stable")
                ax.plot(x[sel][o], model[sel][o], STYLES[j % len(STYLES)] if styled else "-",
                        color=pcol.get(round(float(p), 4), "black"), lw=1.0 if styled else 0.6)
    ax.set_xlabel(X_LABEL.get(xcol, xcol))
    ax.set_ylabel(f"{quantity} [{unit}]" if unit else quantity)
    title = "measured (markers) and model (lines)"
    if len(levels) > 1 and not styled:
        title += f": one line per {', '.join(_cond_name(c) for c in sec)} level " \
                 f"({len(levels)} levels)"
    ax.set_title(title, fontsize=8 if len(title) > 50 else 9)
    ax.grid(alpha=0.3)
    rax.axhline(0, color="black", lw=0.8)
    rax.set_xlabel(X_LABEL.get(xcol, xcol))
    rax.set_ylabel(f"model - measured [{unit}]" if unit else "model - measured")
    rax.set_title("residuals", fontsize=9)
    rax.grid(alpha=0.3)
    handles = [Line2D([], [], color=c, marker="o", ls="-", label=f"{p:g} bar")
               for p, c in pcol.items()]
    for j, k in enumerate(levels if 1 < len(levels) and styled else []):
        text = ", ".join(f"{_cond_name(c)} {v:.4g}" for c, v in k)
        handles.append(Line2D([], [], color="black", marker=MARKERS[j % len(MARKERS)],
                              mfc="none" if j else "black", ls=STYLES[j % len(STYLES)],
                              label=text))
    if handles:
        ax.legend(handles=handles, fontsize=6.5, loc="best", ncol=2 if len(handles) > 6 else 1)


def _cond_name(col: str) -> str:
    return {"Fz_N": "Fz [N]", "gamma_deg": "gamma [deg]", "Vx_mps": "Vx [m/s]"}.get(col, col)


# ----- MF slip pages ---------------------------------------------------------------------------

def slip_pages(fd, pages: Sequence[SlipPage]) -> list[Page]:
    out = []
    for sp in pages:
        fig = new_page(f"MF: {sp.title}",
                       "model from the written .tir (identify.model.evaluate, useMode 211) "
                       "over the measured range; measured points of the MF stages as markers;"
                       " one panel per pressure, one colour per load")
        n = len(sp.panels)
        ncol = n if n <= 3 else 3 if n != 4 else 2
        nrow = int(math.ceil(n / ncol)) if n else 1
        lcol = load_colours(sp.panels[0].loads) if n else {}
        axes = []
        for i, panel in enumerate(sp.panels):
            r, c = divmod(i, ncol)
            w, h = 0.86 / ncol, 0.78 / nrow
            ax = fig.add_axes((0.07 + c * w, 0.08 + (nrow - 1 - r) * h, w - 0.06, h - 0.08))
            axes.append(ax)
            if sp.ellipse:
                na = len(sp.alphas_deg)
                for j, fz in enumerate(panel.loads):
                    for m, a in enumerate(sp.alphas_deg):
                        for sign in (0, 1):  # +alpha and -alpha
                            xs, ys = panel.curves[(2 * j + sign) * na + m]
                            ax.plot(xs, ys, STYLES[m % len(STYLES)], color=lcol[fz], lw=1.1)
                ax.set_aspect("equal", adjustable="datalim")
            else:
                for j, fz in enumerate(panel.loads):
                    xs, ys = panel.curves[j]
                    ax.plot(xs, ys, "-", color=lcol[fz], lw=1.3)
                    if panel.points and panel.points[j][0].size:
                        px, py = panel.points[j]
                        ax.plot(px, py, "o", color=lcol[fz], ms=2.5, alpha=0.6, ls="none")
            ax.set_title(f"{panel.pi_bar:g} bar", fontsize=9)
            ax.set_xlabel(sp.xlabel, fontsize=8)
            ax.set_ylabel(sp.ylabel, fontsize=8)
            ax.tick_params(labelsize=7)
            ax.grid(alpha=0.3)
        if axes:
            handles = [Line2D([], [], color=c, lw=1.5, label=f"Fz {fz:.0f} N")
                       for fz, c in lcol.items()]
            if sp.ellipse:
                handles += [Line2D([], [], color="black", ls=STYLES[m % len(STYLES)],
                                   label=f"alpha +/-{a:.1f} deg")
                            for m, a in enumerate(sp.alphas_deg)]
            else:
                handles.append(Line2D([], [], color="black", marker="o", ls="none", ms=3,
                                      label="measured"))
            axes[0].legend(handles=handles, fontsize=6.5, loc="best")
        footer(fig, fd)
        out.append((f"MF {sp.title.split(' (')[0]}", fig))
    return out


# ----- MCMC ------------------------------------------------------------------------------------

def _read_chain(path):
    import emcee

    backend = emcee.backends.HDFBackend(str(path), name="mcmc", read_only=True)
    return backend.get_chain()  # (steps, walkers, ndim)


def mcmc_pages(fd, fit: Mapping[str, Any]) -> tuple[list[Page], str]:
    """Corner plot, walker traces and the tau/acceptance table of one fit with MCMC."""
    mc = fit.get("mcmc")
    if not mc:
        return [], ""
    name = T.label(fit)
    names = list((mc.get("median") or {}).keys())
    free = list((fit.get("parameters") or {}).keys())
    tau = mc.get("tau") or {}
    sub = (f"acceptance {T.fmt(mc.get('acceptance'), 3)}, {mc.get('n_walkers')} walkers x "
           f"{mc.get('n_steps')} steps, discard {mc.get('n_discard')}, thin {mc.get('n_thin')}"
           f", ~{mc.get('n_samples')} effective samples, "
           f"{'chain > 50 tau' if mc.get('converged') else 'CHAIN SHORTER THAN 50 TAU'}, "
           f"seed {mc.get('seed')}")
    pages: list[Page] = []
    note = ""
    chain_path = fd.chain_file(fit)
    chain = None
    if chain_path is not None:
        try:
            chain = _read_chain(chain_path)
        except Exception as exc:  # noqa: BLE001 - an unreadable chain only loses the plots
            note = f"{name}: MCMC chain {chain_path.name} unreadable ({exc})"
    else:
        note = f"{name}: MCMC chains not saved; corner plot and traces left out"
    params = fit.get("parameters") or {}
    rows = []
    for n in names:
        rows.append([n, T.fmt(params.get(n), 6) if n in params else "(noise)",
                     T.fmt((mc.get("median") or {}).get(n), 6),
                     T.fmt((mc.get("q025") or {}).get(n), 5),
                     T.fmt((mc.get("q975") or {}).get(n), 5), T.fmt(tau.get(n), 4)])
    fig = new_page(f"MCMC {name}: posterior", sub)
    if chain is not None:
        steps, walkers, ndim = chain.shape
        labels = (free + ["log_sigma", "phi"])[:ndim] if len(names) != ndim else names
        discard = int(mc.get("n_discard") or 0)
        thin = max(1, int(mc.get("n_thin") or 1))
        flat = chain[min(discard, max(steps - 1, 0))::thin].reshape(-1, ndim)
        show = list(range(min(ndim, 10)))
        try:
            import corner

            corner.corner(flat[:, show], labels=[labels[i] for i in show], fig=fig,
                          quantiles=[0.025, 0.5, 0.975], show_titles=True, title_fmt=".4g",
                          title_kwargs={"fontsize": 6.5}, label_kwargs={"fontsize": 7},
                          max_n_ticks=3)
            fig.subplots_adjust(left=0.07, right=0.52, bottom=0.1, top=0.84, wspace=0.06,
                                hspace=0.06)
            for a in fig.axes:
                a.tick_params(labelsize=5.5)
            fig.text(0.07, 0.875, f"corner plot: {flat.shape[0]} samples after burn-in and "
                                  "thinning" + (f" (first {len(show)} of {ndim} parameters)"
                                                if ndim > len(show) else ""),
                     fontsize=8, va="top")
        except Exception as exc:  # noqa: BLE001 - no corner plot is a note, not a failure
            note = f"{name}: corner plot failed ({exc})"
    ax = fig.add_axes((0.56, 0.1, 0.41, 0.76) if chain is not None else (0.04, 0.08, 0.92, 0.78))
    draw_table(ax, ["parameter", "least sq.", "median", "2.5 %", "97.5 %", "tau"], rows,
               [0.3, 0.15, 0.15, 0.14, 0.14, 0.1], fontsize=7,
               title="Posterior (least-squares optimum kept apart)",
               align=["left", "right", "right", "right", "right", "right"])
    if note:
        fig.text(0.04, 0.05, note, fontsize=8, color=GREY)
    footer(fig, fd)
    pages.append((f"MCMC {name} posterior", fig))
    if chain is None:
        return pages, note
    per_page = 6
    for start in range(0, ndim, per_page):
        idx = list(range(start, min(ndim, start + per_page)))
        tfig = new_page(f"MCMC {name}: walker traces"
                        + (f" ({start // per_page + 1})" if ndim > per_page else ""), sub)
        h = 0.8 / len(idx)
        for r, i in enumerate(idx):
            ax = tfig.add_axes((0.08, 0.08 + (len(idx) - 1 - r) * h, 0.88, h - 0.02))
            ax.plot(chain[:, :, i], color="black", alpha=max(0.05, min(0.4, 8 / walkers)),
                    lw=0.5)
            ax.axvline(discard, color=RED, lw=0.8)
            ax.set_ylabel(labels[i], fontsize=7)
            ax.tick_params(labelsize=6)
            t = tau.get(labels[i])
            if t is not None:
                ax.text(0.99, 0.9, f"tau {T.fmt(t, 3)}", transform=ax.transAxes, ha="right",
                        va="top", fontsize=7, color=GREY)
            if r < len(idx) - 1:
                ax.set_xticklabels([])
        ax.set_xlabel("step (red: burn-in discarded)")
        footer(tfig, fd)
        pages.append((f"MCMC {name} traces", tfig))
    return pages, note


# ----- data quality ----------------------------------------------------------------------------

def quality_pages(fd, notes: Sequence[str]) -> list[Page]:
    """Every data-quality flag (fit.json and extraction.json), fit diagnostics, report notes.

    First page: flags counted by kind and test (or "no flags"), fit diagnostics and notes;
    then the full list of flags, run by run."""
    import textwrap

    flags = T.data_flags(fd.doc, fd.extraction)
    diags = T.fit_diagnostics(fd.doc)
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
    _text_block(bx, lines[:60], fontsize=7.5)
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
