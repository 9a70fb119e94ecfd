"""One page per fit (relation or MF stage): measured points and model lines, residuals, the
thesis error per pressure with the total first, the parameter table (continued on more pages
when it is long)."""
from __future__ import annotations

import math
import re
from collections.abc import Sequence

import numpy as np
import pandas as pd
from matplotlib.lines import Line2D

from identify.fit.result import FitResult
from identify.fit.status import OK
from identify.io.fitdir import FitDir
from identify.report import tables as T
from identify.report.curves import (
    X_LABEL,
    RelationCurves,
    camber_sweeps,
    group_key,
    levels,
    relation_curves,
    secondary_columns,
    sweep_rows,
)
from identify.report.layout import (
    GREY,
    MARKERS,
    ORANGE,
    PAGE,
    RED,
    STYLES,
    Page,
    draw_table,
    footer,
    new_page,
    pressure_colours,
    rows_fitting,
)


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
        ["Fz_N"] if q <= {"Fz", "My", "Re", "Rl"} else ["alpha_rad"]
    for col in prefer + sorted(spread, key=spread.get, reverse=True):
        if spread.get(col, 0) > 1:
            return "alpha_deg" if col == "alpha_rad" else col
    return "Fz_N"


def fit_pages(fd: FitDir, fit: FitResult) -> tuple[list[Page], str]:
    """The page(s) of one fit and a note on how its model lines were drawn."""
    rows = fd.rows(fit)
    is_mf = fit.relation == "MF"
    note = ""
    families: list[tuple[str, np.ndarray]] = []
    if len(rows) == 0:
        curves = None
        xcol = "Fz_N"
        note = f"{T.label(fit)}: no measured-vs-model rows"
    elif is_mf:
        xcol = _mf_x(rows)
        families = mf_families(rows, xcol)
        if len(families) == 1:  # one kind of sweep: drawn against what it sweeps
            xcol = families[0][0]
        curves = _joined(rows, xcol)
    else:
        rc = relation_curves(fd, fit, rows)
        curves, xcol = rc, rc.x_column
        if not rc.exact:
            note = f"{T.label(fit)}: {rc.note}"
    status = "converged" if fit.converged else f"NOT CONVERGED: {fit.message}"
    keys = fd.run.tir_keys(fit)
    sub = (f"total thesis error {T.fmt_pct(fit.error_total_pct)} %, "
           f"{fit.n_points} points, objective {fit.objective}, {status}, "
           f"{fit.starts_at_best}/{fit.n_starts} starts at the best value"
           + (f"; supplies {_keys_text(keys)} to the .tir" if keys else "; not used in the .tir"))
    choice = fd.run.form_choice(fit.relation)
    if choice is not None and fit.form in (choice.simpler, choice.richer):
        sub += (f". Form {'chosen' if fit.form == choice.form else 'not chosen'} "
                f"({'--form' if choice.overridden else 'by the data'}): {choice.reason}")
    if math.isfinite(fit.noise_floor_pct):
        sub += (f"; noise floor {T.fmt_pct(fit.noise_floor_pct)} % ({fit.floor_source}, "
                f"error {fit.error_total_pct / fit.noise_floor_pct:.3g} x floor)"
                if fit.noise_floor_pct > 0 else "")
    if fit.converged and fit.status_text != OK:
        sub += f". {fit.status_text.upper()}: {'; '.join(fit.reasons)}"
    fig = new_page(f"MF stage {fit.form}" if is_mf else f"Relation {T.label(fit)}", sub)
    unit = _unit(rows)
    quantity = str(rows["quantity"].iloc[0]) if len(rows) else fit.relation
    pcol = pressure_colours(rows["pi_bar"]) if len(rows) else {}
    if len(families) > 1:  # one panel per swept variable: every point against its own sweep
        n = len(families)
        for i, (fx, sel) in enumerate(families):
            w, rw = 0.39 / n, 0.40 / n
            ax = fig.add_axes((0.09 + i * w, 0.47, w - 0.035, 0.37))
            rax = fig.add_axes((0.56 + i * rw, 0.47, rw - 0.035, 0.37))
            part = rows[sel].reset_index(drop=True)
            _plot_fit(ax, rax, part, _joined(part, fx), fx, pcol, quantity, unit,
                      pressures=i == 0, title=f"{_SWEEP_NAME[fx]} ({int(sel.sum())} points)")
            if i:  # the first panel of each row names the quantity
                ax.set_ylabel("")
                rax.set_ylabel("")
    else:
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
    fixed = fit.fixed
    if fixed:
        text = "held fixed: " + ", ".join(f"{k}={T.fmt(v)}" for k, v in fixed.items())
        fig.text(0.27, 0.05, text[:200] + (" ..." if len(text) > 200 else ""), fontsize=7,
                 color=GREY)
    extra = []
    if fit.active_constraints:
        extra.append("active constraints: " + "; ".join(fit.active_constraints))
    if note:
        extra.append(note.split(": ", 1)[-1] if is_mf else note)
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
    """[lo, hi]; "none" when both are open (infinite or unknown)."""
    if not math.isfinite(lo) and not math.isfinite(hi):
        return "none"
    a = T.fmt(lo, 3) if math.isfinite(lo) else "-inf"
    b = T.fmt(hi, 3) if math.isfinite(hi) else "inf"
    return f"[{a}, {b}]"


_LS = re.compile(r"LS \+/-([0-9.eE+-]+) s\.e\.")
_SUFFIX = re.compile(r"(.*?)( \([^()]*\))")


def interval_title(kinds: Sequence[str]) -> str:
    """The kinds of 95 % interval of a parameter table in one short phrase: the
    least-squares ones merged into one entry with the range of their quantiles
    (``LS +/-2.11-2.19 s.e.``), a covariance they all share named once at the end
    (``LS +/-2.11-2.19 s.e., LS profile (staged sweep jackknife)``)."""
    split = []
    for kind in dict.fromkeys(kinds):
        m = _SUFFIX.fullmatch(kind)
        split.append((m.group(1), m.group(2)) if m else (kind, ""))
    suffixes = {suffix for _, suffix in split}
    shared = suffixes.pop() if len(suffixes) == 1 else ""
    quantiles: dict[str, list[float]] = {}
    other: list[str] = []
    for base, suffix in split:
        tail = "" if shared else suffix
        m = _LS.fullmatch(base)
        if m:
            quantiles.setdefault(tail, []).append(float(m.group(1)))
        elif base + tail not in other:
            other.append(base + tail)
    parts = []
    for tail, q in quantiles.items():
        lo, hi = f"{min(q):.3g}", f"{max(q):.3g}"
        parts.append(f"LS +/-{lo if lo == hi else lo + '-' + hi} s.e.{tail}")
    return ", ".join(sorted(parts) + sorted(other)) + shared


def interval_digits(lo: float, hi: float, digits: int = 4, most: int = 10) -> int:
    """Significant digits that tell the ends of an interval apart (``digits`` at least,
    ``most`` at most): a narrow interval of a large value needs more than four."""
    while digits < most and lo != hi and T.fmt(lo, digits) == T.fmt(hi, digits):
        digits += 1
    return digits


def _param_table(ax, prow, fit, more: int = 0) -> None:
    title = "Free parameters, 95 % interval: " + interval_title([r.interval for r in prow])
    if more:
        title += f" (+{more} on the next page)"
    table = [[r.name, T.fmt(r.value, max(6, interval_digits(r.lo95, r.hi95))),
              T.fmt(r.stderr, 3), T.fmt(r.lo95, interval_digits(r.lo95, r.hi95)),
              T.fmt(r.hi95, interval_digits(r.lo95, r.hi95)), _bounds_text(r.lower, r.upper),
              ("ARB. BOUND" if r.bound_kind != "physical" else "phys. bound") if r.at_bound
              else "not ident." if r.unidentified else "",
              "yes" if r.in_tir else ""] for r in prow]
    draw_table(ax, ["parameter", "value", "std. error", "95 % low", "95 % high", "bounds",
                    "flag", ".tir"], table,
               [0.16, 0.14, 0.11, 0.12, 0.12, 0.21, 0.09, 0.05], fontsize=7.5, title=title,
               colours=[RED if (r.at_bound and r.bound_kind != "physical") or r.unidentified
                        else ORANGE if r.at_bound else "black" for r in prow],
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
"""Above this many levels of one secondary condition (loads, cambers, speeds) the levels are
not told apart by marker and line style (an MF stage can hold dozens of sweeps): one marker,
thin lines. With two conditions, markers tell the first apart (up to len(MARKERS) levels) and
line styles the second (up to len(STYLES)), one legend entry per level of each."""


def _level_styles(keys: list[tuple], sec: list[str]):
    """(styled, style of each level key -> (marker, line style, hollow), legend entries
    [(label, marker, line style, hollow)]): one legend entry per level of each condition."""
    levels_sorted = sorted(set(keys))
    per = [sorted({k[i][1] for k in levels_sorted}) for i in range(len(sec))]
    if len(sec) == 1 and len(per[0]) <= MAX_STYLED_LEVELS:
        style = {k: (MARKERS[j % len(MARKERS)], STYLES[j % len(STYLES)], j > 0)
                 for j, k in enumerate(levels_sorted)}
        legend = [(f"{_cond_name(sec[0])} {_cond_value(sec[0], k[0][1]):.4g}", *style[k])
                  for k in levels_sorted]
        return True, style, legend if len(levels_sorted) > 1 else []
    if len(sec) == 2 and len(per[0]) <= len(MARKERS) and len(per[1]) <= len(STYLES):
        style = {k: (MARKERS[per[0].index(k[0][1])], STYLES[per[1].index(k[1][1])],
                     per[0].index(k[0][1]) > 0) for k in levels_sorted}
        legend = [(f"{_cond_name(sec[0])} {_cond_value(sec[0], v):.4g}", MARKERS[i], "none",
                    i > 0) for i, v in enumerate(per[0])]
        legend += [(f"{_cond_name(sec[1])} {_cond_value(sec[1], v):.4g}", "none", STYLES[i],
                    False) for i, v in enumerate(per[1])]
        return True, style, legend
    return False, {k: ("o", "-", False) for k in levels_sorted}, []


_SWEEP_NAME = {"alpha_deg": "slip-angle sweeps", "kappa": "slip-ratio sweeps",
               "gamma_deg": "camber sweeps", "Fz_N": "load"}
_SLIP_LEVELS = {"alpha_rad": np.deg2rad(0.5), "kappa": 0.02}
"""Resolution of slip angle [rad] and slip ratio [-] held as a condition (a level) while the
other one is swept."""


def mf_families(rows: pd.DataFrame, xcol: str) -> list[tuple[str, np.ndarray]]:
    """The points of an MF stage by the variable their sweep runs over: (x column, rows),
    the page's x first. Camber sweeps at a fixed slip angle go against camber, slip-ratio
    sweeps at a fixed slip angle against kappa, the rest against slip angle; a stage drawn
    against load (My, the geometry) keeps every point in one panel. Every point is in one
    family, so every point is drawn."""
    n = len(rows)
    if n == 0 or xcol == "Fz_N":
        return [(xcol, np.ones(n, bool))]
    gamma = camber_sweeps(rows)
    kappa = sweep_rows(rows, "alpha_rad", "kappa", 0.02, np.deg2rad(0.05)) & ~gamma
    alpha = ~(gamma | kappa)
    fams = [(c, m) for c, m in (("alpha_deg", alpha), ("kappa", kappa), ("gamma_deg", gamma))
            if m.any()]
    fams.sort(key=lambda f: f[0] != xcol)
    return fams or [(xcol, np.ones(n, bool))]


def _slip_conditions(rows: pd.DataFrame, xcol: str) -> list[str]:
    """The slip held as a condition while the other is swept: slip angle for a slip-ratio
    sweep, slip ratio for a slip-angle sweep, when it takes more than one level."""
    out = []
    for col, res in _SLIP_LEVELS.items():
        if col in rows and col != {"alpha_deg": "alpha_rad"}.get(xcol, xcol) \
                and xcol in ("alpha_deg", "kappa", "gamma_deg"):
            lv = levels(rows[col].to_numpy(float), res)
            if np.unique(lv[np.isfinite(lv)]).size > 1:
                out.append(col)
    return out


def _plot_fit(ax, rax, rows, curves, xcol, pcol, quantity, unit, pressures: bool = True,
              title: str = "") -> None:
    """Measured markers and model lines (``ax``), residuals (``rax``); the legend names the
    pressures (unless ``pressures`` is False: another panel of the page names them) and the
    levels of the conditions held."""
    x = _x_values(rows, xcol)
    meas = rows["measured"].to_numpy(float)
    model = rows["model"].to_numpy(float)
    pis = np.round(rows["pi_bar"].to_numpy(float), 4)
    sec = secondary_columns(rows, xcol if xcol != "alpha_deg" else "alpha_rad")
    if not isinstance(curves, RelationCurves):  # MF: the other slip, held, is a condition too
        sec += _slip_conditions(rows, xcol)
    keys = group_key(rows, sec)
    levels = sorted(set(keys))
    level_of = {k: j for j, k in enumerate(levels)}
    idx = np.array([level_of[k] for k in keys], dtype=int)
    styled, style_of, legend = _level_styles(keys, sec)
    many = len(rows) > 400
    ms = 2.0 if many else 4.5
    for p in sorted(set(pis)):
        c = pcol.get(round(float(p), 4), "black")
        for j in range(len(levels)):
            sel = (pis == p) & (idx == j)
            if not sel.any():
                continue
            mk, _, hollow = style_of[levels[j]]
            ax.plot(x[sel], meas[sel], mk, color=c, ms=ms, mfc="none" if hollow else c,
                    mew=0.8, ls="none", alpha=0.5 if many else 1.0)
            rax.plot(x[sel], model[sel] - meas[sel], mk, color=c, ms=ms * 0.9, ls="none",
                     mfc="none" if hollow else c, alpha=0.5 if many else 1.0)
    if isinstance(curves, RelationCurves):
        for cv in curves.curves:
            c = pcol.get(round(cv.pi_bar, 4), "black") if math.isfinite(cv.pi_bar) else "black"
            ls = style_of.get(cv.group, ("o", "-", False))[1]
            ax.plot(cv.x, cv.y, ls, color=c, lw=1.3)
    else:  # joined model values per pressure and secondary level, sorted by x
        for p in sorted(set(pis)):
            for j in range(len(levels)):
                sel = (pis == p) & (idx == j)
                if sel.sum() < 2:
                    continue
                o = np.argsort(x[sel], kind="stable")
                ax.plot(x[sel][o], model[sel][o], style_of[levels[j]][1],
                        color=pcol.get(round(float(p), 4), "black"), lw=1.0 if styled else 0.6)
    ax.set_xlabel(X_LABEL.get(xcol, xcol))
    ax.set_ylabel(f"{quantity} [{unit}]" if unit else quantity)
    given = bool(title)
    title = title or "measured (markers) and model (lines)"
    if len(levels) > 1 and not styled and not given:
        title += f": one line per {', '.join(_cond_name(c) for c in sec)} level " \
                 f"({len(levels)} levels)"
    ax.set_title(title, fontsize=7 if given else 8 if len(title) > 50 else 9)
    ax.grid(alpha=0.3)
    rax.axhline(0, color="black", lw=0.8)
    rax.set_xlabel(X_LABEL.get(xcol, xcol))
    rax.set_ylabel(f"model - measured [{unit}]" if unit else "model - measured")
    rax.set_title("residuals", fontsize=7 if given else 9)
    rax.grid(alpha=0.3)
    handles = [Line2D([], [], color=c, marker="o", ls="-", label=f"{p:g} bar")
               for p, c in pcol.items()] if pressures else []
    for text, mk, ls, hollow in legend:
        handles.append(Line2D([], [], color="black", marker=None if mk == "none" else mk,
                              mfc="none" if hollow else "black", ls=ls, label=text))
    if handles:
        ax.legend(handles=handles, fontsize=5.5 if given else 6.5, loc="best",
                  ncol=2 if len(handles) > 6 else 1)


def _cond_name(col: str) -> str:
    return {"Fz_N": "Fz [N]", "gamma_deg": "gamma [deg]", "Vx_mps": "Vx [m/s]",
            "alpha_rad": "alpha [deg]", "kappa": "kappa"}.get(col, col)


def _cond_value(col: str, value: float) -> float:
    """A condition level as its legend shows it (slip angle in degrees)."""
    return float(np.rad2deg(value)) if col == "alpha_rad" else value

