"""The MF slip pages: Fy-alpha, Fx-kappa, Mz-alpha, Mx-gamma and the friction ellipse.

The curves are the written .tir evaluated with ``identify.model.evaluate`` over the slip,
camber and load ranges of the MF rows of measured_vs_model.csv; the measured points of the MF
stages near pure slip are drawn over them (not the camber sweeps at a fixed slip angle, nor the
slip sweeps at a fixed camber, which would stand as vertical bars). The friction ellipse is
drawn at the measured combined slip angles, each with its own sign and over the slip ratios
measured at it only (nothing is drawn where nothing was measured), with the measured combined
points (Fx and Fy of one operating point) as markers; without any, it is left out. One panel
per pressure, one colour per load (one legend entry each), one y-scale across the panels of a
page.
"""
from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import pandas as pd
from matplotlib.lines import Line2D

from identify.io.fitdir import FitDir
from identify.model.evaluate import evaluate
from identify.model.modes import FIT_MODE
from identify.report.curves import N_DENSE, camber_sweeps, levels, slip_sweeps
from identify.report.layout import STYLES, Page, footer, load_colours, new_page
from identify.report.tables import num


@dataclass(frozen=True)
class SlipPanel:
    """One pressure's panel of an MF slip page: model curves and measured points per load."""

    pi_bar: float
    loads: tuple[float, ...]
    curves: tuple[tuple[np.ndarray, np.ndarray], ...]     # per load (x, y); the ellipse:
    #                                         per load, sign of alpha and slip angle (Fx, Fy)
    points: tuple[tuple[np.ndarray, np.ndarray], ...]     # per load (x, y), may be empty


@dataclass(frozen=True)
class SlipPage:
    title: str
    xlabel: str
    ylabel: str
    panels: tuple[SlipPanel, ...]
    note: str = ""
    ellipse: bool = False
    alphas_deg: tuple[float, ...] = ()


PURE_KAPPA = 0.005
PURE_ALPHA = np.deg2rad(0.5)
PURE_GAMMA_DEG = 0.5


def _mf_levels(mf: pd.DataFrame, fnomin: float):
    pis = np.round(mf["pi_bar"].to_numpy(float), 2)
    tol = 0.05 * (fnomin if math.isfinite(fnomin) and fnomin > 0 else 4000.0)
    loads = levels(mf["Fz_N"].to_numpy(float), tol)
    return pis, loads


def _pick_loads(levels: np.ndarray, limit: int = 5) -> list[float]:
    u = np.unique(levels[np.isfinite(levels)])
    if u.size <= limit:
        return [float(v) for v in u]
    idx = np.unique(np.round(np.linspace(0, u.size - 1, limit)).astype(int))
    return [float(u[i]) for i in idx]


def mf_slip_pages(fd: FitDir) -> tuple[list[SlipPage], list[str]]:
    """The MF slip pages (Fy-alpha, Fx-kappa, Mz-alpha, Mx-gamma, friction ellipse) and notes
    on pages left out. Empty when the fit has no MF rows or no readable .tir."""
    mf = fd.mf_rows()
    notes: list[str] = []
    if mf.empty:
        return [], notes
    if fd.tir is None:
        return [], ["MF slip pages left out: the .tir could not be read"]
    P = dict(fd.tir)
    fnomin = num(P.get("FNOMIN", fd.nominal_load_N))
    pis, loads = _mf_levels(mf, fnomin)
    q = mf["quantity"].astype(str).to_numpy()
    alpha = mf["alpha_rad"].to_numpy(float)
    kappa = mf["kappa"].to_numpy(float)
    gamma = mf["gamma_deg"].to_numpy(float)
    vx_all = mf["Vx_mps"].to_numpy(float)
    vx = float(np.nanmedian(vx_all)) if np.isfinite(vx_all).any() else 16.7
    pressures = sorted({float(p) for p in pis[np.isfinite(pis)]})
    load_levels = _pick_loads(loads)

    def rng(values, sel, default):
        v = values[sel & np.isfinite(values)]
        if v.size < 2 or np.ptp(v) <= 0:
            return default
        return float(v.min()), float(v.max())

    def model(p_bar, fz, k, a, g_deg, out):
        n = np.size(k) if np.ndim(k) else np.size(a) if np.ndim(a) else np.size(g_deg)
        arr = (lambda v: np.broadcast_to(np.asarray(v, dtype=float), (n,)).copy())
        with np.errstate(all="ignore"):
            res = evaluate(P, arr(fz), arr(k), arr(a), np.deg2rad(arr(g_deg)), arr(vx),
                           p=arr(p_bar * 1e5), mode=FIT_MODE)
        return {o: np.asarray(res[o], dtype=float) for o in out}

    def page(title, quantity, xname, xlabel, ylabel, xrange, pure, to_x):
        sel_q = q == quantity
        panels = []
        for p in pressures:
            curves, points = [], []
            for fz in load_levels:
                grid = np.linspace(*xrange, N_DENSE)
                kw = {"k": 0.0, "a": 0.0, "g_deg": 0.0}
                kw[xname] = grid
                y = model(p, fz, kw["k"], kw["a"], kw["g_deg"], (quantity,))[quantity]
                curves.append((to_x(grid), y))
                sel = sel_q & (pis == round(p, 2)) & (loads == fz) & pure
                meas = mf["measured"].to_numpy(float)[sel]
                xs = {"k": kappa, "a": alpha, "g_deg": gamma}[xname][sel]
                points.append((to_x(xs), meas))
            panels.append(SlipPanel(p, tuple(load_levels), tuple(curves), tuple(points)))
        return SlipPage(title, xlabel, ylabel, tuple(panels))

    small_k = np.nan_to_num(np.abs(kappa), nan=0.0) <= PURE_KAPPA
    small_a = np.nan_to_num(np.abs(alpha), nan=0.0) <= PURE_ALPHA
    small_g = np.nan_to_num(np.abs(gamma), nan=0.0) <= PURE_GAMMA_DEG
    not_camber_sweep = ~camber_sweeps(mf)   # vertical bars against slip angle
    not_slip_sweep = ~slip_sweeps(mf)       # vertical bars against camber
    pages = []
    a_rng = rng(alpha, np.isin(q, ("Fy", "Mz")), None)
    k_rng = rng(kappa, q == "Fx", None)
    g_rng = rng(gamma, np.ones(q.size, bool), None)
    if a_rng is not None:
        pages.append(page("Fy - alpha (pure side slip, kappa = 0, gamma = 0)", "Fy", "a",
                          "slip angle [deg]", "Fy [N]", a_rng,
                          small_k & small_g & not_camber_sweep, np.rad2deg))
    else:
        notes.append("Fy-alpha and Mz-alpha pages left out: the MF rows hold no slip-angle "
                     "range")
    if k_rng is not None:
        pages.append(page("Fx - kappa (pure longitudinal slip, alpha = 0, gamma = 0)", "Fx",
                          "k", "longitudinal slip kappa [-]", "Fx [N]", k_rng,
                          small_a & small_g, lambda v: v))
    else:
        notes.append("Fx-kappa page left out: the MF rows hold no longitudinal-slip range")
    if a_rng is not None:
        pages.append(page("Mz - alpha (pure side slip, kappa = 0, gamma = 0)", "Mz", "a",
                          "slip angle [deg]", "Mz [N m]", a_rng,
                          small_k & small_g & not_camber_sweep, np.rad2deg))
    if g_rng is not None and g_rng[1] - g_rng[0] >= 2 * PURE_GAMMA_DEG:
        pages.append(page("Mx - gamma (alpha = 0, kappa = 0)", "Mx", "g_deg",
                          "camber angle [deg]", "Mx [N m]", g_rng,
                          small_k & small_a & not_slip_sweep, lambda v: v))
    else:
        notes.append("Mx-gamma page left out: the MF rows hold no camber range")
    if a_rng is not None and k_rng is not None:
        combined = _combined_pairs(mf, pis, loads)
        measured = (np.unique(np.round(combined["alpha_deg"].to_numpy(float), 1))
                    if len(combined) else np.empty(0))
        if measured.size == 0:
            notes.append("friction-ellipse page left out: no combined-slip point (Fx and Fy "
                         "of one operating point at a non-zero slip angle and slip ratio) was "
                         "measured")
            return pages, notes
        if measured.size > len(STYLES):  # as many as the line styles tell apart, spread out
            idx = np.unique(np.round(np.linspace(0, measured.size - 1, len(STYLES))))
            measured = measured[idx.astype(int)]
        alphas = tuple(float(a) for a in measured)
        alpha_of = np.round(combined["alpha_deg"].to_numpy(float), 1)
        kappa_of = combined["kappa"].to_numpy(float)
        panels = []
        for p in pressures:
            curves, points = [], []
            for fz in load_levels:
                for a_deg in alphas:
                    # the slip ratios measured at this slip angle: nothing drawn beyond them
                    span = kappa_of[alpha_of == round(a_deg, 1)]
                    grid = np.linspace(float(span.min()), float(span.max()), N_DENSE)
                    r = model(p, fz, grid, np.deg2rad(a_deg), 0.0, ("Fx", "Fy"))
                    curves.append((r["Fx"], r["Fy"]))
                sel = (combined["pi_bar"] == round(p, 2)) & (combined["Fz_level"] == fz)
                points.append((combined["Fx"].to_numpy(float)[sel],
                               combined["Fy"].to_numpy(float)[sel]))
            panels.append(SlipPanel(p, tuple(load_levels), tuple(curves), tuple(points)))
        pages.append(SlipPage("Friction ellipse (combined slip: Fy vs Fx, kappa swept at "
                              "fixed slip angles)", "Fx [N]", "Fy [N]", tuple(panels),
                              ellipse=True, alphas_deg=alphas,
                              note="model at the measured slip angles over the slip ratios "
                                   "measured at each"))
    return pages, notes


def _combined_pairs(mf: pd.DataFrame, pis: np.ndarray, loads: np.ndarray) -> pd.DataFrame:
    """Measured (Fx, Fy) of the same combined-slip operating points (the MF rows of the Fx and
    Fy quantities at |alpha| > 0 and |kappa| > 0, joined on the operating point)."""
    cols = ["pi_bar", "Fz_N", "alpha_rad", "kappa", "gamma_deg", "Vx_mps"]
    frame = mf.assign(pi_bar=pis, Fz_level=loads)
    a = np.nan_to_num(np.abs(frame["alpha_rad"].to_numpy(float)))
    k = np.nan_to_num(np.abs(frame["kappa"].to_numpy(float)))
    frame = frame[(a > PURE_ALPHA) & (k > PURE_KAPPA)]
    q = frame["quantity"].astype(str)
    keys = cols + ["Fz_level"]
    fx = frame[q == "Fx"].drop_duplicates(keys)[keys + ["measured"]]
    fy = frame[q == "Fy"].drop_duplicates(keys)[keys + ["measured"]]
    both = fx.merge(fy, on=keys, suffixes=("_x", "_y"))
    return pd.DataFrame({"pi_bar": both["pi_bar"], "Fz_level": both["Fz_level"],
                         "alpha_deg": np.rad2deg(both["alpha_rad"].to_numpy(float)),
                         "kappa": both["kappa"],
                         "Fx": both["measured_x"], "Fy": both["measured_y"]})


# ----- pages ------------------------------------------------------------------------------------

def slip_pages(fd: FitDir, pages: Sequence[SlipPage]) -> list[Page]:
    """One page per MF slip page of :func:`identify.report.curves.mf_slip_pages`."""
    out = []
    for sp in pages:
        fig = new_page(f"MF: {sp.title}",
                       "model from the written .tir (identify.model.evaluate, useMode 211) "
                       + (sp.note or "over the measured range")
                       + "; measured points of the MF stages as markers;"
                       " one panel per pressure, one colour per load")
        n = len(sp.panels)
        ncol = n if n <= 3 else 3 if n != 4 else 2
        nrow = math.ceil(n / ncol) if n else 1
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
                    for m in range(na):
                        xs, ys = panel.curves[j * na + m]
                        ax.plot(xs, ys, STYLES[m % len(STYLES)], color=lcol[fz], lw=1.1)
                    if panel.points and panel.points[j][0].size:
                        px, py = panel.points[j]
                        ax.plot(px, py, "o", color=lcol[fz], ms=2.0, alpha=0.5, ls="none")
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
        _share_limits(axes, sp)
        if axes:
            handles = [Line2D([], [], color=c, lw=1.5, label=f"Fz {fz:.0f} N")
                       for fz, c in lcol.items()]
            if sp.ellipse:
                handles += [Line2D([], [], color="black", ls=STYLES[m % len(STYLES)],
                                   label=f"alpha {a:+.1f} deg")
                            for m, a in enumerate(sp.alphas_deg)]
                if any(pt[0].size for panel in sp.panels for pt in panel.points):
                    handles.append(Line2D([], [], color="black", marker="o", ls="none", ms=3,
                                          label="measured (combined slip)"))
            else:
                handles.append(Line2D([], [], color="black", marker="o", ls="none", ms=3,
                                      label="measured"))
            axes[0].legend(handles=handles, fontsize=6.5, loc="best")
        footer(fig, fd)
        out.append((f"MF {sp.title.split(' (')[0]}", fig))
    return out


def _share_limits(axes, sp: SlipPage) -> None:
    """One y-range (and for the ellipse one x-range, equal aspect) across the panels."""
    ys = [np.asarray(y, float) for panel in sp.panels for _, y in panel.curves]
    ys += [np.asarray(y, float) for panel in sp.panels for _, y in panel.points]
    xs = [np.asarray(x, float) for panel in sp.panels for x, _ in panel.curves]
    xs += [np.asarray(x, float) for panel in sp.panels for x, _ in panel.points]

    def span(arrays):
        v = np.concatenate([a[np.isfinite(a)] for a in arrays]) if arrays else np.empty(0)
        if v.size == 0:
            return None
        lo, hi = float(v.min()), float(v.max())
        pad = 0.05 * (hi - lo) if hi > lo else 1.0
        return lo - pad, hi + pad

    y, x = span(ys), span(xs)
    if sp.ellipse and x is not None and y is not None:
        lim = max(abs(v) for v in (*x, *y))
        x = y = (-lim, lim)
    for ax in axes:
        if y is not None:
            ax.set_ylim(*y)
        if sp.ellipse and x is not None:
            ax.set_xlim(*x)
            ax.set_aspect("equal", adjustable="box")


# ----- MCMC ------------------------------------------------------------------------------------
